"""A behaviour declares each XML port once — a field of its frozen ``Params`` dataclass — and its
``PORTS``, its constructor and the checks on the values all come from that one declaration."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any

import py_trees
import pytest

from mission.behaviours.follow import FollowTarget
from mission.behaviours.mission_state import SetMissionState
from mission.behaviours.ports import REQUIRED, BlackboardRef, Port, PortsDeclared, port
from mission.core.types import Pose2D


class Camera(py_trees.behaviour.Behaviour, PortsDeclared):
    """A test-only leaf with a port of every kind."""

    @dataclass(frozen=True, kw_only=True)
    class Params:
        topic: str = port(doc="image topic")
        exposure_ms: float = port(8.0, "exposure time")
        binning: int = port(1, "pixels per output pixel")
        colour: bool = port(True, "BGR rather than mono")
        last_stamp: float = port(doc="stamp of the newest image", direction="output")
        frames: int = port("{frames}", "frames seen (into {frames} unless the tree says)", direction="output")

    def __init__(self, name: str = "Camera", **ports: Any) -> None:
        super().__init__(name)
        self.params = self.bind_params(ports)

    def update(self) -> py_trees.common.Status:
        self.feedback_message = f"watching {self.params.topic}"
        return py_trees.common.Status.RUNNING


def test_ports_are_the_params_fields_in_order_with_type_default_meaning_and_direction():
    assert dict(Camera.PORTS) == {
        "topic": Port(str, REQUIRED, "image topic"),
        "exposure_ms": Port(float, 8.0, "exposure time"),
        "binning": Port(int, 1, "pixels per output pixel"),
        "colour": Port(bool, True, "BGR rather than mono"),
        "last_stamp": Port(float, REQUIRED, "stamp of the newest image", "output"),
        "frames": Port(int, "{frames}", "frames seen (into {frames} unless the tree says)", "output"),
    }
    assert Camera.PORTS["topic"].required and not Camera.PORTS["binning"].required
    assert not Camera.PORTS["last_stamp"].required  # an output need not be connected


def test_a_shipped_behaviours_ports_are_exactly_its_params_fields():
    fields = dataclasses.fields(FollowTarget.Params)
    assert list(FollowTarget.PORTS) == [f.name for f in fields]
    inputs = [(p.default, f.default) for p, f in zip(FollowTarget.PORTS.values(), fields, strict=True) if p.reads]
    assert all(port_default == field_default for port_default, field_default in inputs)
    assert FollowTarget.PORTS["goal"].direction == "output" and FollowTarget.Params().goal is None


def test_the_constructor_takes_the_ports_as_keywords_and_keeps_the_checked_values():
    node = FollowTarget("follow", target="person", offset_m=1)
    assert node.name == "follow"
    assert node.params == FollowTarget.Params(target="person", offset_m=1.0, window=5, rate_hz=10.0)
    assert type(node.params.offset_m) is float  # an int is a fine float; it is stored as one
    assert FollowTarget().name == "FollowTarget"  # unnamed: the class name, as in a tree file
    with pytest.raises(dataclasses.FrozenInstanceError):
        node.params.offset_m = 2.0  # type: ignore[misc]


def test_an_unknown_keyword_is_a_type_error_naming_it_and_the_ports_there_are():
    with pytest.raises(TypeError) as err:
        FollowTarget(ofset_m=0.7)
    assert str(err.value) == (
        "FollowTarget: unknown port 'ofset_m' (did you mean offset_m?); "
        "FollowTarget ports: target, offset_m, window, rate_hz, face_range_m, goal"
    )


def test_a_missing_required_port_is_a_type_error_naming_it():
    with pytest.raises(TypeError) as err:
        SetMissionState()
    assert str(err.value).startswith("SetMissionState: missing required port state (str); one of EXPLORE, DOCK")


@pytest.mark.parametrize(
    ("ports", "message"),
    [
        ({"window": "5"}, "FollowTarget: port window expects int, got '5'"),
        ({"window": 2.5}, "FollowTarget: port window expects int, got 2.5"),
        ({"offset_m": True}, "FollowTarget: port offset_m expects float, got True"),
        ({"target": None}, "FollowTarget: port target expects str, got None"),
    ],
)
def test_a_value_of_the_wrong_type_is_a_type_error_naming_the_port(ports, message):
    with pytest.raises(TypeError) as err:
        FollowTarget(**ports)
    assert str(err.value) == message


def test_range_checks_live_in_the_declaration_so_every_way_in_gets_them():
    expected = r"expected window ≥ 1, rate_hz > 0, offset_m ≥ 0 \(got 0, 10.0, 0.5\)"
    with pytest.raises(ValueError, match=expected):
        FollowTarget(window=0)
    with pytest.raises(ValueError, match=expected):
        FollowTarget.Params(window=0)


def test_a_refused_constructor_call_leaves_nothing_on_the_blackboard():
    clients = dict(py_trees.blackboard.Blackboard.clients)
    with pytest.raises(TypeError):
        FollowTarget(ofset_m=0.7)
    assert py_trees.blackboard.Blackboard.clients == clients


def _declare(params: type) -> type:
    return type("Broken", (py_trees.behaviour.Behaviour, PortsDeclared), {"Params": params})


@dataclass(frozen=True, kw_only=True)
class _PlainField:
    gain: float = 1.0


@dataclass(kw_only=True)
class _Mutable:
    gain: float = port(1.0, "a gain")


@dataclass(frozen=True, kw_only=True)
class _TuplePort:
    points: tuple = port(doc="not a port type")  # type: ignore[type-arg]


@dataclass(frozen=True, kw_only=True)
class _IntDefaultForFloat:
    gain: float = port(1, "an int written where a float is declared")


class _NotADataclass:
    gain: float = 1.0


@pytest.mark.parametrize(
    ("params", "message"),
    [
        (_PlainField, "Broken.Params.gain: expected a port(default, doc) field"),
        (_Mutable, "Broken.Params: expected @dataclass(frozen=True, kw_only=True); port values never change"),
        (_TuplePort, "Broken.Params.points: type tuple is not a port type; expected str, int, float, bool or Pose2D"),
        (_IntDefaultForFloat, "Broken.Params.gain: default 1 is not float"),
        (_NotADataclass, "Broken.Params: expected a dataclass declaring the ports"),
    ],
    ids=["plain field", "not frozen", "unsupported type", "default of another type", "not a dataclass"],
)
def test_a_malformed_declaration_fails_when_the_class_is_defined(params, message):
    with pytest.raises(TypeError) as err:
        _declare(params)
    assert str(err.value).startswith(message)


def test_an_output_port_is_not_a_constructor_argument_and_set_output_writes_where_it_is_connected():
    camera = Camera(topic="/image")
    assert camera.params.last_stamp is None  # outputs hold no value in Params
    with pytest.raises(TypeError, match="Camera: last_stamp is an output port: the node writes it"):
        Camera(topic="/image", last_stamp=1.0)
    assert camera.set_output("last_stamp", 2.5) is False  # not connected: nothing written
    written: dict[str, object] = {}
    camera.port_sink = lambda name, value: written.setdefault(name, value) is value
    camera.connected_outputs = frozenset({"last_stamp"})  # what the loader sets with the sink
    assert camera.set_output("last_stamp", 2.5) is True
    assert written == {"last_stamp": 2.5}
    with pytest.raises(TypeError, match="Camera: port last_stamp expects float, got 'late'"):
        camera.set_output("last_stamp", "late")
    with pytest.raises(ValueError, match="topic is not an output port; outputs: last_stamp, frames"):
        camera.set_output("topic", "/other")


def test_a_port_read_from_the_blackboard_waits_for_its_value_before_the_checks_run():
    pending = BlackboardRef("w", "/tree/w")
    node = FollowTarget(window=pending)  # the checks (window ≥ 1) wait for the real value
    assert node.params.window == 5  # the default until the first tick reads the entry
    required = SetMissionState(state=BlackboardRef("s", "/tree/s"))
    assert required.params.state is REQUIRED


@pytest.mark.parametrize(
    ("kind", "value", "expected"),
    [
        (int, 3.0, 3),
        (int, "4", 4),
        (float, 2, 2.0),
        (bool, 1, True),
        (bool, "false", False),
        (str, 2.5, "2.500000"),
        (str, 7, "7"),
        (Pose2D, "1;2;0.5", Pose2D(1.0, 2.0, 0.5)),
    ],
)
def test_a_blackboard_value_is_converted_to_the_port_type_as_bt_cpp_converts_it(kind, value, expected):
    assert Port(kind).coerce(value) == expected


@pytest.mark.parametrize(("kind", "value"), [(int, 2.5), (bool, 2), (float, "fast"), (Pose2D, "1;2")])
def test_a_blackboard_value_that_does_not_fit_the_port_says_what_was_expected(kind, value):
    with pytest.raises(ValueError):
        Port(kind).coerce(value)


class Copy(py_trees.behaviour.Behaviour, PortsDeclared):
    """BT.CPP's CopyPorts: ports named like Python keywords (``in``, ``from``)."""

    @dataclass(frozen=True, kw_only=True)
    class Params:
        in_: str = port(doc="copied from")
        from_: int = port(0, "a keyword with a default")

    def __init__(self, name: str, **ports: Any) -> None:
        super().__init__(name)
        self.params = self.bind_params(ports)

    def update(self) -> py_trees.common.Status:
        return py_trees.common.Status.SUCCESS


def test_a_port_named_like_a_python_keyword_is_declared_with_a_trailing_underscore():
    assert list(Copy.PORTS) == ["in", "from"]
    node = Copy("copy", **{"in": "hello"})
    assert node.params.in_ == "hello" and node.params.from_ == 0
    with pytest.raises(TypeError, match="in_x"):
        Copy("copy", **{"in": "x", "in_x": 1})
