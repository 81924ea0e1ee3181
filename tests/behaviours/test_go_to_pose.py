"""GoToPose and WaitForTarget: the two leaves Nav2's DockRobot needs beyond DOCK's own — go to a pose the
tree is given (the dock database's staging pose), then wait, standing still, for the first sight of the dock."""

from __future__ import annotations

import math

import py_trees

from mission.behaviours.go_to_pose import GoToPose
from mission.behaviours.wait_for_target import WaitForTarget
from mission.core import blackboard as bbk
from mission.core.config import TargetSpec
from mission.core.types import Pose2D, Twist
from tests.helpers.behaviour_world import Scene, ScriptedNavigator, marker_facing, read

S = py_trees.common.Status
DOCK = marker_facing(4.0, 2.0, math.radians(180))  # on a wall at x = 4, facing −x


def leaf(node):
    node.setup_with_descendants()
    return node


def test_go_to_pose_sends_the_given_pose_and_succeeds_when_the_navigator_reports_it_reached():
    scene = Scene(robot=Pose2D(1.0, 1.5, 0.0), navigator=ScriptedNavigator())
    root = leaf(GoToPose(pose=Pose2D(3.3, 2.0, 0.0), what="the staging pose"))
    statuses = [scene.cycle(root) for _ in range(5)]
    assert statuses == [S.RUNNING] * 4 + [S.SUCCESS]
    assert scene.navigator.goals[0].pose == Pose2D(3.3, 2.0, 0.0)
    assert root.feedback_message == "at the staging pose (3.30, 2.00, 0°)"


def test_go_to_pose_fails_with_the_navigators_reason_and_after_its_timeout():
    nav = ScriptedNavigator(unreachable=((3.3, 2.0),))
    scene = Scene(robot=Pose2D(1.0, 1.5, 0.0), navigator=nav)
    root = leaf(GoToPose(pose=Pose2D(3.3, 2.0, 0.0), what="the staging pose"))
    while root.status != S.FAILURE and scene.clock < 2.0:
        scene.cycle(root)
    assert read(bbk.REASON).startswith("navigation to the staging pose (3.30, 2.00, 0°) failed")
    slow = Scene(robot=Pose2D(1.0, 1.5, 0.0), navigator=ScriptedNavigator(ticks_to_arrive=1000))
    root = leaf(GoToPose(pose=Pose2D(3.3, 2.0, 0.0), timeout_s=1.0))
    while root.status != S.FAILURE and slow.clock < 3.0:
        slow.cycle(root)
    assert read(bbk.REASON) == "the goal (3.30, 2.00, 0°) not reached within 1 s"
    assert 1.0 < slow.clock < 1.2


def test_wait_for_target_holds_the_robot_still_and_succeeds_on_the_first_sighting():
    scene = Scene(robot=Pose2D(2.0, 2.0, 0.0), marker=DOCK, marker_id=0)
    scene.perceive_targets({"dock": TargetSpec(marker_id=0)})
    root = leaf(WaitForTarget(target="dock", timeout_s=5.0))
    assert scene.cycle(root) == S.SUCCESS  # in view from here: the first frame is enough
    away = Scene(robot=Pose2D(2.0, 2.0, math.pi), marker=DOCK, marker_id=0)  # facing away
    away.perceive_targets({"dock": TargetSpec(marker_id=0)})
    root = leaf(WaitForTarget(target="dock", timeout_s=5.0))
    assert away.cycle(root) == S.RUNNING
    assert read(bbk.TWIST) == Twist(0.0, 0.0) and read(bbk.NAV_GOAL) is None
    while root.status == S.RUNNING:
        away.cycle(root)
    assert root.status == S.FAILURE and read(bbk.REASON) == "dock not seen within 5 s"
    assert 5.0 < away.clock < 5.2
