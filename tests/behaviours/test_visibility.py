"""IsTargetVisible: seen now, allowing a few blinking frames."""

from __future__ import annotations

import py_trees

from mission.behaviours.visibility import IsTargetVisible
from mission.core import blackboard as bbk
from mission.core.types import TargetTrack
from tests.helpers.behaviour_world import board, tick

S = py_trees.common.Status


def seed(track: TargetTrack | None, clock: float = 10.0) -> None:
    bbk.set_(board(), bbk.CLOCK, clock)
    bbk.set_(board(), bbk.TRACKS, {} if track is None else {track.name: track})


def test_a_target_never_seen_is_not_visible():
    seed(None)
    node = IsTargetVisible(target="target", max_misses=4)
    assert tick(node) == S.FAILURE
    assert node.feedback_message == "target never seen"


def test_visible_while_misses_stay_within_max_misses():
    node = IsTargetVisible(target="target", max_misses=4)
    for misses, expected in [(0, S.SUCCESS), (4, S.SUCCESS), (5, S.FAILURE)]:
        seed(TargetTrack("target", visible=misses == 0, last_seen=9.7, misses=misses))
        assert tick(node) == expected
    assert node.feedback_message == "target not visible: 5 misses > 4, last seen 0.3 s ago"


def test_default_max_misses_is_zero():
    seed(TargetTrack("dock", last_seen=9.9, misses=1))
    node = IsTargetVisible(target="dock")
    assert tick(node) == S.FAILURE
