"""The behaviour catalogue: every tag a tree file may use, with the ports and defaults users rely on."""

from __future__ import annotations

import py_trees

from mission.behaviours.ports import REQUIRED
from mission.core.types import Pose2D
from mission.trees.factory import shipped_factory
from mission.trees.manifest import BuildContext

# tag → (node type, {port: (type, default)}) — what tree files rely on (the docs' table shows the same)
CATALOGUE = {
    "PerceiveTargets": ("Action", {}),
    "IsTargetVisible": ("Condition", {"target": (str, "target"), "max_misses": (int, 0), "grace_s": (float, 0.0)}),
    "IsLineOfSightBlocked": (
        "Condition",
        {"target": (str, "target"), "min_misses": (int, 5), "target_radius_m": (float, 0.3)},
    ),
    "FollowTarget": (
        "Action",
        {
            "target": (str, "target"),
            "offset_m": (float, 0.5),
            "window": (int, 5),
            "rate_hz": (float, 10.0),
            "face_range_m": (float, 0.0),
        },
    ),
    "HoldLastGoal": ("Action", {"target": (str, "target"), "timeout_s": (float, 3.0), "offset_m": (float, 0.5)}),
    "SearchSweep": (
        "Action",
        {"target": (str, "target"), "duration_s": (float, 20.0), "angular_speed": (float, 0.6)},
    ),
    "PursueLastSeen": (
        "Action",
        {
            "target": (str, "target"),
            "horizon_s": (float, 2.0),
            "speed_mps": (float, 0.35),
            "look_s": (float, 1.0),
            "min_timeout_s": (float, 2.0),
            "max_timeout_s": (float, 12.0),
            "max_standoff_m": (float, 3.0),
            "clearance_m": (float, 0.35),
        },
    ),
    "TurnToBearing": (
        "Action",
        {
            "target": (str, "target"),
            "angular_speed": (float, 1.0),
            "overshoot_deg": (float, 30.0),
            "back_deg": (float, 180.0),
            "horizon_s": (float, 2.0),
        },
    ),
    "SearchBelief": (
        "Action",
        {
            "target": (str, "target"),
            "timeout_s": (float, 25.0),
            "target_speed_mps": (float, 1.0),
            "view_range_m": (float, 4.0),
            "min_mass": (float, 0.03),
            "speed_mps": (float, 0.35),
            "angular_speed": (float, 0.8),
            "sweep_deg": (float, 90.0),
            "spacing_m": (float, 0.4),
            "max_travel_m": (float, 8.0),
            "clearance_m": (float, 0.35),
            "replan_s": (float, 1.0),
        },
    ),
    "CoverUnseen": (
        "Action",
        {
            "target": (str, "target"),
            "timeout_s": (float, 40.0),
            "done_fraction": (float, 0.95),
            "speed_mps": (float, 0.35),
            "angular_speed": (float, 0.8),
            "sweep_deg": (float, 90.0),
            "spacing_m": (float, 0.4),
            "max_travel_m": (float, 12.0),
            "clearance_m": (float, 0.35),
            "replan_s": (float, 1.0),
        },
    ),
    "GiveUpSearch": ("Action", {"target": (str, "target")}),
    "RotateSearch": (
        "Action",
        {
            "target": (str, "target"),
            "angle_deg": (float, 90.0),
            "angular_speed": (float, 1.0),
            "angular_tolerance": (float, 0.15),
            "rounds": (int, 3),
            "timeout_s": (float, 10.0),
        },
    ),
    "Explore": (
        "Action",
        {"target": (str, "dock"), "waypoints": (str, ""), "angular_speed": (float, 0.5), "timeout_s": (float, 120.0)},
    ),
    "GoToStaging": ("Action", {"target": (str, "dock"), "offset_m": (float, 0.7), "timeout_s": (float, 40.0)}),
    "GoToPose": ("Action", {"pose": (Pose2D, REQUIRED), "timeout_s": (float, 0.0), "what": (str, "the goal")}),
    "DriveToPose": (
        "Action",
        {
            "pose": (Pose2D, REQUIRED),
            "backward": (bool, False),
            "max_v": (float, 0.15),
            "max_w": (float, 0.5),
            "linear_tolerance": (float, 0.05),
            "angular_tolerance": (float, 0.05),
            "timeout_s": (float, 0.0),
            "what": (str, "the goal"),
        },
    ),
    "WaitForTarget": ("Action", {"target": (str, "dock"), "timeout_s": (float, 5.0)}),
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
# tag → {output port: type}: what a tree can connect to the blackboard ({key}) to read in other nodes or scripts
OUTPUTS = {
    "IsTargetVisible": {"visible": bool, "last_seen_pose": Pose2D},
    "FollowTarget": {"goal": Pose2D},
    "HoldLastGoal": {"goal": Pose2D},
    "GoToStaging": {"dock_pose": Pose2D, "staging_pose": Pose2D},
}


def test_the_shipped_factory_registers_exactly_the_catalogue_with_its_ports_and_defaults():
    behaviours = {node.tag: node for node in shipped_factory().behaviours(deprecated=True)}
    assert set(behaviours) == set(CATALOGUE)
    for tag, (node_type, ports) in CATALOGUE.items():
        node = behaviours[tag]
        assert node.kind == node_type, tag
        assert {k: (p.type, p.default) for k, p in node.ports.items() if p.reads} == ports, tag
        assert {k: p.type for k, p in node.ports.items() if p.direction == "output"} == OUTPUTS.get(tag, {}), tag
        assert all(p.doc for p in node.ports.values()), f"{tag}: every port says what it means"
        assert node.doc, f"{tag}: says what it does"


def test_constructing_every_leaf_is_light_and_touches_no_blackboard_value():
    for node in shipped_factory().behaviours():
        value = {Pose2D: Pose2D(0.0, 0.0, 0.0), str: "DONE"}
        required = {n: value[p.type] for n, p in node.ports.items() if p.required}
        built = node.build(f"my {node.tag}", [], required, BuildContext())
        assert isinstance(built, py_trees.behaviour.Behaviour) and built.name == f"my {node.tag}"
    assert py_trees.blackboard.Blackboard.storage == {}
