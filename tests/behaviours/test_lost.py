"""HoldLastGoal: LOST freezes the goal at the last known target pose until the loss timer runs out."""

from __future__ import annotations

import math

import py_trees

from mission.behaviours.lost import HoldLastGoal
from mission.core import blackboard as bbk
from mission.core.types import Pose2D, RobotState, TargetTrack, Twist
from tests.helpers.behaviour_world import board, marker_facing, read, tick

S = py_trees.common.Status
SEEN_FROM = Pose2D(0.0, 0.0, 0.0)


def seed(clock: float, robot: Pose2D = SEEN_FROM) -> None:
    w = board()
    bbk.set_(w, bbk.CLOCK, clock)
    bbk.set_(w, bbk.ROBOT_STATE, RobotState(robot, Twist(), clock))


def lost_track() -> TargetTrack:
    return TargetTrack(
        "target", last_seen=10.0, misses=6, pose_map=marker_facing(3.0, 4.0, math.pi), robot_at_last_seen=SEEN_FROM
    )


def test_lost_holds_a_frozen_goal_then_fails_when_the_timer_from_last_seen_expires():
    bbk.set_(board(), bbk.TRACKS, {"target": lost_track()})
    node = HoldLastGoal(timeout_s=3.0)
    seed(10.5)
    assert tick(node) == S.RUNNING
    goal = read(bbk.NAV_GOAL)
    # 0.5 m short of the last target position along the line it was seen along, facing it
    assert math.isclose(goal.pose.x, 3.0 * 0.9, abs_tol=1e-9) and math.isclose(goal.pose.y, 4.0 * 0.9, abs_tol=1e-9)
    assert math.isclose(goal.pose.yaw, math.atan2(4.0, 3.0), abs_tol=1e-9)
    assert read(bbk.STATE) == "LOST" and read(bbk.TWIST) is None
    assert node.feedback_message == "LOST: frozen goal (2.70, 3.60), 0.5 s of 3.0 s"

    seed(12.9, robot=Pose2D(1.5, 0.5, 1.0))  # the robot drives around the obstacle: the goal does not move
    assert tick(node) == S.RUNNING
    assert read(bbk.NAV_GOAL) == goal

    seed(13.2)
    assert tick(node) == S.FAILURE
    assert read(bbk.REASON) == "LOST: target unseen for 3.2 s > timeout 3.0 s"
    assert read(bbk.NAV_GOAL) is None and read(bbk.TWIST) == Twist(0.0, 0.0)


def test_re_entering_lost_does_not_restart_the_timer():
    bbk.set_(board(), bbk.TRACKS, {"target": lost_track()})
    node = HoldLastGoal(timeout_s=2.0)
    seed(11.5)
    assert tick(node) == S.RUNNING
    node.stop(S.INVALID)  # briefly preempted (e.g. line of sight looked clear for a tick)
    seed(12.1)
    assert tick(node) == S.FAILURE


def test_lost_without_a_known_target_position_fails_with_a_reason():
    bbk.set_(board(), bbk.TRACKS, {"target": TargetTrack("target")})
    seed(1.0)
    assert tick(HoldLastGoal()) == S.FAILURE
    assert read(bbk.REASON) == "LOST: target was never placed in the map, no goal to hold"
