"""Trees that come and go with goals (issue 32): the runner perceives with no tree, ticks a tree an action
server starts with the goal's inputs on its blackboard, halts it on cancel or when the next goal preempts it,
and tells its observers each time. In the simulation, with the shipped DockRobot tree."""

from __future__ import annotations

import math

import py_trees

from mission.app.runner import TreeRunner
from mission.app.sim_run import prepare_run
from mission.core import blackboard as bbk
from mission.core.observers import RunObserver
from mission.core.types import Pose2D, Twist
from mission.sim.sim_adapter import SimAdapter

S = py_trees.common.Status
# explore_dock's tag hangs at (0, 4) facing +x: docked, the robot faces it, 0.7 m further back is staging
GOAL = {
    "staging_pose": Pose2D(1.05, 4.0, math.pi),
    "navigate_to_staging_pose": True,
    "max_staging_time": 60.0,
    "num_attempts": 4,
    "initial_perception_timeout": 5.0,
    "dock_approach_timeout": 30.0,
}


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
