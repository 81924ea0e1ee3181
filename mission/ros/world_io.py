"""What the ROS adapter and replay share: topic settings, blackboard writing and command translation.

:class:`CachedWorld` is a WorldAdapter whose inputs arrive as ROS messages into a
:class:`~mission.ros.sensor_cache.SensorCache` and whose outputs leave as ROS messages through
:meth:`CachedWorld.emit`. The live adapter (:mod:`mission.ros.adapter`) emits to rclpy publishers;
replay (:mod:`mission.ros.replay`) feeds the cache from a bag and keeps what the tree commanded. No rclpy.

Commands (intent on the blackboard → messages):

* ``/goal/nav_goal``      → ``goal`` (``/goal_pose``) once per new goal (Nav2's bt_navigator starts a
  navigation per message) and ``target_goal`` (``/target_goal_pose``), the current goal at ~10 Hz;
* ``/goal/twist``         → ``cmd_vel`` every tick while set, one zero twist when it is cleared;
* ``/goal/dock_setpoint`` → ``dock`` (``detected_dock_pose`` for Nav2's opennav_docking) once per setpoint.

Without nav2_msgs (not on PyPI) there is no action feedback, so the navigator status is inferred:
RUNNING from the moment a goal is sent, SUCCEEDED once the robot is within ``goal_tolerance_m``.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import py_trees

from mission.core import blackboard as bbk
from mission.core import se3
from mission.core.types import DockSetpoint, NavGoal, NavStatus, Twist
from mission.ros.conversions import pose2d_stamped, pose_stamped, twist_msg
from mission.ros.messages import MessageFactory
from mission.ros.sensor_cache import SensorCache


@dataclass
class RosTopics:
    """Topic names, frames and tolerances (the node's ROS parameters of the same names)."""

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


class CachedWorld:
    """The shared half of a ROS-message world. Subclasses provide ``now()`` and ``emit()``."""

    def __init__(self, topics: RosTopics, msgs: MessageFactory, warn: Any = lambda message: None) -> None:
        self.topics = topics
        self.msgs = msgs
        self.cache = SensorCache(
            camera_frame=topics.camera_frame, info_tolerance_s=topics.camera_info_tolerance_s, warn=warn
        )
        self._frame_seq = 0
        self._goal: NavGoal | None = None
        self._goal_status = NavStatus.IDLE
        self._last_target_goal = -math.inf
        self._twist_active = False
        self._dock_stamp: float | None = None

    # -- to implement ------------------------------------------------------------------------------
    def now(self) -> float:
        raise NotImplementedError

    def emit(self, kind: str, msg: Any) -> None:
        """Send a command message; kind is goal | target_goal | cmd_vel | dock."""
        raise NotImplementedError

    # -- WorldAdapter ------------------------------------------------------------------------------
    def advance(self, dt: float) -> None:
        """ROS worlds run on their own clock."""

    def sense(self, bb: py_trees.blackboard.Client) -> None:
        frame = self.cache.take_frame()
        state = self.cache.robot_state()
        extrinsics = self.topics.camera_extrinsics()
        if frame is not None:
            if state is not None:
                # Where the camera was in the map when the image was taken (latching sources need it).
                p = state.pose
                frame = dataclasses.replace(
                    frame, T_anchor_camera=se3.compose(se3.planar(p.x, p.y, p.yaw), extrinsics),
                    anchor_frame=self.topics.map_frame,
                )  # fmt: skip
            self._frame_seq += 1
            bbk.set_(bb, bbk.FRAME, frame)
            bbk.set_(bb, bbk.FRAME_SEQ, self._frame_seq)
        bbk.set_(bb, bbk.CLOCK, self.now())
        bbk.set_(bb, bbk.ROBOT_STATE, state)
        bbk.set_(bb, bbk.SCAN, self.cache.scan)
        bbk.set_(bb, bbk.MAP, self.cache.map)
        bbk.set_(bb, bbk.CAMERA_EXTRINSICS, extrinsics)
        goal, tol = self._goal, self.topics.goal_tolerance_m
        reached = goal is not None and state is not None and state.pose.distance_to(goal.pose) <= tol
        if reached and self._goal_status == NavStatus.RUNNING:
            self._goal_status = NavStatus.SUCCEEDED
        bbk.set_(bb, bbk.NAV_STATUS, self._goal_status)
        stats = bbk.get(bb, bbk.PERCEPTION_STATS, None)
        stats = dict(stats) if isinstance(stats, dict) else {}
        stats["frames_dropped_transport"] = self.cache.stats.images_dropped
        bbk.set_(bb, bbk.PERCEPTION_STATS, stats)

    def act(self, bb: py_trees.blackboard.Client) -> None:
        now = self.now()
        t, m = self.topics, self.msgs
        goal = bbk.get(bb, bbk.NAV_GOAL, None)
        if isinstance(goal, NavGoal):
            frame_id = goal.frame_id or t.map_frame
            if self._goal is None or goal.seq != self._goal.seq:
                self._goal = goal
                self._goal_status = NavStatus.RUNNING
                self.emit("goal", pose2d_stamped(m, goal.pose, now, frame_id))
            if now - self._last_target_goal >= 1.0 / t.target_goal_hz - 1e-3:
                self._last_target_goal = now
                self.emit("target_goal", pose2d_stamped(m, goal.pose, now, frame_id))
        elif goal is None and self._goal is not None:
            self._goal, self._goal_status = None, NavStatus.IDLE

        twist = bbk.get(bb, bbk.TWIST, None)
        if isinstance(twist, Twist):
            self.emit("cmd_vel", twist_msg(m, twist))
            self._twist_active = True
        elif self._twist_active:
            self.emit("cmd_vel", twist_msg(m, Twist()))  # stop once when the tree lets go
            self._twist_active = False

        dock = bbk.get(bb, bbk.DOCK_SETPOINT, None)
        if isinstance(dock, DockSetpoint) and dock.stamp != self._dock_stamp:
            self._dock_stamp = dock.stamp
            pos, quat = dock.pose_camera
            frame = bbk.get(bb, bbk.FRAME, None)
            frame_id = getattr(frame, "frame_id", None) or t.camera_frame
            self.emit("dock", pose_stamped(m, se3.from_pos_quat(pos, quat), dock.stamp, frame_id))
