"""The example trees (trees/examples/) run real missions in the simulation, the `mission run` code path.

``explore_dock_scripted.xml`` is EXPLORE → DOCK written with BehaviorTree.CPP 4's language: a Script sets the
marker's name and counters, two SubTrees take it as a port (remapping into their own blackboards), one reports
back through an output port, the other counts its attempts into the caller's entry, a ``_skipIf`` and a
``Precondition`` guard the docking, and the final script writes the mission state through its BT.CPP name.
"""

from __future__ import annotations

import py_trees

from mission.app.sim_run import run_scenario
from mission.core.types import Pose2D
from mission.trees.loader import describe_tree, example_trees

EXAMPLE = "examples/explore_dock_scripted.xml"


def test_the_example_uses_remapping_subtree_ports_a_script_and_preconditions():
    desc = describe_tree(EXAMPLE)
    nodes = list(desc.walk())
    subtrees = [n for n in nodes if n.tag == "SubTree"]
    assert {n.name for n in subtrees} == {"FindMarkerTree", "DockAttemptsTree"}
    assert all(str(n.ports["marker"]) == "{marker}" for n in subtrees)  # a port remapped into each SubTree
    assert any(n.tag == "Script" for n in nodes) and any(n.tag == "Precondition" for n in nodes)
    assert any("_skipIf" in n.conditions for n in nodes)
    assert EXAMPLE in example_trees()


def test_the_scripted_example_explores_and_docks_in_the_simulation():
    outcome, _, _ = run_scenario("explore_dock", tree=EXAMPLE, seed=0)
    assert outcome.success, outcome.reason
    dock = outcome.metrics["dock"]
    assert dock["lateral_m"] <= 0.03 and dock["distance_m"] <= 0.025 and dock["skew_deg"] <= 10.0
    assert outcome.final_state == "DONE"  # the last Script wrote mission_state, which is /mission/state
    entries = py_trees.blackboard.Blackboard.storage
    assert entries["/tree/marker"] == "dock"
    assert entries["/tree/found"] is True  # IsTargetVisible's output, through FindMarkerTree's port "seen"
    assert 1 <= entries["/tree/attempts"] <= 3  # counted inside DockAttemptsTree, into the caller's entry
    # what a SubTree keeps to itself stays in its own blackboard (BT.CPP's scoping), not the root's
    assert isinstance(entries["/tree/FindMarkerTree::3/marker_pose"], Pose2D)
    assert isinstance(entries["/tree/DockAttemptsTree::7/staging"], Pose2D)
    assert "/tree/marker_pose" not in entries and "/tree/staging" not in entries
