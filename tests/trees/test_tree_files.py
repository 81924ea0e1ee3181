"""The shipped tree files: they match the behaviour catalogue, load with the shipped factory, tick on an
empty blackboard without crashing, carry an up-to-date Groot2 TreeNodesModel, and a user can compose
new trees from the shipped behaviours without writing Python."""

from __future__ import annotations

import logging
import shutil

import py_trees
import pytest
from py_trees.common import Status

from mission.core import blackboard as bbk
from mission.core.errors import TreeError
from mission.trees.factory import shipped_factory
from mission.trees.loader import (
    TREES_DIR,
    TreeDescription,
    describe_tree,
    example_trees,
    load_tree,
    shipped_trees,
    validate_tree,
)
from mission.trees.tree_nodes_model import nodes_model_section, with_nodes_model

SHIPPED = ["explore.xml", "dock.xml", "follow.xml", "mission.xml", "explore_dock.xml", "discover_follow.xml"]


def shape(desc: TreeDescription) -> str:
    """A tree as one line: ``Tag:name(port=value)[children]`` (name only when set, SubTrees by ID)."""
    if desc.tag == "SubTree":
        return f"SubTree({desc.subtree})"
    text = desc.tag if desc.name == desc.tag or desc.tag == "BehaviorTree" else f"{desc.tag}:{desc.name}"
    if desc.ports:
        text += "(" + ",".join(f"{k}={v}" for k, v in desc.ports.items()) + ")"
    if desc.children:
        text += "[" + ",".join(shape(c) for c in desc.children) + "]"
    return text


FOLLOW = (
    "ReactiveFallback:coordinator["
    "ReactiveSequence:FOLLOW[IsTargetVisible(target=target,max_misses=4,grace_s=1.5),FollowTarget(target=target)],"
    "ReactiveSequence:LOST[IsLineOfSightBlocked(target=target,min_misses=5),PursueLastSeen(target=target)],"
    "SubTree(SearchTree)]"
)
CATALOGUE = {
    "explore.xml": "BehaviorTree[Explore(target=dock)]",
    "dock.xml": "BehaviorTree[RetryUntilSuccessful(num_attempts=3)["
    "Sequence:approach[GoToStaging(target=dock),VisualServoDock(target=dock)]]]",
    "follow.xml": f"BehaviorTree[{FOLLOW}]",
    "mission.xml": "BehaviorTree[Sequence[SubTree(ExploreTree),SubTree(DockTree),SubTree(FollowTree)]]",
    "explore_dock.xml": "BehaviorTree[Sequence[SubTree(ExploreTree),SubTree(DockTree),SetMissionState(state=DONE)]]",
    "discover_follow.xml": "BehaviorTree[Sequence[Explore:discover(target=target,angular_speed=0.1,timeout_s=90.0),"
    "SubTree(FollowTree)]]",
}
MAIN_TREE = {  # no tree ID is the name of a node (BT.CPP 4.6.2+ refuses a tree called Explore next to the action)
    "explore.xml": "ExploreTree",
    "dock.xml": "DockTree",
    "follow.xml": "FollowTree",
    "mission.xml": "Mission",
    "explore_dock.xml": "ExploreDock",
    "discover_follow.xml": "DiscoverFollow",
}


def test_every_catalogue_tree_ships_with_the_package():
    assert set(SHIPPED) <= set(shipped_trees())


@pytest.mark.parametrize("name", SHIPPED)
def test_a_shipped_tree_has_the_shape_the_catalogue_describes(name):
    desc = describe_tree(name)
    assert desc.name == MAIN_TREE[name]
    assert shape(desc) == CATALOGUE[name]


def test_the_follow_subtree_of_the_mission_is_the_target_coordinator_from_the_catalogue():
    follow = next(d for d in describe_tree("mission.xml").walk() if d.tag == "SubTree" and d.name == "FollowTree")
    assert shape(follow.children[0]) == FOLLOW


@pytest.mark.parametrize("name", SHIPPED)
def test_a_shipped_tree_loads_and_keeps_ticking_on_an_empty_blackboard(name):
    validate_tree(name)
    root = load_tree(name, shipped_factory())
    tree = py_trees.trees.BehaviourTree(root)
    tree.setup(timeout=5.0)
    for _ in range(5):
        tree.tick()
        assert root.status != Status.INVALID
    for node in root.iterate():
        if node.status != Status.INVALID and not node.children:
            assert node.feedback_message, f"{node.name} ticked without a feedback message"
    tree.shutdown()


@pytest.mark.parametrize("name", SHIPPED)
def test_shipped_trees_use_only_the_declared_readable_blackboard_keys(name):
    tree = py_trees.trees.BehaviourTree(load_tree(name))
    tree.setup(timeout=5.0)
    for _ in range(3):
        tree.tick()
    declared = {k.path for k in bbk.ALL_KEYS}
    used = set(py_trees.blackboard.Blackboard.storage) | set(py_trees.blackboard.Blackboard.metadata)
    assert used <= declared, f"undeclared (e.g. UUID) keys: {sorted(used - declared)}"


def test_subtrees_in_the_mission_are_named_after_their_ids_so_viewers_show_the_phase():
    root = load_tree("mission.xml")
    assert root.name == "Mission"
    assert [c.name for c in root.children] == ["ExploreTree", "DockTree", "FollowTree"]


@pytest.mark.parametrize("name", SHIPPED)
def test_the_groot2_nodes_model_in_a_shipped_file_matches_the_shipped_behaviours(name):
    text = (TREES_DIR / name).read_text()
    assert nodes_model_section(text) is not None
    assert with_nodes_model(text, shipped_factory()) == text, "stale: run `python -m mission.trees.tree_nodes_model`"


@pytest.mark.parametrize("name", example_trees())
def test_an_example_files_nodes_model_is_current_and_keeps_the_subtree_models_written_by_hand(name):
    text = (TREES_DIR / name).read_text()
    assert with_nodes_model(text, shipped_factory()) == text, "stale: run `python -m mission.trees.tree_nodes_model`"
    section = nodes_model_section(text)
    assert section is not None and '<SubTree ID="FindMarkerTree">' in section
    stale = text.replace(section, '  <TreeNodesModel>\n    <SubTree ID="FindMarkerTree"/>\n  </TreeNodesModel>\n')
    regenerated = nodes_model_section(with_nodes_model(stale, shipped_factory()))
    assert regenerated is not None and '<Action ID="Explore">' in regenerated  # the behaviours, written anew
    assert '<SubTree ID="FindMarkerTree"/>' in regenerated  # and the file's own SubTree model, kept


def test_a_user_composes_a_new_tree_from_shipped_behaviours_without_python(tmp_path):
    path = tmp_path / "patrol.xml"
    path.write_text(
        f"""<root BTCPP_format="4" main_tree_to_execute="Patrol">
  <include path="{TREES_DIR / "dock.xml"}"/>
  <BehaviorTree ID="Patrol">
    <Sequence name="steps">
      <Fallback name="find the dock">
        <Timeout msec="90000">
          <Explore target="dock" waypoints="1.0,0.0;1.0,1.5" angular_speed="0.4"/>
        </Timeout>
        <SetMissionState name="give up" state="FAILED"/>
      </Fallback>
      <SubTree ID="DockTree"/>
      <Parallel success_count="1">
        <SearchSweep target="target" duration_s="15" angular_speed="0.3"/>
        <Inverter><IsTargetVisible target="target"/></Inverter>
      </Parallel>
      <SetMissionState state="DONE"/>
    </Sequence>
  </BehaviorTree>
</root>
"""
    )
    validate_tree(path)
    clock = bbk.writer("test clock")
    bbk.set_(clock, bbk.CLOCK, 0.0)
    root = load_tree(path)
    tree = py_trees.trees.BehaviourTree(root)
    tree.setup(timeout=5.0)
    for step in range(3):
        bbk.set_(clock, bbk.CLOCK, 0.1 * step)
        tree.tick()
    assert root.name == "Patrol"
    assert root.status == Status.RUNNING
    explore = next(n for n in root.iterate() if n.name == "Explore")
    assert explore.status == Status.RUNNING, explore.feedback_message


def test_a_typo_in_a_copy_of_a_shipped_tree_names_file_line_and_element(tmp_path):
    copy = tmp_path / "follow.xml"
    shutil.copy(TREES_DIR / "follow.xml", copy)
    text = copy.read_text().replace('<FollowTarget target="target"/>', '<FollowTarget target="target" offset_m="far"/>')
    copy.write_text(text)
    line = next(i for i, row in enumerate(text.splitlines(), start=1) if "offset_m=" in row and "FollowTarget" in row)
    with pytest.raises(TreeError) as err:
        validate_tree(copy)
    assert str(err.value) == f"{copy.resolve()}:{line}: <FollowTarget>: port offset_m expects float, got 'far'"


def test_a_tree_written_before_perception_became_a_stage_still_runs_and_says_the_leaf_is_not_needed(tmp_path, caplog):
    path = tmp_path / "old.xml"
    path.write_text("""<root BTCPP_format="4" main_tree_to_execute="Old">
  <BehaviorTree ID="Old">
    <ReactiveSequence>
      <ForceSuccess><PerceiveTargets/></ForceSuccess>
      <SetMissionState state="DONE"/>
    </ReactiveSequence>
  </BehaviorTree>
</root>
""")
    tree = py_trees.trees.BehaviourTree(load_tree(path))
    with caplog.at_level(logging.WARNING):
        tree.setup(timeout=5.0)
    tree.tick()
    assert tree.root.status == Status.SUCCESS
    leaf = next(n for n in tree.root.iterate() if n.name == "PerceiveTargets")
    assert leaf.feedback_message.startswith("perception runs as a stage before every tick")
    assert any("remove it from the tree" in r.getMessage() for r in caplog.records)
