"""A run whose trees come and go, as an action server drives it (issue 32), for the observer tests.

The explore_dock simulation with a TreeRunner that starts with no tree (``perception_only``): the test starts
goal trees (``start_tree``) and stops them (``stop_tree``) between real steps of the loop, as the Nav2 action
servers do on a goal, a cancel and a goal's end. Two different trees, so an observer showing the old one
after a change is caught: the shipped ``dock_robot.xml`` (root ``DockRobot``; with GOAL it drives to the
staging pose, ``NAV_TO_STAGING_POSE`` RUNNING) and ``explore_dock.xml`` (root ``ExploreDock``).
"""

from __future__ import annotations

import math

from mission.app.runner import TreeRunner
from mission.app.sim_run import prepare_run
from mission.core.observers import RunObserver
from mission.core.types import Pose2D
from mission.sim.sim_adapter import SimAdapter

# explore_dock's tag hangs at (0, 4) facing +x: docked, the robot faces it, 0.7 m further back is staging
GOAL = {
    "staging_pose": Pose2D(1.05, 4.0, math.pi),
    "navigate_to_staging_pose": True,
    "max_staging_time": 60.0,
    "num_attempts": 4,
    "initial_perception_timeout": 5.0,
    "dock_approach_timeout": 30.0,
}
DOCK_TREE, DOCK_ROOT = "dock_robot.xml", "DockRobot"
EXPLORE_TREE, EXPLORE_ROOT = "explore_dock.xml", "ExploreDock"
STAGING = "NAV_TO_STAGING_POSE"  # dock_robot.xml's node RUNNING while the robot drives to the staging pose


def goal_runner(*observers: RunObserver) -> TreeRunner:
    """A set-up runner in the explore_dock simulation with no tree yet (call close() at the end)."""
    prepared = prepare_run("explore_dock")
    runner = TreeRunner(
        prepared.config,
        SimAdapter(prepared.scenario, seed=0),
        perception_only=True,
        config_file=prepared.config_path,
        observers=list(observers),
    )
    runner.setup()
    return runner


def steps(runner: TreeRunner, n: int) -> None:
    """`n` steps of the loop (sense → perceive → tick → act, observers), the world advancing after each."""
    for _ in range(n):
        runner.step()
        runner.world.advance(runner.dt)
