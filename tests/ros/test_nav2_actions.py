"""Nav2's docking and following actions served by our trees, closed loop over real DDS between processes.

Three processes, as on a robot whose team already runs Nav2: ``mission sim-robot --serve`` (the pybullet world
behind ROS topics, scoring against ground truth on ``/sim/ground_truth``), the colcon-installed node in server
mode exactly as ``ros2 run mission tree --tree none --params-file FILE`` starts it, and a client written only
from nav2_msgs' .action definitions (tests/helpers/nav2_task_client.py: rclpy and nav2_msgs, nothing of ours).
The params file is a Nav2 user's docking_server section (mission/ros/params/explore_dock.yaml): one dock type,
one dock whose pose is the robot's base when docked. For following, the scenario gets an ``external_detector``:
the sim-robot publishes the target's pose (a person tracker's stand-in: line of sight, noise, dropouts) on
``/target_pose`` and as the TF frame ``target``, and the goal names one or the other.
"""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import pytest
import yaml

from tests.helpers.ros_env import ROOT, ROS_ENV, TREE_EXE, NodeProcess, build_ros, clean_shm, installed_env

pytestmark = pytest.mark.ros

MISSION = str(ROOT / ".venv" / "bin" / "mission")
CONFIG = str(ROOT / "mission" / "configs" / "sim_aruco.yaml")
PARAMS = ROOT / "mission" / "ros" / "params" / "explore_dock.yaml"
CLIENT = ROOT / "bench" / "nav2_task_client.py"  # a Nav2 user's client: rclpy and nav2_msgs only
DOCK_POSE = [0.47, 4.0, math.pi]  # home_dock's pose in PARAMS: the base when docked
# DockRobot's constants (nav2_msgs/action/DockRobot.action)
DOCK_NOT_IN_DB, FAILED_TO_DETECT_DOCK = 901, 904
NAV_TO_STAGING_POSE, INITIAL_PERCEPTION, CONTROLLING, RETRY = 1, 2, 3, 5
# FollowObject's (nav2_msgs/action/FollowObject.action)
FAILED_TO_DETECT_OBJECT = 902
FOLLOW_INITIAL_PERCEPTION, FOLLOW_CONTROLLING, FOLLOW_RETRY = 1, 2, 4


def tracked_scenario(tmp: Path, base: str = "follow_occlusion", **detector: object) -> str:
    """`base` with an external detector reporting the target (module doc); the scenario file's path."""
    data = yaml.safe_load((ROOT / "sim" / "scenarios" / f"{base}.yaml").read_text())
    data["external_detector"] = {"topic": "/target_pose", "frame": "target", **detector}
    path = tmp / f"{base}_tracked.yaml"
    path.write_text(yaml.safe_dump(data))
    return str(path)


@contextmanager
def served(
    tmp: Path,
    params: Path = PARAMS,
    duration: float = 200.0,
    scenario: str = "explore_dock",
    node_params: tuple[str, ...] = (),
) -> Iterator[dict[str, str]]:
    """sim-robot (`scenario`, serving) and the node in server mode; yields the client's environment."""
    build_ros()
    env = installed_env()
    node = NodeProcess(
        [
            str(TREE_EXE),
            "--config",
            CONFIG,
            "--tree",
            "none",
            "--params-file",
            str(params),
            "--ros-args",
            "-p",
            "use_sim_time:=true",
            *[arg for p in node_params for arg in ("-p", p)],
        ],
        env,
        tmp / "node.log",
    )
    robot = NodeProcess(
        [
            MISSION,
            "sim-robot",
            "--scenario",
            scenario,
            "--serve",
            "--config",
            CONFIG,
            "--max-duration",
            str(duration),
        ],
        {**os.environ, **ROS_ENV},
        tmp / "robot.log",
    )
    try:
        yield env
    except BaseException:
        print("--- node log\n" + node.log()[-4000:] + "\n--- sim-robot log\n" + robot.log()[-3000:])
        raise
    finally:
        robot.stop()
        node.stop()
        clean_shm()


def run_client(env: dict[str, str], plan: list[dict], timeout: float = 150.0) -> list[dict]:
    """Run the plan with the Nav2 user's client; its events."""
    proc = subprocess.run(
        [sys.executable, str(CLIENT), json.dumps(plan), str(timeout)],
        env=env,
        capture_output=True,
        text=True,
        timeout=timeout * len(plan) + 60,
        check=False,
    )
    events = [json.loads(line) for line in proc.stdout.splitlines() if line.startswith("{")]
    assert proc.returncode == 0, f"client exited {proc.returncode}: {proc.stderr[-2000:]}\n{proc.stdout}"
    return events


def results(events: list[dict]) -> list[dict]:
    return [e for e in events if e["event"] == "result"]


def states(events: list[dict]) -> list[int]:
    return [e["state"] for e in events if e["event"] == "feedback"]


def docked_within_tolerance(result: dict) -> bool:
    dock = result["truth"]["dock"]  # ground truth: the camera against the tag, as `mission run` scores docking
    return dock["lateral_m"] <= 0.03 and dock["distance_m"] <= 0.025 and dock["skew_deg"] <= 10.0


def test_an_unknown_dock_a_cancel_and_a_preemption_as_a_nav2_client_sees_them(tmp_path):
    """Not in the database: DOCK_NOT_IN_DB at once, the robot not moved. Canceled on the way to staging: CANCELED.
    A dock_robot goal preempted by a dock-by-pose goal: the first ABORTED, the second docks within tolerance."""
    plan = [
        {"dock": {"id": "kitchen_dock"}},
        {"dock": {"id": "home_dock"}, "cancel_after_s": 3.0},
        {"dock": {"id": "home_dock"}, "preempt_after_s": 2.0, "then": {"dock": {"pose": DOCK_POSE}}},
    ]
    with served(tmp_path) as env:
        events = run_client(env, plan)
    unknown, canceled, preempted, by_pose = results(events)
    assert unknown["status"] == "ABORTED" and unknown["error_code"] == DOCK_NOT_IN_DB
    assert unknown["error_msg"] == "dock 'kitchen_dock' is not in the dock database; known: home_dock"
    assert canceled["status"] == "CANCELED"
    assert preempted["status"] == "ABORTED" and preempted["error_msg"] == "preempted by a newer goal"
    assert by_pose["status"] == "SUCCEEDED" and by_pose["success"], by_pose
    assert docked_within_tolerance(by_pose), by_pose["truth"]
    assert sorted(set(states(events))) == [NAV_TO_STAGING_POSE, INITIAL_PERCEPTION, CONTROLLING]


@pytest.mark.slow
def test_dock_by_id_then_undock_then_dock_by_pose(tmp_path):
    """The nav2_simple_commander sequence: dockRobotByID, undockRobot (back out to the staging pose, with the
    dock type the server docked at), dockRobotByPose with the dock's pose and its type."""
    plan = [
        {"dock": {"id": "home_dock"}},
        {"undock": {}},
        {"dock": {"pose": DOCK_POSE, "type": "wall_tag_dock", "navigate": False}},
    ]
    with served(tmp_path) as env:
        events = run_client(env, plan)
    by_id, undock, by_pose = results(events)
    assert by_id["status"] == "SUCCEEDED" and docked_within_tolerance(by_id), by_id
    assert undock["status"] == "SUCCEEDED" and undock["success"], undock
    x, y, yaw = undock["truth"]["robot"]
    staging = (DOCK_POSE[0] + 0.7, DOCK_POSE[1])  # 0.7 m back along the docked heading (facing −x)
    assert math.hypot(x - staging[0], y - staging[1]) < 0.06
    assert abs(math.atan2(math.sin(yaw - math.pi), math.cos(yaw - math.pi))) < 0.06
    # undocked at the staging pose, the robot is within dock_prestaging_tolerance: it docks from here
    assert by_pose["status"] == "SUCCEEDED" and docked_within_tolerance(by_pose), by_pose


def test_an_unknown_dock_leaves_the_robot_where_it_was(tmp_path):
    with served(tmp_path, duration=60.0) as env:
        events = run_client(env, [{"dock": {"id": "kitchen_dock"}}, {"dock": {"id": "kitchen_dock"}}])
    first, second = results(events)
    assert first["error_code"] == second["error_code"] == DOCK_NOT_IN_DB
    x0, y0, yaw0 = first["truth"]["robot"]
    x1, y1, yaw1 = second["truth"]["robot"]
    assert math.hypot(x1 - x0, y1 - y0) < 0.005 and abs(yaw1 - yaw0) < 0.005


def test_goals_a_server_cannot_run_end_at_once_with_why_and_the_node_serves_the_next(tmp_path):
    """A dock_tree of the user's that does not load, and a follow goal naming neither a topic nor a frame."""
    bad_tree = tmp_path / "my_dock.xml"
    bad_tree.write_text('<root BTCPP_format="4"><BehaviorTree ID="X"><Dock/></BehaviorTree></root>')
    with served(tmp_path, duration=60.0, node_params=(f"dock_tree:={bad_tree}",)) as env:
        events = run_client(env, [{"dock": {"id": "home_dock"}}, {"follow": {}}, {"dock": {"id": "kitchen_dock"}}])
        # the same from a terminal: `mission task`, nav2_simple_commander's calls on our own client
        cli = subprocess.run(
            [MISSION, "task", "dock", "--id", "kitchen_dock", "--server-timeout", "20"],
            env={**os.environ, **ROS_ENV},
            capture_output=True,
            text=True,
            timeout=60,
            check=False,
        )
    bad, nothing, unknown = results(events)
    assert bad["status"] == "ABORTED" and bad["error_code"] == 999  # UNKNOWN
    assert bad["error_msg"].startswith(f"the tree {bad_tree} cannot run: {bad_tree}:1"), bad["error_msg"]
    assert nothing["error_code"] == FAILED_TO_DETECT_OBJECT
    assert nothing["error_msg"] == "No pose topic or target frame provided."
    assert unknown["error_code"] == DOCK_NOT_IN_DB  # the node still serves
    assert cli.returncode == 1, cli.stderr
    assert cli.stdout.strip().splitlines()[-1] == (
        "FAILED: DOCK_NOT_IN_DB (901): dock 'kitchen_dock' is not in the dock database; known: home_dock"
    )


@pytest.mark.slow
def test_a_dock_the_camera_cannot_see_fails_to_detect_it_after_every_retry_and_returns_to_staging(tmp_path):
    """A dock pose with no tag in front of it: each attempt stages and waits initial_perception_timeout; after
    max_retries the result is FAILED_TO_DETECT_DOCK with num_retries = max_retries, and the robot is back at
    the staging pose (where opennav_docking would leave it wherever the last attempt ended)."""
    params = tmp_path / "params.yaml"
    params.write_text(PARAMS.read_text().replace("max_retries: 3", "max_retries: 1"))
    blank_wall = [4.0, 7.3, math.pi / 2]  # facing the north wall, where no tag hangs
    with served(tmp_path, params) as env:
        events = run_client(env, [{"dock": {"pose": blank_wall}}], timeout=180.0)
    (result,) = results(events)
    assert result["status"] == "ABORTED" and result["error_code"] == FAILED_TO_DETECT_DOCK, result
    assert result["num_retries"] == 1
    assert "dock" in result["error_msg"]
    assert RETRY in states(events)
    x, y, _ = result["truth"]["robot"]
    staging = (blank_wall[0], blank_wall[1] - 0.7)
    assert math.hypot(x - staging[0], y - staging[1]) < 0.3


def follow_states(events: list[dict]) -> list[int]:
    return [e["state"] for e in events if e["event"] == "feedback" and e["action"] == "follow"]


def test_following_poses_on_a_topic_through_an_occlusion_recovers_the_object(tmp_path):
    """follow_occlusion: the target walks behind a row of pillars, so the tracker loses it for seconds. The goal
    follows, retries (LOST, then SEARCH if the loss lasts), follows again, and succeeds at max_duration."""
    with served(tmp_path, scenario=tracked_scenario(tmp_path), duration=90.0) as env:
        events = run_client(env, [{"follow": {"topic": "/target_pose", "max_duration": 32.0}}], timeout=90.0)
    (result,) = results(events)
    assert result["status"] == "SUCCEEDED" and result["error_code"] == 0, result
    assert 32.0 <= result["total_elapsed_time"] < 33.0
    seen = follow_states(events)
    assert seen[:2] == [FOLLOW_INITIAL_PERCEPTION, FOLLOW_CONTROLLING]
    lost_at = seen.index(FOLLOW_RETRY)
    assert FOLLOW_CONTROLLING in seen[lost_at:], f"the object was not followed again after the loss: {seen}"
    assert result["num_retries"] >= 1
    rx, ry, _ = result["truth"]["robot"]
    tx, ty, _ = result["truth"]["target"]
    assert math.hypot(tx - rx, ty - ry) < 2.5, result["truth"]


@pytest.mark.slow
def test_following_a_tf_frame(tmp_path):
    with served(tmp_path, scenario=tracked_scenario(tmp_path, "follow_open"), duration=60.0) as env:
        events = run_client(env, [{"follow": {"frame": "target", "max_duration": 30.0}}], timeout=60.0)
    (result,) = results(events)
    assert result["status"] == "SUCCEEDED", result
    assert FOLLOW_CONTROLLING in follow_states(events)
    rx, ry, _ = result["truth"]["robot"]
    tx, ty, _ = result["truth"]["target"]
    assert math.hypot(tx - rx, ty - ry) < 2.5, result["truth"]


@pytest.mark.slow
def test_a_pose_topic_that_goes_silent_fails_to_detect_the_object_after_the_search_not_before(tmp_path):
    """The tracker dies at 12 s. opennav_following gives up after its retries (FAILED_TO_DETECT_OBJECT within
    seconds); here the ladder searches first (turn to the bearing, the belief's viewpoints, coverage), and
    only then is the object given up with the same code."""
    scenario = tracked_scenario(tmp_path, "follow_open", silent_after_s=12.0)
    with served(tmp_path, scenario=scenario, duration=200.0) as env:
        events = run_client(env, [{"follow": {"topic": "/target_pose"}}], timeout=180.0)
    (result,) = results(events)
    assert result["status"] == "ABORTED" and result["error_code"] == FAILED_TO_DETECT_OBJECT, result
    assert "gave up" in result["error_msg"], result["error_msg"]
    assert FOLLOW_RETRY in follow_states(events)
    assert result["total_elapsed_time"] > 12.0 + 25.0  # the search ran: at least the belief's 25 s
