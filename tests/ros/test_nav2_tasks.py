"""What a DockRobot / UndockRobot goal makes of our trees, without ROS: the inputs from the goal and the dock
database, Nav2's feedback state from where the tree is, Nav2's error code from the node that failed. The
feedback and error cases run the shipped dock_robot.xml in the simulation, as the server runs it."""

from __future__ import annotations

import math

import py_trees
import pytest

from mission.app.runner import TreeRunner
from mission.app.sim_run import prepare_run
from mission.core.config import TargetSpec
from mission.core.types import Pose2D
from mission.ros import nav2_tasks as tasks
from mission.ros.nav2_params import Dock, DockingParams, DockType
from mission.sim.sim_adapter import SimAdapter

S = py_trees.common.Status
WALL_TAG = DockType("wall_tag")
HOME = Dock("home_dock", "wall_tag", 0.47, 4.0, math.pi, id="0")
PARAMS = DockingParams(dock_types={"wall_tag": WALL_TAG}, docks={"home_dock": HOME})


def test_a_dock_id_gives_the_staging_pose_behind_the_docked_pose_and_nav2s_timeouts():
    plan = tasks.plan_dock(tasks.DockGoal(dock_id="home_dock", max_staging_time=60.0), PARAMS, Pose2D(2.6, 3.0, 0.0))
    staging = plan.inputs["staging_pose"]
    assert (round(staging.x, 6), round(staging.y, 6), staging.yaw) == (1.17, 4.0, math.pi)
    assert plan.inputs["navigate_to_staging_pose"] is True
    assert plan.inputs["num_attempts"] == 4  # max_retries 3 + the first
    assert plan.inputs["max_staging_time"] == 60.0
    assert plan.inputs["initial_perception_timeout"] == 5.0 and plan.inputs["dock_approach_timeout"] == 30.0
    assert plan.retarget == {"dock": TargetSpec(marker_id=0)}  # the dock's id is the tag the camera looks for


def test_a_robot_already_near_the_staging_pose_does_not_navigate_as_in_nav2():
    near = Pose2D(1.17 + 0.2, 4.0 + 0.2, math.pi - 0.1)  # L2 of (x, y, yaw) differences ≈ 0.30 < 0.5
    plan = tasks.plan_dock(tasks.DockGoal(dock_id="home_dock"), PARAMS, near)
    assert plan.inputs["navigate_to_staging_pose"] is False
    told = tasks.plan_dock(tasks.DockGoal(dock_id="home_dock", navigate_to_staging_pose=False), PARAMS, None)
    assert told.inputs["navigate_to_staging_pose"] is False


def test_goals_that_cannot_start_are_rejected_with_nav2s_codes():
    with pytest.raises(tasks.TaskRejected) as no_dock:
        tasks.plan_dock(tasks.DockGoal(dock_id="kitchen"), PARAMS, None)
    assert no_dock.value.error == "DOCK_NOT_IN_DB"
    assert str(no_dock.value) == "dock 'kitchen' is not in the dock database; known: home_dock"
    two_types = DockingParams(dock_types={"a": DockType("a"), "b": DockType("b")})
    by_pose = tasks.DockGoal(use_dock_id=False, dock_pose=Pose2D(1, 1, 0))
    with pytest.raises(tasks.TaskRejected) as no_type:
        tasks.plan_dock(by_pose, two_types, None)
    assert no_type.value.error == "DOCK_NOT_VALID" and "dock type '' is not one of dock_plugins: a, b" in str(
        no_type.value
    )
    with pytest.raises(tasks.TaskRejected) as odom:
        tasks.plan_dock(tasks.DockGoal(use_dock_id=False, dock_pose=Pose2D(1, 1, 0), dock_frame="odom"), PARAMS, None)
    assert odom.value.error == "DOCK_NOT_VALID" and "frame 'odom'" in str(odom.value)


def test_undocking_stages_behind_where_the_robot_is_with_the_type_it_docked_at():
    plan = tasks.plan_undock(tasks.UndockGoal(), PARAMS, Pose2D(0.47, 4.0, math.pi), docked_type="wall_tag")
    staging = plan.inputs["staging_pose"]
    assert (round(staging.x, 6), round(staging.y, 6)) == (1.17, 4.0) and staging.yaw == math.pi
    assert plan.inputs["undock_backward"] is True
    assert plan.inputs["undock_linear_tolerance"] == plan.inputs["undock_angular_tolerance"] == 0.05
    two_types = DockingParams(dock_types={"a": DockType("a"), "b": DockType("b")})
    with pytest.raises(tasks.TaskRejected) as unknown:
        tasks.plan_undock(tasks.UndockGoal(), two_types, Pose2D(0, 0, 0))
    assert unknown.value.error == "DOCK_NOT_VALID"


def sim_runner() -> TreeRunner:
    prepared = prepare_run("explore_dock")
    runner = TreeRunner(
        prepared.config, SimAdapter(prepared.scenario, seed=0), perception_only=True, config_file=prepared.config_path
    )
    runner.setup()
    return runner


def run_goal(runner: TreeRunner, plan: tasks.TaskPlan, seconds: float) -> tuple[tasks.PhaseWatch, list[str]]:
    runner.start_tree(plan.tree, plan.inputs)
    watch = tasks.PhaseWatch(tasks.DOCK_ROBOT)
    runner.tree.visitors.append(watch)
    seen: list[str] = []
    while runner.elapsed() < seconds:
        status = runner.step()
        state = tasks.feedback_state(tasks.DOCK_ROBOT, watch, int(runner.tree_entry("attempt") or 1))
        if not seen or seen[-1] != state:
            seen.append(state)
        if status in (S.SUCCESS, S.FAILURE):
            break
        runner.world.advance(runner.dt)
    return watch, seen


def test_a_dock_the_camera_never_sees_fails_to_detect_it_retrying_from_staging():
    runner = sim_runner()
    try:
        blank = DockingParams(max_retries=1, dock_types={"wall_tag": WALL_TAG})
        goal = tasks.DockGoal(use_dock_id=False, dock_pose=Pose2D(4.0, 7.3, math.pi / 2), max_staging_time=60.0)
        watch, seen = run_goal(runner, tasks.plan_dock(goal, blank, None), 90.0)
        assert runner.status == S.FAILURE
        error, message = tasks.failure(tasks.DOCK_ROBOT, watch, "")
        assert error == "FAILED_TO_DETECT_DOCK"
        assert message == "dock not seen within 5 s"
        assert seen[:4] == ["NAV_TO_STAGING_POSE", "INITIAL_PERCEPTION", "RETRY", "INITIAL_PERCEPTION"]
    finally:
        runner.close()


def test_staging_that_takes_longer_than_max_staging_time_fails_to_stage():
    runner = sim_runner()
    try:
        params = DockingParams(max_retries=0, dock_types={"wall_tag": WALL_TAG}, docks={"home_dock": HOME})
        goal = tasks.DockGoal(dock_id="home_dock", max_staging_time=2.0)  # 1.6 m and a turn away
        watch, seen = run_goal(runner, tasks.plan_dock(goal, params, None), 30.0)
        assert runner.status == S.FAILURE and seen[0] == "NAV_TO_STAGING_POSE"
        error, message = tasks.failure(tasks.DOCK_ROBOT, watch, "")
        assert error == "FAILED_TO_STAGE"
        assert message == "the staging pose (1.17, 4.00, 180°) not reached within 2 s"
    finally:
        runner.close()


def test_a_phase_the_tree_finishes_within_one_tick_is_still_reported_in_order():
    """The dock already in view on arrival: INITIAL_PERCEPTION succeeds in the tick CONTROLLING starts in. A Nav2
    client still sees INITIAL_PERCEPTION before CONTROLLING, as opennav_docking sends it."""
    seen_at_once = py_trees.behaviours.Success(name="INITIAL_PERCEPTION")
    controlling = py_trees.behaviours.Running(name="CONTROLLING")
    staged = py_trees.behaviours.Success(name="NAV_TO_STAGING_POSE")
    root = py_trees.composites.Sequence("dock", memory=True, children=[staged, seen_at_once, controlling])
    tree = py_trees.trees.BehaviourTree(root)
    watch = tasks.PhaseWatch(tasks.DOCK_ROBOT)
    tree.visitors.append(watch)
    assert tasks.feedback_states(tasks.DOCK_ROBOT, watch, 1) == []  # not ticked yet: no NONE feedback
    tree.tick()
    assert watch.current == "CONTROLLING"
    assert tasks.feedback_state(tasks.DOCK_ROBOT, watch, 1) == "CONTROLLING"  # where the tree is
    assert tasks.feedback_states(tasks.DOCK_ROBOT, watch, 1) == [
        "NAV_TO_STAGING_POSE",
        "INITIAL_PERCEPTION",
        "CONTROLLING",
    ]
    tree.tick()
    assert tasks.feedback_states(tasks.DOCK_ROBOT, watch, 1) == ["CONTROLLING"]  # nothing new: where it is
