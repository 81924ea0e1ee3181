"""SetMissionState: a tree announces DONE (or any other mission state)."""

from __future__ import annotations

import py_trees
import pytest

from mission.behaviours.mission_state import SetMissionState
from mission.core import blackboard as bbk
from tests.helpers.behaviour_world import read, tick

S = py_trees.common.Status


def test_it_writes_the_state_and_succeeds():
    node = SetMissionState(state="DONE")
    assert tick(node) == S.SUCCESS
    assert read(bbk.STATE) == "DONE" and node.feedback_message == "mission state ← DONE"


def test_an_unknown_state_is_refused_when_the_tree_is_built():
    with pytest.raises(
        ValueError, match=r"state: expected one of EXPLORE, DOCK, FOLLOW, LOST, SEARCH, DONE, FAILED, got 'Done'"
    ):
        SetMissionState(state="Done")
