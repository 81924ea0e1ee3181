"""Where the robot and its camera are, from TF when the robot publishes it, else from the fallbacks.

What a ROS robot tells about its frames, in order of preference (REP 105):

* **camera mount** (base_frame → the image's frame_id): ``/tf_static`` (the URDF via robot_state_publisher),
  else the ``camera_xyz_rpy`` parameter;
* **map → odom**: ``/tf`` (AMCL, SLAM, or the simulation), else AMCL's ``/amcl_pose`` carried by odometry,
  else none (odometry is taken as the map pose);
* **odom → base_link**: ``/tf`` when the robot publishes it there, else the ``/odom`` messages (fed into the
  same buffer, so an image is still placed with the pose at its own stamp).

Each switch of source is said once in the log. A TF tree that exists but is broken — looping, or a link
that stopped updating (stale) — is a *fault*: the robot pose and the camera pose are then unknown, and
:attr:`RobotFrames.fault` says why, for the blackboard (``/robot/fault``) and the tree. No rclpy here.
"""

from __future__ import annotations

import contextlib
import dataclasses
from collections.abc import Callable

import numpy as np

from mission.core import se3
from mission.core.types import Pose2D, RobotState
from mission.ros.sensor_cache import SensorCache
from mission.ros.tf_buffer import TfBuffer, TfError

ODOM_FED = "odom topic"


class RobotFrames:
    """The TF buffer plus the fallbacks; answers "where is the base now" and "where was the camera at t"."""

    def __init__(
        self,
        *,
        map_frame: str,
        odom_frame: str,
        base_frame: str,
        fallback_mount: np.ndarray,
        tolerance_s: float = 0.1,
        stale_after_s: float = 1.0,
        say: Callable[[str], None] = lambda message: None,
    ) -> None:
        self.map_frame, self.odom_frame, self.base_frame = map_frame, odom_frame, base_frame
        self.fallback_mount = fallback_mount
        self.stale_after_s = float(stale_after_s)
        self.tf = TfBuffer(cache_s=10.0, tolerance_s=tolerance_s)
        self.say = say
        self.fault = ""  # why the pose cannot be trusted now ('' when fine)
        self._sources: dict[str, str] = {}  # what → where it comes from now (said once per change)
        self._base_from_tf = False  # /tf carries odom → base_link (then /odom is not fed into the buffer)

    # -- input ---------------------------------------------------------------------------------------
    def on_tf(self, parent: str, child: str, stamp: float, t: np.ndarray, *, static: bool) -> None:
        parent, child = parent.lstrip("/"), child.lstrip("/")
        if child == self.base_frame and not static:
            self._base_from_tf = True
        with contextlib.suppress(TfError):  # an empty or self-referencing frame id: nothing a lookup could use
            self.tf.set_transform(parent, child, stamp, t, static=static)

    def on_odometry(self, state: RobotState) -> None:
        """An /odom message: odom → base_link at its stamp, unless /tf carries that link itself."""
        if not self._base_from_tf:
            p = state.pose
            self.tf.set_transform(self.odom_frame, self.base_frame, state.stamp, se3.planar(p.x, p.y, p.yaw))

    def clear(self) -> None:
        """Time jumped back: forget every dynamic transform (tf2 does the same)."""
        self.tf.clear()
        self._base_from_tf = False

    # -- what the adapter asks -------------------------------------------------------------------------
    def _use(self, what: str, source: str, detail: str = "") -> None:
        if self._sources.get(what) != source:
            self._sources[what] = source
            self.say(f"{what}: {source}" + (f" ({detail})" if detail else ""))

    def camera_mount(self, camera_frame: str) -> np.ndarray:
        """T_base_camera: TF when it has the mount, else the camera_xyz_rpy parameter."""
        t, why = self.tf.try_lookup(self.base_frame, camera_frame, None)
        if t is not None:
            self._use("camera mount", f"from TF {self.base_frame} → {camera_frame}")
            return t
        self._use("camera mount", "from the camera_xyz_rpy parameter (no TF mount)", why)
        return self.fallback_mount

    def map_from_odom(self, cache: SensorCache, stamp: float | None) -> np.ndarray | None:
        """T_map_odom at `stamp`: TF, else AMCL's correction (/amcl_pose), else None (odometry is the map)."""
        try:
            t = self.tf.lookup(self.map_frame, self.odom_frame, stamp)
            self._use("map → odom", "from TF")
            return t
        except TfError as err:
            if err.kind == "loop":
                raise
            if err.kind in ("stale", "past") and stamp is not None:  # a slow localiser: its newest correction
                return self.tf.lookup(self.map_frame, self.odom_frame, None)
            amcl = cache.map_from_odom
            if amcl is not None:
                self._use("map → odom", "from /amcl_pose (no map → odom on TF)")
                return amcl
            self._use("map → odom", "none: odometry taken as the map pose (no TF map → odom, no /amcl_pose)")
            return None

    def robot_state(self, cache: SensorCache, now: float) -> RobotState | None:
        """The base in the map frame now (None, with :attr:`fault` set, when TF is broken)."""
        odom = cache.odom
        if odom is None:
            return None
        self.fault = ""
        try:
            if self._base_from_tf:
                newest = self.tf.newest_stamp(self.base_frame)
                if newest is not None and now - newest > self.stale_after_s:
                    raise TfError(
                        "stale",
                        f"TF {self.odom_frame} → {self.base_frame} is stale: the newest transform "
                        f"is {now - newest:.1f} s old",
                    )
                t_odom_base = self.tf.lookup(self.odom_frame, self.base_frame, None)
            else:
                p = odom.pose
                t_odom_base = se3.planar(p.x, p.y, p.yaw)
            t_map_odom = self.map_from_odom(cache, None)
        except TfError as err:
            self.fault = f"TF: {err}"
            return None
        t = t_odom_base if t_map_odom is None else t_map_odom @ t_odom_base
        return dataclasses.replace(odom, pose=Pose2D(float(t[0, 3]), float(t[1, 3]), se3.yaw_of(t)))

    def frame_in_map(self, cache: SensorCache, frame: str, stamp: float | None) -> tuple[np.ndarray | None, str]:
        """T_map_frame at `stamp` (None: the newest) for any frame on TF — an object's pose's header frame, a
        tracked frame — through map → odom as the robot's own pose goes (AMCL's correction when TF has none).
        (None, why) when TF cannot say."""
        frame = frame.lstrip("/") or self.map_frame
        if frame == self.map_frame:
            return np.eye(4), ""
        direct, _why = self.tf.try_lookup(self.map_frame, frame, stamp)
        if direct is not None:
            return direct, ""
        try:
            t_odom_frame = self.tf.lookup(self.odom_frame, frame, stamp)
            t_map_odom = self.map_from_odom(cache, stamp)
        except TfError as err:
            return None, f"TF: {err}"
        return (t_odom_frame if t_map_odom is None else se3.compose(t_map_odom, t_odom_frame)), ""

    def camera_in_map(self, cache: SensorCache, camera_frame: str, stamp: float) -> tuple[np.ndarray | None, str]:
        """T_map_camera at the image's `stamp` (None and why when TF cannot say where the camera was)."""
        try:
            t_odom_base = self.tf.lookup(self.odom_frame, self.base_frame, stamp)
            t_map_odom = self.map_from_odom(cache, stamp)
        except TfError as err:
            return None, f"TF: {err}"
        t_base_cam = self.camera_mount(camera_frame)
        t = (
            se3.compose(t_odom_base, t_base_cam)
            if t_map_odom is None
            else se3.compose(t_map_odom, t_odom_base, t_base_cam)
        )
        return t, ""
