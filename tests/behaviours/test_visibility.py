"""IsTargetVisible: seen now, allowing a few blinking frames."""

from __future__ import annotations

import py_trees
import pytest

from mission.behaviours.visibility import IsTargetVisible
from mission.core import blackboard as bbk
from mission.core.types import Pose2D, TargetTrack
from tests.helpers.behaviour_world import Scene, board, grid_with_boxes, lost_at, tick

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


# -- the grace for a loss the robot's own turn caused ------------------------------------------------------------
# Following round an obstacle's corner, the navigator turns the robot away from a target at the image's edge.


def sighted(
    *, at=(2.0, 1.0), turned_to: float = 0.0, clock: float = 0.5, walking=None, boxes=(), misses: int = 9
) -> None:
    """The target was last seen `at` (27° left) at t = 0 by the robot at the origin facing +x; since then
    `misses` frames missed it and the robot has turned to `turned_to` (rad) on the spot."""
    Scene(robot=Pose2D(0.0, 0.0, turned_to), grid=grid_with_boxes(list(boxes)), clock=clock).sense()
    track = lost_at(*at, last_seen=0.0, walking=walking)
    track.misses = misses
    track.robot_at_last_seen = Pose2D(0.0, 0.0, 0.0)


def following(grace_s: float = 1.5) -> IsTargetVisible:
    """The FOLLOW condition, having just seen the target."""
    node = IsTargetVisible(target="target", max_misses=4, grace_s=grace_s)
    sighted(clock=0.0, misses=0)
    assert tick(node) == S.SUCCESS
    return node


def test_a_target_the_robots_own_turn_put_off_the_images_side_still_counts_as_visible_for_the_grace():
    node = following()
    sighted(turned_to=-0.5)  # 29° right: the target is now 58° left of the camera's axis, past its 35° half
    assert tick(node) == S.SUCCESS
    assert node.feedback_message == (
        "target pushed to the image's side by the robot's own turn (+23° past it), in clear sight: "
        "counted visible (0.5 of 1.5 s grace)"
    )


def test_a_turn_that_leaves_the_target_just_inside_the_view_counts_too_its_marker_is_partly_off_the_image():
    node = following()
    sighted(turned_to=-0.1)  # 6° right: the target's place is 34° left of the camera's axis, 1° inside its side
    assert tick(node) == S.SUCCESS
    assert node.feedback_message.startswith("target pushed to the image's side by the robot's own turn (-1° past it)")


def test_the_grace_ends_after_grace_s_and_does_not_come_back_without_a_sighting():
    node = following()
    sighted(turned_to=-0.5, clock=1.6)
    assert tick(node) == S.FAILURE  # 1.6 s > 1.5 s
    assert node.feedback_message == "target not visible: 9 misses > 4, last seen 1.6 s ago"
    sighted(turned_to=-0.5, clock=1.0)  # as if a search's turn put it off the side again, within the 1.5 s
    assert tick(node) == S.FAILURE


@pytest.mark.parametrize(
    "why, since",
    [
        ("it walked out of the view itself", dict(walking=(0.0, 2.0))),
        ("a wall stands between", dict(turned_to=-0.5, boxes=[(1.0, 0.3, 1.2, 0.9)])),
        ("it is in the view and simply not detected", dict(turned_to=0.2)),
        ("the robot turned toward it, not away", dict(at=(2.0, 1.25), turned_to=0.05)),
        ("the robot turned away, but it is well inside the view", dict(at=(2.0, 0.5), turned_to=-0.1)),
        ("it is too far off to have left the view by a turn", dict(at=(4.4, 2.2), turned_to=-0.5)),
    ],
)
def test_no_grace_when_the_robots_turn_is_not_why_the_target_is_unseen(why, since):
    node = following()
    sighted(**since)
    assert tick(node) == S.FAILURE, why


def test_without_grace_s_a_turn_away_is_a_loss_as_before():
    node = following(grace_s=0.0)
    sighted(turned_to=-0.5)
    assert tick(node) == S.FAILURE
