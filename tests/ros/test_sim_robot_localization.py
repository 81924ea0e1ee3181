"""Over ROS, a simulated robot whose localization is real (issue 33): ``mission sim-robot`` under the typical
profile publishes its wheels' drifting odometry on /odom and AMCL's estimate on /amcl_pose — only once the
robot has moved, as Nav2's amcl does — while /sim/ground_truth keeps the truth. Two processes over DDS."""

from __future__ import annotations

import json
import math
import os
import time

import pytest
from geometry_msgs.msg import PoseWithCovarianceStamped, Twist
from nav_msgs.msg import Odometry
from std_msgs.msg import String

from mission.ros.ros_adapter import LATCHED
from tests.helpers.ros_env import ROOT, ROS_ENV, NodeProcess, RosClient, clean_shm, wait_for

pytestmark = pytest.mark.ros

MISSION = str(ROOT / ".venv" / "bin" / "mission")


def test_over_ros_the_wheels_drift_and_amcl_updates_only_after_the_robot_has_moved(tmp_path):
    config = tmp_path / "typical.yaml"
    config.write_text("sim:\n  realism: typical\n")
    cmd = [MISSION, "sim-robot", "--scenario", "follow_open", "--seed", "3", "--config", str(config)]
    robot = NodeProcess([*cmd, "--max-duration", "14"], {**os.environ, **ROS_ENV}, tmp_path / "robot.log")
    client = RosClient()
    try:
        client.subscribe(PoseWithCovarianceStamped, "/amcl_pose", LATCHED)
        client.subscribe(Odometry, "/odom")
        client.subscribe(String, "/sim/ground_truth")
        wait_for(lambda: len(client.messages("/sim/ground_truth")) > 20, 60, "the sim-robot's ground truth")
        time.sleep(1.0)  # standing still: the corrector has nothing to update on
        assert client.messages("/amcl_pose") == []
        drive = client.node.create_publisher(Twist, "/cmd_vel", 10)
        forward = Twist()
        forward.linear.x = 0.3
        deadline = time.monotonic() + 30
        while not client.messages("/amcl_pose") and time.monotonic() < deadline:
            drive.publish(forward)
            time.sleep(0.05)
        amcl = wait_for(lambda: client.messages("/amcl_pose"), 5, "/amcl_pose after the robot moved")
        truths = [json.loads(m.data) for m in client.messages("/sim/ground_truth")]
        first = amcl[0]
        t = first.header.stamp.sec + first.header.stamp.nanosec * 1e-9
        start = truths[0]["robot"]
        then = min(truths, key=lambda g: abs(g["t"] - t))["robot"]
        assert math.hypot(then[0] - start[0], then[1] - start[1]) >= 0.24  # AMCL's update_min_d, 0.25 m
        p = first.pose.pose.position
        assert math.hypot(p.x - then[0], p.y - then[1]) < 0.15  # its estimate: the truth within its noise
        assert first.header.frame_id == "map" and first.pose.covariance[0] == pytest.approx(0.03**2)
        by_stamp = {round(g["t"], 3): g for g in truths}
        last, now = next(  # the newest odometry whose step's ground truth has arrived too
            (o, by_stamp[k])
            for o in reversed(client.messages("/odom"))
            if (k := round(o.header.stamp.sec + o.header.stamp.nanosec * 1e-9, 3)) in by_stamp
        )
        drift = math.hypot(last.pose.pose.position.x - now["robot"][0], last.pose.pose.position.y - now["robot"][1])
        assert 1e-4 < drift < 0.1  # the wheels' odometry, off the truth by a percent of the way driven
    finally:
        client.close()
        robot.stop()
        clean_shm()
