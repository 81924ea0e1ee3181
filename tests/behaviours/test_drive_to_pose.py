"""DriveToPose: the leaf Nav2's UndockRobot needs — drive straight to a pose a few decimetres away with velocity
commands and no planner (reversing off the dock to its staging pose), then turn to the pose's heading."""

from __future__ import annotations

import math

import py_trees

from mission.behaviours.drive_to_pose import DriveToPose
from mission.core import blackboard as bbk
from mission.core import se3
from mission.core.types import Pose2D, Twist
from tests.helpers.behaviour_world import Scene, read

S = py_trees.common.Status


def leaf(node):
    node.setup_with_descendants()
    return node


def run(scene: Scene, root, limit_s: float = 30.0) -> list[Twist]:
    """Cycle until the leaf is done (or `limit_s` of scene time); the twists it commanded, tick by tick."""
    twists = []
    while scene.clock < limit_s:
        status = scene.cycle(root)
        twists.append(read(bbk.TWIST))
        if status != S.RUNNING:
            break
    return twists


def behind(pose: Pose2D, metres: float) -> Pose2D:
    """Nav2's undock staging pose: `metres` back along the robot's heading, the same heading."""
    return Pose2D(pose.x - metres * math.cos(pose.yaw), pose.y - metres * math.sin(pose.yaw), pose.yaw)


def test_it_reverses_off_the_dock_to_a_pose_behind_it_and_stops_within_the_tolerances():
    docked = Pose2D(0.3, 4.0, math.pi)  # facing a dock on the wall at x = 0
    staging = behind(docked, 0.7)
    scene = Scene(robot=docked)
    root = leaf(DriveToPose(pose=staging, backward=True, what="the staging pose"))
    twists = run(scene, root)
    assert root.status == S.SUCCESS
    moving = [t for t in twists[:-1] if t.v != 0.0]
    assert moving and all(t.v < 0 for t in moving), "reverses all the way: never turns round to drive forward"
    assert max(abs(t.v) for t in twists) <= 0.15 + 1e-9
    assert scene.robot.distance_to(staging) <= 0.05
    assert abs(se3.wrap_angle(scene.robot.yaw - staging.yaw)) <= 0.05
    assert twists[-1] == Twist(0.0, 0.0) and read(bbk.NAV_GOAL) is None  # stopped, and no navigator involved
    assert root.feedback_message == "at the staging pose (1.00, 4.00, 180°)"
    assert 0.7 / 0.15 < scene.clock < 10.0  # no faster than max_v allows, and no dawdling


def test_forward_it_drives_forward_to_a_pose_ahead_and_off_to_one_side():
    start = Pose2D(1.0, 1.0, 0.0)
    goal = Pose2D(1.6, 1.2, 0.0)
    scene = Scene(robot=start)
    root = leaf(DriveToPose(pose=goal, max_v=0.2, linear_tolerance=0.03))
    twists = run(scene, root)
    assert root.status == S.SUCCESS
    assert all(t.v >= 0 for t in twists)
    assert 0.19 < max(t.v for t in twists) <= 0.2  # up to max_v once it heads for the point
    assert scene.robot.distance_to(goal) <= 0.03
    assert abs(se3.wrap_angle(scene.robot.yaw - goal.yaw)) <= 0.05


def test_at_the_point_it_turns_in_place_to_the_poses_yaw():
    scene = Scene(robot=Pose2D(2.0, 2.0, 0.0))
    root = leaf(DriveToPose(pose=Pose2D(2.0, 2.0, math.radians(60)), max_w=0.4))
    twists = run(scene, root)
    assert root.status == S.SUCCESS
    assert all(t.v == 0.0 for t in twists) and max(t.w for t in twists) == 0.4
    assert abs(se3.wrap_angle(scene.robot.yaw - math.radians(60))) <= 0.05
    assert scene.robot.distance_to(Pose2D(2.0, 2.0, 0.0)) < 1e-9


def test_it_fails_after_its_timeout_naming_the_pose():
    scene = Scene(robot=Pose2D(0.3, 4.0, math.pi))
    staging = Pose2D(1.0, 4.0, math.pi)
    root = leaf(DriveToPose(pose=staging, backward=True, max_v=0.05, timeout_s=2.0, what="the staging pose"))
    run(scene, root)
    assert root.status == S.FAILURE
    assert read(bbk.REASON) == "the staging pose (1.00, 4.00, 180°) not reached within 2 s"
    assert root.feedback_message == read(bbk.REASON)
    assert 2.0 < scene.clock < 2.2
    assert read(bbk.TWIST) == Twist(0.0, 0.0)  # its command withdrawn: the robot stops


def test_without_a_robot_pose_it_waits_with_the_robot_stopped():
    scene = Scene(robot=Pose2D(0.3, 4.0, math.pi))
    root = leaf(DriveToPose(pose=Pose2D(1.0, 4.0, math.pi), backward=True))
    writer = bbk.writer("test")
    for _ in range(5):
        scene.sense()
        bbk.set_(writer, bbk.ROBOT_STATE, None)  # the adapter has no pose (no TF yet)
        bbk.set_(writer, bbk.WORLD_FAULT, "no map → base_link transform")
        root.tick_once()
        scene.act()
        assert root.status == S.RUNNING
        assert read(bbk.TWIST) == Twist(0.0, 0.0) and read(bbk.NAV_GOAL) is None
    assert root.feedback_message == "waiting for the robot pose (no map → base_link transform)"
    assert scene.robot == Pose2D(0.3, 4.0, math.pi)
