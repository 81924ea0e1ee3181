"""The behaviour catalogue: every tag a tree file may use, with the ports and defaults users rely on."""

from __future__ import annotations

import inspect

import py_trees

from mission.behaviours.ports import REQUIRED
from mission.behaviours.registry import all_behaviours

# tag → (node type, {port: (type, default)}) — the table in the README / catalogue.md
CATALOGUE = {
    "PerceiveTargets": ("Action", {}),
    "IsTargetVisible": ("Condition", {"target": (str, "target"), "max_misses": (int, 0)}),
    "IsLineOfSightBlocked": ("Condition", {"target": (str, "target"), "min_misses": (int, 5)}),
    "FollowTarget": (
        "Action",
        {"target": (str, "target"), "offset_m": (float, 0.5), "window": (int, 5), "rate_hz": (float, 10.0)},
    ),
    "HoldLastGoal": ("Action", {"target": (str, "target"), "timeout_s": (float, 3.0), "offset_m": (float, 0.5)}),
    "SearchSweep": (
        "Action",
        {"target": (str, "target"), "duration_s": (float, 20.0), "angular_speed": (float, 0.6)},
    ),
    "Explore": (
        "Action",
        {"target": (str, "dock"), "waypoints": (str, ""), "angular_speed": (float, 0.5), "timeout_s": (float, 120.0)},
    ),
    "GoToStaging": ("Action", {"target": (str, "dock"), "offset_m": (float, 0.7), "timeout_s": (float, 40.0)}),
    "VisualServoDock": (
        "Action",
        {
            "target": (str, "dock"),
            "standoff_m": (float, 0.30),
            "lateral_tol_m": (float, 0.03),
            "distance_tol_m": (float, 0.025),
            "skew_tol_deg": (float, 10.0),
            "max_v": (float, 0.25),
            "max_w": (float, 0.75),
            "detection_timeout_s": (float, 1.0),
            "timeout_s": (float, 30.0),
        },
    ),
    "SetMissionState": ("Action", {"state": (str, REQUIRED)}),
}


def test_every_catalogue_tag_is_registered_with_its_ports_and_defaults():
    registry = all_behaviours()
    assert set(CATALOGUE) <= set(registry)
    for tag, (node_type, ports) in CATALOGUE.items():
        cls = registry[tag]
        assert node_type == cls.NODE_TYPE, tag
        assert {k: (p.type, p.default) for k, p in cls.PORTS.items()} == ports, tag
        assert all(p.doc for p in cls.PORTS.values()), f"{tag}: every port says what it means"


def test_constructors_take_exactly_the_ports_as_keywords_with_the_same_defaults():
    for tag, cls in all_behaviours().items():
        params = inspect.signature(cls.__init__).parameters
        keywords = {n: p for n, p in params.items() if p.kind is inspect.Parameter.KEYWORD_ONLY}
        assert set(keywords) - {"deps"} == set(cls.PORTS), tag
        for name, port in cls.PORTS.items():
            default = keywords[name].default
            assert (default is inspect.Parameter.empty) == port.required, (tag, name)
            if not port.required:
                assert default == port.default, (tag, name)


def test_constructing_every_leaf_is_light_and_touches_no_blackboard_value():
    for tag, cls in all_behaviours().items():
        required = {n: "DONE" for n, p in cls.PORTS.items() if p.required}
        node = cls(f"my {tag}", **required)
        assert isinstance(node, py_trees.behaviour.Behaviour) and node.name == f"my {tag}"
    assert py_trees.blackboard.Blackboard.storage == {}
