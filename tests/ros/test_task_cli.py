"""`mission task` as a user runs it (a subprocess: `python -m mission task …`), over real rclpy and the shared-memory
DDS profile, against fake docking and following servers in the test process (tests/helpers/nav2_servers.py):
the goal it sends, the feedback lines, the result line with the error code's name, the exit status, no server,
and Ctrl-C canceling the goal as `ros2 action send_goal` does."""

from __future__ import annotations

import math
import os
import queue
import signal
import subprocess
import sys
import threading
import time

import pytest
from builtin_interfaces.msg import Duration

from tests.helpers.nav2_servers import Script

pytestmark = pytest.mark.ros

DISCOVERY = ["--server-timeout", "10"]  # discovery over shared memory can take 2–3 s on a busy machine


@pytest.fixture
def servers(fake):
    for name in fake.scripts:
        fake.scripts[name] = lambda goal: Script()
    return fake


@pytest.fixture
def types(nav2):
    return {name: nav2.get("action", name) for name in ("DockRobot", "UndockRobot", "FollowObject")}


def mission_task(*args: str, timeout: float = 60) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "mission", "task", *args], capture_output=True, text=True, timeout=timeout, check=False
    )


def lines(text: str) -> list[str]:
    return text.strip().splitlines()


def test_dock_by_id_prints_each_state_by_name_and_succeeds(servers, types):
    fb = types["DockRobot"].Feedback
    servers.scripts["dock_robot"] = lambda goal: Script(
        feedback=[
            {"state": fb.NAV_TO_STAGING_POSE},
            {"state": fb.NAV_TO_STAGING_POSE},  # no change: no new line
            {"state": fb.INITIAL_PERCEPTION},
            {"state": fb.CONTROLLING},
            {"state": fb.RETRY, "num_retries": 1},
            {"state": fb.CONTROLLING, "num_retries": 1},
        ],
        result={"success": True, "num_retries": 1},
        period_s=0.02,
    )
    proc = mission_task("dock", "--id", "home_dock", *DISCOVERY)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    out = lines(proc.stdout)
    states = [line.split(": ", 1)[1].split(" (")[0] for line in out if line.startswith("dock_robot: ") and "(" in line]
    assert states[-5:] == ["NAV_TO_STAGING_POSE", "INITIAL_PERCEPTION", "CONTROLLING", "RETRY", "CONTROLLING"]
    assert any(line.startswith("dock_robot: RETRY (retries 1") for line in out)
    assert out[-1] == "SUCCEEDED: dock_robot (1 retry)"
    goal = servers.received("dock_robot")[-1].goal
    assert (goal.use_dock_id, goal.dock_id, goal.navigate_to_staging_pose) == (True, "home_dock", True)


def test_a_dock_not_in_the_database_is_exit_1_with_the_error_codes_name_and_message(servers):
    servers.scripts["dock_robot"] = lambda goal: Script(
        outcome="abort",
        result={"success": False, "error_code": 901, "error_msg": f"dock '{goal.dock_id}' is not in the database"},
    )
    proc = mission_task("dock", "--id", "x", *DISCOVERY)
    assert proc.returncode == 1, proc.stdout + proc.stderr
    assert lines(proc.stdout)[-1] == "FAILED: DOCK_NOT_IN_DB (901): dock 'x' is not in the database"


def test_dock_by_pose_sends_the_pose_in_its_frame_with_the_type_and_no_navigation(servers):
    proc = mission_task(
        "dock", "--pose", "1.5", "-2", "1.2", "--type", "charging_dock", "--frame", "odom", "--no-nav",
        "--max-staging-time", "60", *DISCOVERY,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stdout + proc.stderr
    goal = servers.received("dock_robot")[-1].goal
    assert (goal.use_dock_id, goal.dock_type, goal.navigate_to_staging_pose) == (False, "charging_dock", False)
    assert goal.max_staging_time == 60.0
    pose = goal.dock_pose
    assert pose.header.frame_id == "odom"
    assert (pose.header.stamp.sec, pose.header.stamp.nanosec) == (0, 0)  # "latest", whatever the server's clock
    assert (pose.pose.position.x, pose.pose.position.y, pose.pose.position.z) == (1.5, -2.0, 0.0)
    q = pose.pose.orientation
    assert (q.x, q.y, q.z, q.w) == pytest.approx((0.0, 0.0, math.sin(0.6), math.cos(0.6)))
    mission_task("dock", "--pose", "0", "0", "0", *DISCOVERY)
    goal = servers.received("dock_robot")[-1].goal
    assert (goal.dock_pose.header.frame_id, goal.dock_type, goal.navigate_to_staging_pose) == ("map", "", True)


def test_undock_sends_the_dock_type(servers):
    proc = mission_task("undock", "--type", "charging_dock", *DISCOVERY)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert lines(proc.stdout)[-1] == "SUCCEEDED: undock_robot"
    assert servers.received("undock_robot")[-1].goal.dock_type == "charging_dock"


def test_follow_by_topic_or_frame_with_a_max_duration(servers, types):
    fb = types["FollowObject"].Feedback
    servers.scripts["follow_object"] = lambda goal: Script(
        feedback=[{"state": fb.INITIAL_PERCEPTION}, {"state": fb.CONTROLLING}],
        result={"total_elapsed_time": Duration(sec=2, nanosec=500_000_000)},
    )
    proc = mission_task("follow", "--topic", "/person_pose", "--max-duration", "2.5", *DISCOVERY)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    out = lines(proc.stdout)
    assert [line.split(" (")[0] for line in out[-3:-1]] == [
        "follow_object: INITIAL_PERCEPTION",
        "follow_object: CONTROLLING",
    ]
    assert out[-1] == "SUCCEEDED: follow_object (after 2.5 s)"
    goal = servers.received("follow_object")[-1].goal
    assert (goal.pose_topic, goal.tracked_frame, goal.max_duration.sec, goal.max_duration.nanosec) == (
        "/person_pose", "", 2, 500_000_000,
    )  # fmt: skip


def test_following_a_frame_that_is_lost_is_exit_1_naming_the_following_error(servers):
    servers.scripts["follow_object"] = lambda goal: Script(
        outcome="abort", result={"error_code": 902, "error_msg": "no detection for 2.0 s, 3 retries used"}
    )
    proc = mission_task("follow", "--frame", "person", *DISCOVERY)
    assert proc.returncode == 1
    assert lines(proc.stdout)[-1] == "FAILED: FAILED_TO_DETECT_OBJECT (902): no detection for 2.0 s, 3 retries used"
    goal = servers.received("follow_object")[-1].goal
    assert (goal.pose_topic, goal.tracked_frame, goal.max_duration.sec) == ("", "person", 0)  # 0: no limit


def test_a_rejected_goal_is_exit_1(servers):
    servers.scripts["undock_robot"] = lambda goal: Script(accept=False)
    proc = mission_task("undock", *DISCOVERY)
    assert proc.returncode == 1
    assert lines(proc.stdout)[-1] == "FAILED: undock_robot: the server rejected the goal"


def test_no_server_is_exit_2_with_one_line_naming_the_action(servers):
    t0 = time.monotonic()
    proc = mission_task("dock", "--id", "home_dock", "--namespace", "nobody", "--server-timeout", "0.5")
    assert proc.returncode == 2, proc.stdout + proc.stderr
    err = lines(proc.stderr)
    assert len(err) == 1, proc.stderr
    assert err[0].startswith(
        "mission: error: /nobody/dock_robot: no nav2_msgs/action/DockRobot action server after 0.5 s"
    )
    assert "SUCCEEDED" not in proc.stdout and "FAILED" not in proc.stdout
    assert time.monotonic() - t0 < 30


def test_ctrl_c_cancels_the_running_goal_and_waits_for_its_end(servers, types):
    controlling = types["FollowObject"].Feedback.CONTROLLING
    servers.scripts["follow_object"] = lambda goal: Script(feedback=[{"state": controlling}], outcome="hold")
    proc = subprocess.Popen(
        [sys.executable, "-m", "mission", "task", "follow", "--topic", "/person_pose", *DISCOVERY],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env={**os.environ, "PYTHONUNBUFFERED": "1"},
    )  # fmt: skip
    out: queue.Queue[str] = queue.Queue()
    reader = threading.Thread(target=lambda: [out.put(line.rstrip("\n")) for line in proc.stdout], daemon=True)
    reader.start()
    seen: list[str] = []
    try:
        deadline = time.monotonic() + 30
        while not any(line.startswith("follow_object: CONTROLLING") for line in seen):
            assert time.monotonic() < deadline, f"no feedback line; so far: {seen}"
            try:
                seen.append(out.get(timeout=0.5))
            except queue.Empty:
                assert proc.poll() is None, f"exited {proc.returncode}: {seen} {proc.stderr.read()}"
        proc.send_signal(signal.SIGINT)
        code = proc.wait(timeout=15)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    reader.join(timeout=5)
    while not out.empty():
        seen.append(out.get())
    assert code == 130, (seen, proc.stderr.read())
    assert "follow_object: canceling the goal" in seen
    assert seen[-1] == "CANCELED: follow_object"
    goal = servers.received("follow_object")[-1]
    assert (goal.cancel_requested, goal.end) == (True, "canceled")
