"""Trees that come and go with goals (issue 32): the runner perceives with no tree, ticks a tree an action
server starts with the goal's inputs on its blackboard, halts it on cancel or when the next goal preempts it,
and tells its observers each time. In the simulation, with the shipped DockRobot and UndockRobot trees."""

from __future__ import annotations

import math

import py_trees
import pytest

from mission.app.runner import TreeRunner
from mission.app.sim_run import prepare_run
from mission.core import blackboard as bbk
from mission.core import se3
from mission.core.observers import RunObserver
from mission.core.types import Pose2D, Twist
from mission.sim.sim_adapter import SimAdapter
from tests.helpers.goal_runs import GOAL

S = py_trees.common.Status


def undock_goal(robot: Pose2D, *, backward: bool = True, offset_m: float = -0.7, max_time: float = 30.0) -> dict:
    """What the undock_robot server writes: the staging pose `offset_m` along the robot's heading (Nav2's
    staging_x_offset: −0.7, behind it) from where it stands when the goal arrives, and Nav2's defaults."""
    c, s = math.cos(robot.yaw), math.sin(robot.yaw)
    return {
        "staging_pose": Pose2D(robot.x + offset_m * c, robot.y + offset_m * s, robot.yaw),
        "undock_backward": backward,
        "max_undocking_time": max_time,
        "undock_linear_tolerance": 0.05,
        "undock_angular_tolerance": 0.05,
    }


def settled(runner: TreeRunner, seconds: float = 1.0) -> Pose2D:
    """Where the robot comes to rest: the world runs on `seconds` under the tree's last command (a stop)."""
    for _ in range(round(seconds / runner.dt)):
        runner.world.advance(runner.dt)
    return runner.world.robot_pose


def within(robot: Pose2D, goal: Pose2D, metres: float = 0.05, radians: float = 0.05) -> bool:
    return robot.distance_to(goal) <= metres and abs(se3.wrap_angle(robot.yaw - goal.yaw)) <= radians


class Trees(RunObserver):
    """Which tree the run had each time it said the tree changed."""

    def __init__(self) -> None:
        self.seen: list[str | None] = []

    def on_tree(self, run) -> None:
        self.seen.append(None if run.tree is None else run.tree_path.name)


def server_runner() -> tuple[TreeRunner, Trees]:
    prepared = prepare_run("explore_dock")
    trees = Trees()
    runner = TreeRunner(
        prepared.config,
        SimAdapter(prepared.scenario, seed=0),
        perception_only=True,
        config_file=prepared.config_path,
        observers=[trees],
    )
    runner.setup()
    return runner, trees


def test_with_no_goal_the_runner_perceives_and_ticks_nothing():
    runner, trees = server_runner()
    try:
        for _ in range(10):
            assert runner.step() == S.INVALID
            runner.world.advance(runner.dt)
        assert runner.tree is None and trees.seen == []
        assert runner.get(bbk.FRAME_SEQ) > 0  # frames arrive and are perceived
    finally:
        runner.close()


def test_a_goal_tree_runs_with_the_goals_inputs_and_docks():
    runner, trees = server_runner()
    try:
        runner.start_tree("dock_robot.xml", GOAL)
        status = runner.run(until=60.0)
        assert status == S.SUCCESS, runner.get(bbk.REASON)
        assert trees.seen == ["dock_robot.xml"]
    finally:
        runner.close()


def test_cancel_halts_the_tree_and_stops_the_robot_and_a_new_goal_preempts_the_old():
    runner, trees = server_runner()
    try:
        runner.start_tree("dock_robot.xml", GOAL)
        runner.run(until=2.0)
        assert runner.get(bbk.NAV_GOAL) is not None  # on the way to staging
        runner.stop_tree()
        assert runner.tree is None
        assert runner.get(bbk.NAV_GOAL) is None and runner.get(bbk.TWIST) == Twist(0.0, 0.0)
        assert runner.step() == S.RUNNING  # the last status stays until a new tree ticks
        away = {**GOAL, "staging_pose": Pose2D(2.0, 2.0, 0.0), "num_attempts": 1}
        runner.start_tree("dock_robot.xml", GOAL)
        runner.step()
        runner.world.advance(runner.dt)
        runner.start_tree("dock_robot.xml", away)  # preempted before it got anywhere
        runner.step()
        assert runner.get(bbk.NAV_GOAL).pose == Pose2D(2.0, 2.0, 0.0)
        assert trees.seen == ["dock_robot.xml", None, "dock_robot.xml", "dock_robot.xml"]
    finally:
        runner.close()


def test_stop_halts_the_tree_every_running_node_terminated():
    runner, _trees = server_runner()
    try:
        runner.start_tree("dock_robot.xml", GOAL)
        runner.run(until=1.0)
        tree = runner.tree
        running = [b.name for b in tree.root.iterate() if b.status == S.RUNNING]
        assert "NAV_TO_STAGING_POSE" in running
        runner.stop_tree()
        assert [b.name for b in tree.root.iterate() if b.status == S.RUNNING] == []  # BT.CPP's haltTree
    finally:
        runner.close()


class Speeds(RunObserver):
    """The forward speed the tree commanded, tick by tick."""

    def __init__(self) -> None:
        self.v: list[float] = []

    def on_tick(self, run, tick) -> None:
        twist = run.get(bbk.TWIST)
        if isinstance(twist, Twist):
            self.v.append(twist.v)


@pytest.mark.slow  # the same over DDS: tests/ros/test_nav2_actions.py (dock, undock, dock by pose)
def test_after_docking_an_undock_goal_reverses_the_robot_to_its_staging_pose():
    runner, trees = server_runner()
    try:
        runner.start_tree("dock_robot.xml", GOAL)
        assert runner.run(until=60.0) == S.SUCCESS, runner.get(bbk.REASON)
        docked = runner.world.robot_pose
        goal = undock_goal(docked)
        speeds = Speeds()
        runner.attach(speeds)
        runner.start_tree("undock_robot.xml", goal)
        t0 = runner.elapsed()
        status = runner.run(until=t0 + 30.0)
        assert status == S.SUCCESS, runner.get(bbk.REASON)
        assert runner.elapsed() - t0 < 10.0  # 0.7 m at ≤ 0.15 m/s, then slowing into the tolerance
        assert all(v <= 0.0 for v in speeds.v) and min(speeds.v) < 0  # in reverse all the way off the dock
        assert within(settled(runner), goal["staging_pose"])
        assert runner.world.base.contacts == 0
        assert trees.seen == ["dock_robot.xml", "undock_robot.xml"]
    finally:
        runner.close()


def test_an_undock_goal_drives_the_robot_off_a_dock_it_backed_onto_forward_to_its_staging_pose():
    runner, trees = server_runner()
    try:
        start = runner.world.robot_pose  # the scenario's start: stand-in for a dock the robot backed onto
        goal = undock_goal(start, backward=False, offset_m=0.7)  # Nav2 with dock_backwards: true
        runner.start_tree("undock_robot.xml", goal)
        assert runner.run(until=30.0) == S.SUCCESS, runner.get(bbk.REASON)
        assert runner.elapsed() < 10.0
        assert within(settled(runner), goal["staging_pose"])
        assert trees.seen == ["undock_robot.xml"]
    finally:
        runner.close()


def test_an_undock_that_cannot_finish_fails_after_max_undocking_time_naming_the_staging_pose():
    runner, _ = server_runner()
    try:
        # backing off from the start, the robot meets the low crate that is not in the map: nothing checks
        # for obstacles on an undock (nor does Nav2's), so the time limit is what ends it
        goal = undock_goal(runner.world.robot_pose, max_time=4.0)
        runner.start_tree("undock_robot.xml", goal)
        assert runner.run(until=30.0) == S.FAILURE
        x, y, yaw = goal["staging_pose"].x, goal["staging_pose"].y, round(math.degrees(goal["staging_pose"].yaw))
        assert runner.get(bbk.REASON) == f"the staging pose ({x:.2f}, {y:.2f}, {yaw}°) not reached within 4 s"
        assert 4.0 < runner.elapsed() < 4.5
        assert runner.world.base.contacts == 1
        assert runner.get(bbk.TWIST) == Twist(0.0, 0.0)  # the robot is told to stop
    finally:
        runner.close()
