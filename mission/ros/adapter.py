"""The ROS 2 world adapter: live topics in, Nav2-style commands out (rclpy).

Subscriptions only cache (a :class:`~mission.ros.sensor_cache.SensorCache` converts and pairs);
``sense()`` writes the newest of everything to the blackboard once per tick and ``act()`` turns the
tree's intent into messages:

* ``/goal/nav_goal``      → ``/goal_pose`` (each new goal once: Nav2's bt_navigator starts a navigation
  per message) and ``/target_goal_pose`` (the current goal, re-sent at ``target_goal_hz``);
* ``/goal/twist``         → ``/cmd_vel`` every tick while set, one zero twist when it is cleared;
* ``/goal/dock_setpoint`` → ``detected_dock_pose`` for Nav2's opennav_docking (each new setpoint).

Without nav2_msgs (not on PyPI) there is no action feedback, so the navigator status is inferred:
RUNNING from the moment a goal is sent, SUCCEEDED once the robot is within ``goal_tolerance_m`` of it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import py_trees
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy, qos_profile_sensor_data

from mission.core import blackboard as bbk
from mission.core import se3
from mission.core.types import DockSetpoint, NavGoal, NavStatus, Twist
from mission.ros.conversions import pose2d_stamped, pose_stamped, twist_msg
from mission.ros.messages import RclpyMessages
from mission.ros.sensor_cache import SensorCache


@dataclass
class RosTopics:
    """Topic names and frames (the node's ROS parameters of the same names)."""

    image_topic: str = "/camera/image_raw"
    camera_info_topic: str = "/camera/camera_info"
    depth_topic: str = "/camera/depth/image_raw"
    odom_topic: str = "/odom"
    scan_topic: str = "/scan"
    map_topic: str = "/map"
    amcl_topic: str = "/amcl_pose"
    goal_topic: str = "/goal_pose"
    target_goal_topic: str = "/target_goal_pose"
    cmd_vel_topic: str = "/cmd_vel"
    dock_pose_topic: str = "detected_dock_pose"
    camera_frame: str = "camera_optical_frame"
    base_frame: str = "base_link"
    map_frame: str = "map"
    camera_info_tolerance_s: float = 0.1
    target_goal_hz: float = 10.0
    goal_tolerance_m: float = 0.25
    # the camera body frame (x forward, y left, z up) in the base frame: x, y, z (m), roll, pitch, yaw (rad)
    camera_xyz_rpy: list[float] = field(default_factory=lambda: [0.0, 0.0, 0.3, 0.0, 0.0, 0.0])

    def camera_extrinsics(self) -> np.ndarray:
        """T_base_optical from ``camera_xyz_rpy`` (the optical frame is the body frame turned to z forward)."""
        x, y, z, roll, pitch, yaw = (float(v) for v in self.camera_xyz_rpy)
        r_body = se3.rot_z(yaw) @ se3.rot_y(pitch) @ se3.rot_x(roll)
        return se3.transform(r_body @ se3.R_BODY_OPTICAL, (x, y, z))


class RosAdapter:
    """WorldAdapter over rclpy topics. Construct with a node; ``setup()`` creates the endpoints."""

    def __init__(self, node: Node, topics: RosTopics | None = None) -> None:
        self.node = node
        self.topics = topics or RosTopics()
        self.msgs = RclpyMessages()
        log = node.get_logger()
        self.cache = SensorCache(
            camera_frame=self.topics.camera_frame,
            info_tolerance_s=self.topics.camera_info_tolerance_s,
            warn=log.warning,
        )
        self._subs: list = []
        self._pubs: dict[str, object] = {}
        self._frame_seq = 0
        self._goal: NavGoal | None = None
        self._goal_status = NavStatus.IDLE
        self._last_target_goal_pub = -math.inf
        self._twist_active = False
        self._dock_stamp: float | None = None

    # -- lifecycle ---------------------------------------------------------------------------------
    def setup(self) -> None:
        t, n, m = self.topics, self.node, self.msgs
        sensor = qos_profile_sensor_data
        latched = QoSProfile(
            depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL
        )
        reliable = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)
        c = self.cache
        self._subs = [
            n.create_subscription(m.cls("sensor_msgs/msg/Image"), t.image_topic,
                                  lambda msg: c.on_image(msg, t.image_topic), sensor),
            n.create_subscription(m.cls("sensor_msgs/msg/Image"), t.depth_topic,
                                  lambda msg: c.on_depth(msg, t.depth_topic), sensor),
            n.create_subscription(m.cls("sensor_msgs/msg/CameraInfo"), t.camera_info_topic,
                                  lambda msg: c.on_camera_info(msg, t.camera_info_topic), sensor),
            n.create_subscription(m.cls("nav_msgs/msg/Odometry"), t.odom_topic,
                                  lambda msg: c.on_odometry(msg, t.odom_topic), sensor),
            n.create_subscription(m.cls("sensor_msgs/msg/LaserScan"), t.scan_topic,
                                  lambda msg: c.on_scan(msg, t.scan_topic), sensor),
            n.create_subscription(m.cls("nav_msgs/msg/OccupancyGrid"), t.map_topic,
                                  lambda msg: c.on_map(msg, t.map_topic), latched),
            n.create_subscription(m.cls("geometry_msgs/msg/PoseWithCovarianceStamped"), t.amcl_topic,
                                  lambda msg: c.on_amcl_pose(msg, t.amcl_topic), reliable),
        ]  # fmt: skip
        pose = m.cls("geometry_msgs/msg/PoseStamped")
        self._pubs = {
            "goal": n.create_publisher(pose, t.goal_topic, reliable),
            "target_goal": n.create_publisher(pose, t.target_goal_topic, reliable),
            "cmd_vel": n.create_publisher(m.cls("geometry_msgs/msg/Twist"), t.cmd_vel_topic, reliable),
            "dock": n.create_publisher(pose, t.dock_pose_topic, reliable),
        }

    def close(self) -> None:
        for s in self._subs:
            self.node.destroy_subscription(s)
        for p in self._pubs.values():
            self.node.destroy_publisher(p)
        self._subs, self._pubs = [], {}

    def advance(self, dt: float) -> None:
        """Live world: time passes on its own."""

    # -- world → blackboard ------------------------------------------------------------------------
    def now(self) -> float:
        return self.node.get_clock().now().nanoseconds * 1e-9

    def sense(self, bb: py_trees.blackboard.Client) -> None:
        frame = self.cache.take_frame()
        if frame is not None:
            self._frame_seq += 1
            bbk.set_(bb, bbk.FRAME, frame)
            bbk.set_(bb, bbk.FRAME_SEQ, self._frame_seq)
        bbk.set_(bb, bbk.CLOCK, self.now())
        state = self.cache.robot_state()
        bbk.set_(bb, bbk.ROBOT_STATE, state)
        bbk.set_(bb, bbk.SCAN, self.cache.scan)
        bbk.set_(bb, bbk.MAP, self.cache.map)
        bbk.set_(bb, bbk.CAMERA_EXTRINSICS, self.topics.camera_extrinsics())
        goal, tol = self._goal, self.topics.goal_tolerance_m
        reached = goal is not None and state is not None and state.pose.distance_to(goal.pose) <= tol
        if reached and self._goal_status == NavStatus.RUNNING:
            self._goal_status = NavStatus.SUCCEEDED
        bbk.set_(bb, bbk.NAV_STATUS, self._goal_status)
        stats = bbk.get(bb, bbk.PERCEPTION_STATS, None)
        stats = dict(stats) if isinstance(stats, dict) else {}
        stats["frames_dropped_transport"] = self.cache.stats.images_dropped
        bbk.set_(bb, bbk.PERCEPTION_STATS, stats)

    # -- blackboard → world ------------------------------------------------------------------------
    def act(self, bb: py_trees.blackboard.Client) -> None:
        now = self.now()
        t, m = self.topics, self.msgs
        goal = bbk.get(bb, bbk.NAV_GOAL, None)
        if isinstance(goal, NavGoal):
            if self._goal is None or goal.seq != self._goal.seq:
                self._goal = goal
                self._goal_status = NavStatus.RUNNING
                self._pubs["goal"].publish(pose2d_stamped(m, goal.pose, now, goal.frame_id or t.map_frame))
            if now - self._last_target_goal_pub >= 1.0 / t.target_goal_hz - 1e-3:
                self._last_target_goal_pub = now
                self._pubs["target_goal"].publish(pose2d_stamped(m, goal.pose, now, goal.frame_id or t.map_frame))
        elif goal is None and self._goal is not None:
            self._goal, self._goal_status = None, NavStatus.IDLE

        twist = bbk.get(bb, bbk.TWIST, None)
        if isinstance(twist, Twist):
            self._pubs["cmd_vel"].publish(twist_msg(m, twist))
            self._twist_active = True
        elif self._twist_active:
            self._pubs["cmd_vel"].publish(twist_msg(m, Twist()))  # stop once when the tree lets go
            self._twist_active = False

        dock = bbk.get(bb, bbk.DOCK_SETPOINT, None)
        if isinstance(dock, DockSetpoint) and dock.stamp != self._dock_stamp:
            self._dock_stamp = dock.stamp
            pos, quat = dock.pose_camera
            frame = bbk.get(bb, bbk.FRAME, None)
            frame_id = getattr(frame, "frame_id", None) or t.camera_frame
            self._pubs["dock"].publish(pose_stamped(m, se3.from_pos_quat(pos, quat), dock.stamp, frame_id))
