"""What the ROS adapter and replay share: topic settings, blackboard writing and command translation.

:class:`CachedWorld` is a WorldAdapter whose inputs arrive as ROS messages into a
:class:`~mission.ros.sensor_cache.SensorCache` and whose outputs leave as ROS messages through
:meth:`CachedWorld.emit`. The live adapter (:mod:`mission.ros.ros_adapter`) emits to rclpy publishers;
replay (:mod:`mission.ros.bag_replay`) feeds the cache from a bag and keeps what the tree commanded. No rclpy.

Commands (intent on the blackboard → messages):

* ``/goal/nav_goal``      → ``goal`` (``/goal_pose``) once per new goal (Nav2's bt_navigator starts a
  navigation per message) and ``target_goal`` (``/target_goal_pose``), the current goal at ~10 Hz;
* ``/goal/twist``         → ``cmd_vel`` every tick while set, one zero twist when it is cleared;
* ``/goal/dock_setpoint`` → ``dock`` (``detected_dock_pose`` for Nav2's opennav_docking) once per setpoint.

Navigation goes through a :class:`Navigation`: the live node's default is Nav2's ``navigate_to_pose`` action
(mission/ros/nav_client.py: status and reason from the action's feedback and result); :class:`TopicNavigation`
publishes ``/goal_pose`` (bt_navigator's topic) and infers the status — RUNNING from the moment a goal is sent,
SUCCEEDED once the robot is within ``goal_tolerance_m`` — which is also what replay uses. A goal the tree lets
go of (``/goal/nav_goal`` cleared: the behaviour was halted) is cancelled.

Poses come from :class:`~mission.ros.frames.RobotFrames`: TF when the robot publishes it, the fallbacks
otherwise; a frame carries the camera pose at its own stamp. ``/robot/fault`` says why inputs cannot be
trusted (TF broken, the clock jumped back, images late); with the robot pose unknown no goal is sent, and the
navigation leaves see FAILED with that reason.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np
import py_trees

from mission.core import blackboard as bbk
from mission.core import se3
from mission.core.types import DockSetpoint, Frame, NavGoal, NavStatus, RobotState, Twist
from mission.ros.conversions import pose2d_stamped, pose_stamped, twist_msg
from mission.ros.frames import RobotFrames
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
    odom_frame: str = "odom"
    camera_info_tolerance_s: float = 0.1
    camera_exposure_s: float = 0.0  # the driver's exposure setting; 0 = not known
    target_goal_hz: float = 10.0
    goal_tolerance_m: float = 0.25
    tf_tolerance_s: float = 0.1  # an image this much newer than the last transform still gets it
    image_late_s: float = 0.5  # an image older than this on arrival is reported late (/robot/fault)
    # the camera body frame (x forward, y left, z up) in the base frame: x, y, z (m), roll, pitch, yaw (rad)
    camera_xyz_rpy: list[float] = field(default_factory=lambda: [0.0, 0.0, 0.3, 0.0, 0.0, 0.0])

    def camera_extrinsics(self) -> np.ndarray:
        """T_base_optical from ``camera_xyz_rpy`` (the optical frame is the body frame turned to z forward)."""
        x, y, z, roll, pitch, yaw = (float(v) for v in self.camera_xyz_rpy)
        r_body = se3.rot_z(yaw) @ se3.rot_y(pitch) @ se3.rot_x(roll)
        return se3.transform(r_body @ se3.R_BODY_OPTICAL, (x, y, z))


class Navigation(Protocol):
    """Where navigation goals go and what comes back (the action client, or /goal_pose)."""

    def send(self, goal: NavGoal, now: float, frame_id: str) -> None: ...

    def cancel(self) -> None: ...

    def status(self, state: RobotState | None, now: float) -> tuple[str, str]:
        """(NavStatus of the newest goal, the navigator's word on it)."""
        ...


class TopicNavigation:
    """Goals on /goal_pose (bt_navigator starts a navigation per message); the status inferred by distance."""

    def __init__(self, emit: Any, msgs: MessageFactory, tolerance_m: float) -> None:
        self.emit, self.msgs, self.tolerance_m = emit, msgs, tolerance_m
        self._goal: NavGoal | None = None
        self._status = NavStatus.IDLE

    def send(self, goal: NavGoal, now: float, frame_id: str) -> None:
        self._goal, self._status = goal, NavStatus.RUNNING
        self.emit("goal", pose2d_stamped(self.msgs, goal.pose, now, frame_id))

    def cancel(self) -> None:
        self._goal, self._status = None, NavStatus.IDLE

    def status(self, state: RobotState | None, now: float) -> tuple[str, str]:
        goal = self._goal
        reached = goal is not None and state is not None and state.pose.distance_to(goal.pose) <= self.tolerance_m
        if reached and self._status == NavStatus.RUNNING:
            self._status = NavStatus.SUCCEEDED
        return self._status, ""


CLOCK_JUMP_NOTICE_S = 2.0  # /robot/fault says the clock jumped back for this long (new time)


class CachedWorld:
    """The shared half of a ROS-message world. Subclasses provide ``now()`` and ``emit()``."""

    def __init__(
        self, topics: RosTopics, msgs: MessageFactory, warn: Any = lambda message: None, say: Any = None
    ) -> None:
        self.topics = topics
        self.msgs = msgs
        self.warn = warn
        self.cache = SensorCache(
            camera_frame=topics.camera_frame,
            info_tolerance_s=topics.camera_info_tolerance_s,
            warn=warn,
            exposure_s=topics.camera_exposure_s or None,
        )
        self.frames = RobotFrames(
            map_frame=topics.map_frame,
            odom_frame=topics.odom_frame,
            base_frame=topics.base_frame,
            fallback_mount=topics.camera_extrinsics(),
            tolerance_s=topics.tf_tolerance_s,
            say=say or (lambda m: None),
        )
        self.navigation: Navigation = TopicNavigation(self.emit, msgs, topics.goal_tolerance_m)
        self._frame_seq = 0
        self._goal: NavGoal | None = None
        self._last_target_goal = -math.inf
        self._twist_active = False
        self._dock_stamp: float | None = None
        self._fed_odom: float | None = None
        self._last_now: float | None = None
        self._jump: tuple[float, str] | None = None  # (new time, what happened) of the last backward jump
        self._late = ""  # images arrive late: why
        self.extra_fault = ""  # set by the live adapter's watchdog (the clock or the sensors stopped)
        self.on_time_jump: Any = lambda: None  # the node resets the perception stage's clock
        self.time_jumps = 0
        self.state: RobotState | None = None
        self._camera_frame_id = topics.camera_frame
        self.external: Any = None  # ExternalPoses while a FollowObject goal follows someone else's poses

    # -- to implement ------------------------------------------------------------------------------
    def now(self) -> float:
        raise NotImplementedError

    def emit(self, kind: str, msg: Any) -> None:
        """Send a command message; kind is goal | target_goal | cmd_vel | dock."""
        raise NotImplementedError

    # -- WorldAdapter ------------------------------------------------------------------------------
    def advance(self, dt: float) -> None:
        """ROS worlds run on their own clock."""

    def _feed_odometry(self) -> None:
        odom = self.cache.odom
        if odom is not None and odom.stamp != self._fed_odom:
            self._fed_odom = odom.stamp
            self.frames.on_odometry(odom)

    def _check_clock(self, now: float) -> None:
        last = self._last_now
        self._last_now = now
        if last is not None and now < last - 1e-6:
            self.time_jumps += 1
            self.frames.clear()
            self._fed_odom = None
            what = f"the clock jumped back from {last:.2f} s to {now:.2f} s: TF history cleared"
            self._jump = (now, what)
            self.warn(what)
            self.on_time_jump()

    def _place(self, frame: Frame, now: float) -> Frame:
        """The frame with the camera pose at its own stamp (when TF or the odometry history knows it)."""
        camera = frame.frame_id or self.topics.camera_frame
        t_map_camera, _why = self.frames.camera_in_map(self.cache, camera, float(frame.stamp))
        age = now - float(frame.stamp)
        late = self.topics.image_late_s
        self._late = f"camera images arrive {age:.2f} s late (> {late:g} s)" if late > 0 and age > late else ""
        sightings = () if self.external is None else self.external.take(self.frames, self.cache)
        if t_map_camera is None:
            return dataclasses.replace(frame, sightings=sightings) if sightings else frame
        return dataclasses.replace(
            frame, T_anchor_camera=t_map_camera, anchor_frame=self.topics.map_frame, sightings=sightings
        )

    def fault(self, now: float) -> str:
        """Why the inputs cannot be trusted now ('' when all is well)."""
        parts = [self.extra_fault, self.frames.fault, self._late]
        if self._jump is not None and now - self._jump[0] < CLOCK_JUMP_NOTICE_S:
            parts.append(self._jump[1])
        return "; ".join(p for p in parts if p)

    def sense_frame(self, bb: py_trees.blackboard.Client) -> bool:
        """Only the newest image (placed at its stamp) and the robot pose: for perception on arrival."""
        now = self.now()
        self._check_clock(now)
        self._feed_odometry()
        frame = self.cache.take_frame()
        if frame is None:
            return False
        self._frame_seq += 1
        self._camera_frame_id = frame.frame_id or self.topics.camera_frame
        bbk.set_(bb, bbk.FRAME, self._place(frame, now))
        bbk.set_(bb, bbk.FRAME_SEQ, self._frame_seq)
        bbk.set_(bb, bbk.CAMERA_EXTRINSICS, self.frames.camera_mount(self._camera_frame_id))
        bbk.set_(bb, bbk.ROBOT_STATE, self.frames.robot_state(self.cache, now))
        return True

    def sense(self, bb: py_trees.blackboard.Client) -> None:
        now = self.now()
        self.sense_frame(bb)
        state = self.state = self.frames.robot_state(self.cache, now)
        bbk.set_(bb, bbk.CLOCK, now)
        bbk.set_(bb, bbk.ROBOT_STATE, state)
        bbk.set_(bb, bbk.SCAN, self.cache.scan)
        bbk.set_(bb, bbk.MAP, self.cache.map)
        bbk.set_(bb, bbk.CAMERA_EXTRINSICS, self.frames.camera_mount(self._camera_frame_id))
        fault = self.fault(now)
        bbk.set_(bb, bbk.WORLD_FAULT, fault)
        status, reason = self.navigation.status(state, now)
        if self._goal is not None and state is None and fault:
            status, reason = NavStatus.FAILED, f"not navigating: {fault}"
        bbk.set_(bb, bbk.NAV_STATUS, status)
        bbk.set_(bb, bbk.NAV_REASON, reason)
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
                if self.state is not None or not self.fault(now):  # the pose is known: navigate
                    self.navigation.send(goal, now, frame_id)
            if now - self._last_target_goal >= 1.0 / t.target_goal_hz - 1e-3:
                self._last_target_goal = now
                self.emit("target_goal", pose2d_stamped(m, goal.pose, now, frame_id))
        elif goal is None and self._goal is not None:
            self._goal = None
            self.navigation.cancel()  # the behaviour let go of its goal (halted, done, preempted): cancel it

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
