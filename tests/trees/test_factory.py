"""The tree factory: a tree file may use the BT.CPP built-ins and the behaviours registered on the factory
it is loaded with — explicitly, each with the constructor arguments (dependencies) given at registration,
as BehaviorTree.CPP's ``registerNodeType<T>(ID, args...)``. Nothing is discovered or global."""

from __future__ import annotations

import dataclasses
from pathlib import Path
from xml.etree import ElementTree

import py_trees
import pytest

from mission.behaviours.dock import VisualServoDock
from mission.behaviours.explore import Explore
from mission.behaviours.follow import FollowTarget
from mission.behaviours.leaf import MissionLeaf
from mission.core.errors import TreeError
from mission.trees.builtins import BUILTINS
from mission.trees.factory import BehaviourFactory, shipped_factory
from mission.trees.loader import load_tree, validate_tree
from mission.trees.tree_nodes_model import GROOT_TYPES, format_default, nodes_model_xml

BUILTIN_LIST = ", ".join(BUILTINS)


def tree_file(tmp_path: Path, node: str) -> Path:
    path = tmp_path / "t.xml"
    path.write_text(f'<root BTCPP_format="4">\n  <BehaviorTree ID="T">\n    {node}\n  </BehaviorTree>\n</root>\n')
    return path


def follow_only() -> BehaviourFactory:
    factory = BehaviourFactory()
    factory.register(FollowTarget)
    return factory


# ------------------------------------------------------------------------------------ what it knows
def test_a_new_factory_knows_the_bt_cpp_builtins_and_no_behaviour():
    factory = BehaviourFactory()
    assert [m.tag for m in factory.builtins()] == list(BUILTINS)
    assert factory.behaviours() == []
    assert factory.manifest("FollowTarget") is None


def test_a_tree_using_a_tag_not_registered_in_its_factory_is_an_error_naming_it(tmp_path):
    path = tree_file(tmp_path, "<Sequence><FollowTarget/><Explore/></Sequence>")  # Explore ships, but not here
    with pytest.raises(TreeError) as err:
        validate_tree(path, follow_only())
    assert str(err.value) == (
        f"{path.resolve()}:3: <Explore>: unknown node 'Explore'; "
        f"expected a registered behaviour (FollowTarget) or a built-in ({BUILTIN_LIST}, SubTree)"
    )
    load_tree(path, shipped_factory())  # the same file with every shipped behaviour registered


def test_a_registration_is_the_declaration_of_the_class():
    manifest = follow_only().manifest("FollowTarget")
    assert manifest is not None
    assert manifest.kind == FollowTarget.NODE_TYPE == "Action"
    assert manifest.ports is FollowTarget.PORTS
    assert manifest.doc == "FOLLOW: keep sending a smoothed approach goal behind the target; always RUNNING."


def test_each_shipped_factory_is_its_own_object():
    mine = shipped_factory()
    mine.register(FollowTarget, "Chase")
    assert mine.manifest("Chase") is not None
    assert shipped_factory().manifest("Chase") is None  # no registry shared behind the scenes


# ------------------------------------------------------------------------------ registering
def test_registering_the_same_tag_twice_is_an_error():
    factory = follow_only()
    with pytest.raises(ValueError, match=r"^tag 'FollowTarget' is already registered; each tag names one node type"):
        factory.register(FollowTarget)
    with pytest.raises(ValueError, match="tag 'FollowTarget' is already registered"):
        factory.register(Explore, "FollowTarget")
    factory.register(FollowTarget, "Chase")  # one class under a second tag is a second node type


@pytest.mark.parametrize(
    ("tag", "message"),
    [
        ("Sequence", "tag 'Sequence' is a BT.CPP built-in; each tag names one node type"),
        ("SubTree", "tag 'SubTree' is part of the tree file format; register FollowTarget under another tag"),
        ("BehaviorTree", "tag 'BehaviorTree' is part of the tree file format"),
    ],
)
def test_a_builtin_or_file_format_tag_cannot_be_registered(tag, message):
    with pytest.raises(ValueError, match=f"^{message}"):
        BehaviourFactory().register(FollowTarget, tag)


def test_registration_arguments_reach_every_instance_of_that_registration(tmp_path):
    class Beacon(MissionLeaf):
        """Reports through the radio it was registered with."""

        def __init__(self, name: str | None = None, *, radio: object, **ports: object) -> None:
            super().__init__(name, **ports)
            self.radio = radio

        def update(self) -> py_trees.common.Status:
            self.feedback_message = "beaconing"
            return py_trees.common.Status.SUCCESS

    front, back = object(), object()
    factory = BehaviourFactory()
    factory.register(Beacon, radio=front)
    factory.register(Beacon, "RearBeacon", radio=back)
    path = tree_file(tmp_path, "<Parallel><Beacon/><Beacon/><RearBeacon/></Parallel>")
    one, two, rear = load_tree(path, factory).children
    assert one.radio is front and two.radio is front
    assert rear.radio is back


def test_a_registration_argument_cannot_be_a_port_or_what_the_loader_passes():
    with pytest.raises(ValueError, match=r"^FollowTarget: offset_m cannot be a registration argument"):
        BehaviourFactory().register(FollowTarget, offset_m=0.7)  # ports come from the tree file
    with pytest.raises(ValueError, match=r"^FollowTarget: name cannot be a registration argument"):
        BehaviourFactory().register(FollowTarget, name="follow")


def test_only_a_behaviour_class_declaring_its_ports_can_be_registered():
    with pytest.raises(TypeError, match="expected a py_trees Behaviour class declaring its ports"):
        BehaviourFactory().register(py_trees.behaviours.Success)  # type: ignore[arg-type]


# ------------------------------------------------------------- one declaration, every consumer
def test_the_loader_checks_a_port_value_as_the_declaration_does_before_anything_is_built(tmp_path):
    path = tree_file(tmp_path, '<Sequence><FollowTarget window="0"/><Explore waypoints="1,2;3"/></Sequence>')
    with pytest.raises(TreeError) as err:
        validate_tree(path)  # nothing is built by validating: these are the Params' own checks
    assert err.value.problems == [  # type: ignore[attr-defined]
        f"{path.resolve()}:3: <FollowTarget>: expected window ≥ 1, rate_hz > 0, offset_m ≥ 0 (got 0, 10.0, 0.5)",
        f"{path.resolve()}:3: <Explore>: waypoints: item 2 '3' is not 'x,y' in metres (expected 'x,y;x,y;…')",
    ]


def test_the_tree_nodes_model_comes_from_the_same_declaration():
    factory = BehaviourFactory()
    factory.register(VisualServoDock)
    model = ElementTree.fromstring(nodes_model_xml(factory))
    [node] = list(model)
    assert (node.tag, node.get("ID")) == ("Action", "VisualServoDock")
    written = [(p.tag, p.get("name"), p.get("type"), p.get("default"), p.text) for p in node]
    declared = [
        (
            "input_port",
            f.name,
            GROOT_TYPES[VisualServoDock.PORTS[f.name].type],
            format_default(f.default),
            VisualServoDock.PORTS[f.name].doc,
        )
        for f in dataclasses.fields(VisualServoDock.Params)
    ]
    assert written == declared


# ------------------------------------------------------------------------ a run's port values (set_port)
def _nodes(root: py_trees.behaviour.Behaviour, cls_name: str) -> list[py_trees.behaviour.Behaviour]:
    return [n for n in root.iterate() if type(n).__name__ == cls_name]


def test_a_port_set_on_a_factory_reaches_every_node_of_that_type_whatever_the_file_writes():
    factory = shipped_factory()
    factory.set_port("SearchBelief", "angular_speed", 1)  # an int for a float port, as a user types it
    factory.set_port("SearchBelief", "timeout_s", 7.5)  # follow.xml writes timeout_s="25"
    searches = _nodes(load_tree("mission.xml", factory), "SearchBelief")
    assert searches and all(n.params.angular_speed == 1.0 and n.params.timeout_s == 7.5 for n in searches)
    assert factory.port_values() == {"SearchBelief": {"angular_speed": 1.0, "timeout_s": 7.5}}
    untouched = _nodes(load_tree("mission.xml", shipped_factory()), "SearchBelief")
    assert untouched and all(n.params.timeout_s == 25.0 for n in untouched)  # only that factory changed


def test_a_port_value_out_of_its_range_is_the_trees_error_at_the_node(tmp_path):
    factory = shipped_factory()
    factory.set_port("FollowTarget", "window", 0)
    with pytest.raises(TreeError, match=r"follow\.xml:\d+: .*window"):
        validate_tree("follow.xml", factory)


@pytest.mark.parametrize(
    ("tag", "port", "value", "message"),
    [
        ("SearchSwep", "angular_speed", 1.0, r"no behaviour 'SearchSwep' \(did you mean SearchSweep\?\)"),
        ("SearchSweep", "angular_sped", 1.0, r"unknown port 'angular_sped' \(did you mean angular_speed\?\)"),
        ("SearchSweep", "angular_speed", "fast", r"port angular_speed expects float, got 'fast'"),
        ("Sequence", "memory", True, r"no behaviour 'Sequence'"),  # built-ins have no settable ports
    ],
)
def test_setting_a_port_that_does_not_exist_or_a_wrong_type_says_what_was_expected(tag, port, value, message):
    with pytest.raises(ValueError, match=message):
        shipped_factory().set_port(tag, port, value)
