"""Nav2's DockRobot as a tree (trees/dock_robot.xml, issue 32), run in the simulation with the inputs the
dock_robot server writes per goal: a staging pose from the dock database instead of a dock found by
exploring; retries from staging; back to staging after the last failed attempt."""

from __future__ import annotations

import math
import textwrap

import pytest

from mission.app.sim_run import run_scenario

# explore_dock's tag hangs at (0, 4) facing +x; docked, the robot faces it (yaw 180°), and Nav2's staging pose
# lies 0.7 m further back along that heading.
STAGING = "1.05;4.0;3.14159"
FACING_AWAY = "1.05;4.0;0.0"


def goal_tree(tmp_path, staging: str, attempts: int) -> str:
    """A tree that writes one goal's inputs, as the server does, and runs the shipped DockRobot."""
    path = tmp_path / "goal.xml"
    path.write_text(
        textwrap.dedent(f"""\
        <root BTCPP_format="4" main_tree_to_execute="Goal">
          <include path="dock_robot.xml"/>
          <BehaviorTree ID="Goal">
            <Sequence>
              <Script code="staging_pose := '{staging}'; navigate_to_staging_pose := true;
                            max_staging_time := 60.0; num_attempts := {attempts};
                            initial_perception_timeout := 5.0; dock_approach_timeout := 30.0"/>
              <SubTree ID="DockRobot" _autoremap="true"/>
              <SetMissionState state="DONE"/>
            </Sequence>
          </BehaviorTree>
        </root>
    """)
    )
    return str(path)


def test_a_dock_the_camera_cannot_see_from_staging_fails_every_attempt_and_the_robot_returns_to_staging(tmp_path):
    outcome, _metrics, sim = run_scenario("explore_dock", tree=goal_tree(tmp_path, FACING_AWAY, attempts=2))
    assert not outcome.success
    assert outcome.reason == "dock not seen within 5 s"
    end = sim.robot_pose
    assert math.hypot(end.x - 1.05, end.y - 4.0) < 0.25  # at staging, not where the last attempt left it
    # two attempts of 5 s each, plus driving: the retries happened, and nothing waited longer than asked
    assert 10.0 < outcome.sim_time_s < 30.0


@pytest.mark.slow
def test_docking_at_a_staging_pose_from_the_dock_database_ends_docked_within_tolerance(tmp_path):
    outcome, _metrics, _sim = run_scenario("explore_dock", tree=goal_tree(tmp_path, STAGING, attempts=4))
    assert outcome.success, outcome.reason
    assert outcome.reason == "docked within tolerance"
    dock = outcome.metrics["dock"]
    assert abs(dock["lateral_m"]) <= 0.03 and abs(dock["distance_m"]) <= 0.025
