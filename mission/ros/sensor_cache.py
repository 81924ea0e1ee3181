"""The newest sensor messages, converted and paired, ready for a world adapter's ``sense()``.

Shared by the live ROS adapter (fed by rclpy callbacks) and replay (fed by messages read from a bag),
so both turn the same messages into the same Frames. No rclpy here.

* Images are converted on arrival (a bad one is dropped and counted) and paired with camera info
  **by stamp** when they are taken, not when they arrive, so an image that arrives a moment before
  its CameraInfo still gets it. The nearest info within ``info_tolerance_s`` wins; without one the
  newest info is used (calibration rarely changes); an invalid info (fx or fy 0) or none at all gives
  the fallback pinhole, with a warning.
* Depth images are paired with the colour image by stamp the same way.
* Images and depth may be ``sensor_msgs/Image`` or ``CompressedImage`` (image_transport's ``compressed`` /
  ``compressedDepth``); a camera that publishes both (``<topic>`` and ``<topic>/compressed``) gives one
  frame per stamp: the copy of an image already taken from the other topic is skipped.
* A calibration file (``fixed_intrinsics``, from ``--calibration``) replaces whatever CameraInfo says.
* With ``/amcl_pose``, the robot pose is AMCL's map pose carried forward by odometry (what the
  map → odom TF does); without it the odometry pose is used as the map pose.
"""

from __future__ import annotations

import bisect
import dataclasses
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from mission.core import se3
from mission.core.types import CameraIntrinsics, Frame, LaserScan, OccupancyGrid, Pose2D, RobotState
from mission.ros.conversions import (
    BadMessage,
    camera_info_to_intrinsics,
    grid_from_msg,
    image_to_camera_array,
    image_to_depth_m,
    odometry_to_state,
    pose_with_covariance_to_pose2d,
    scan_from_msg,
)
from mission.ros.messages import stamp_to_sec


class ThrottledLog:
    """One warning per key at most every `period_s` (the first one always), with a count of the rest."""

    def __init__(self, sink: Callable[[str], None], period_s: float = 5.0) -> None:
        self.sink = sink
        self.period_s = period_s
        self._last: dict[str, float] = {}
        self._suppressed: dict[str, int] = {}

    def __call__(self, key: str, message: str) -> None:
        now = time.monotonic()
        last = self._last.get(key)
        if last is not None and now - last < self.period_s:
            self._suppressed[key] = self._suppressed.get(key, 0) + 1
            return
        n = self._suppressed.pop(key, 0)
        self._last[key] = now
        self.sink(message + (f" ({n} more since the last warning)" if n else ""))


@dataclass
class _Stamped:
    stamp: float
    value: Any
    topic: str = ""  # where it came from, for warnings about it later


def _nearest(items: deque[_Stamped], stamp: float) -> _Stamped | None:
    if not items:
        return None
    stamps = [it.stamp for it in items]
    i = bisect.bisect_left(stamps, stamp)
    candidates = [items[j] for j in (i - 1, i) if 0 <= j < len(items)]
    return min(candidates, key=lambda it: abs(it.stamp - stamp))


@dataclass
class CacheStats:
    """What was received and what was dropped (debug JSON ``dropped`` / ``received``)."""

    received: dict[str, int] = field(default_factory=dict)
    dropped: dict[str, int] = field(default_factory=dict)  # "<topic kind>:<reason>" → count
    fallback_intrinsics: int = 0  # frames that used the fallback pinhole

    @property
    def images_dropped(self) -> int:
        return sum(v for k, v in self.dropped.items() if k.startswith("image:"))

    def to_json(self) -> dict[str, Any]:
        return {
            "received": dict(self.received),
            "dropped": dict(self.dropped),
            "dropped_total": sum(self.dropped.values()),
            "fallback_intrinsics": self.fallback_intrinsics,
        }


class SensorCache:
    """Converts and holds the newest inputs; every ``on_*`` method takes a decoded message."""

    def __init__(
        self,
        *,
        camera_frame: str = "camera_optical_frame",
        info_tolerance_s: float = 0.1,
        warn: Callable[[str], None] = lambda message: None,
        history: int = 30,
        fixed_intrinsics: CameraIntrinsics | None = None,
        exposure_s: float | None = None,
    ) -> None:
        self.camera_frame = camera_frame
        self.exposure_s = exposure_s  # the driver's exposure setting, carried on every frame (None = not known)
        self.fixed_intrinsics = fixed_intrinsics
        self.info_tolerance_s = info_tolerance_s
        self.log = ThrottledLog(warn)
        self.stats = CacheStats()
        self._infos: deque[_Stamped] = deque(maxlen=history)  # value: CameraIntrinsics | str (why invalid)
        self._depths: deque[_Stamped] = deque(maxlen=history)
        self._image: tuple[float, str, np.ndarray] | None = None
        self._image_topic = ""
        self._image_seq = 0
        self._taken_seq = 0
        self.odom: RobotState | None = None
        self._T_map_odom: np.ndarray | None = None
        self.scan: LaserScan | None = None
        self.map: OccupancyGrid | None = None
        self.latest_stamp = 0.0  # newest header stamp seen on any topic (replay's clock)

    # -- bookkeeping -------------------------------------------------------------------------------
    def _received(self, kind: str, stamp: float) -> None:
        self.stats.received[kind] = self.stats.received.get(kind, 0) + 1
        self.latest_stamp = max(self.latest_stamp, stamp)

    def _drop(self, kind: str, topic: str, err: BadMessage) -> None:
        key = f"{kind}:{err.kind}"
        self.stats.dropped[key] = self.stats.dropped.get(key, 0) + 1
        self.log(key, f"dropped a message on {topic}: {err.detail}")

    # -- inputs ------------------------------------------------------------------------------------
    def on_image(self, msg: Any, topic: str = "image") -> bool:
        """A colour image (Image or CompressedImage); returns False when it was dropped or a copy."""
        stamp = stamp_to_sec(msg.header.stamp)
        self._received("image", stamp)
        if self._image is not None and stamp == self._image[0] and topic != self._image_topic:
            return False  # the same frame from the camera's other transport (raw / compressed)
        try:
            image = image_to_camera_array(msg)
        except BadMessage as err:
            self._drop("image", topic, err)
            return False
        self._image = (stamp, str(msg.header.frame_id) or self.camera_frame, image)
        self._image_topic = topic
        self._image_seq += 1
        return True

    def on_depth(self, msg: Any, topic: str = "depth") -> bool:
        stamp = stamp_to_sec(msg.header.stamp)
        self._received("depth", stamp)
        try:
            depth = image_to_depth_m(msg)
        except BadMessage as err:
            self._drop("depth", topic, err)
            return False
        self._insert(self._depths, _Stamped(stamp, depth))
        return True

    def on_camera_info(self, msg: Any, topic: str = "camera_info") -> bool:
        stamp = stamp_to_sec(msg.header.stamp)
        self._received("camera_info", stamp)
        try:
            value: CameraIntrinsics | str = camera_info_to_intrinsics(msg)
            ok = True
        except BadMessage as err:
            self.stats.dropped[f"camera_info:{err.kind}"] = self.stats.dropped.get(f"camera_info:{err.kind}", 0) + 1
            self.log("camera_info", f"invalid camera info on {topic}: {err.detail}; using the fallback intrinsics")
            value, ok = err.detail, False
        self._insert(self._infos, _Stamped(stamp, value, topic))
        return ok

    def on_odometry(self, msg: Any, topic: str = "odom") -> bool:
        stamp = stamp_to_sec(msg.header.stamp)
        self._received("odom", stamp)
        try:
            self.odom = odometry_to_state(msg)
        except BadMessage as err:
            self._drop("odom", topic, err)
            return False
        return True

    def on_amcl_pose(self, msg: Any, topic: str = "amcl_pose") -> bool:
        stamp = stamp_to_sec(msg.header.stamp)
        self._received("amcl_pose", stamp)
        try:
            pose, _, _ = pose_with_covariance_to_pose2d(msg)
        except BadMessage as err:
            self._drop("amcl_pose", topic, err)
            return False
        odom_pose = self.odom.pose if self.odom is not None else Pose2D(0.0, 0.0, 0.0)
        self._T_map_odom = se3.planar(pose.x, pose.y, pose.yaw) @ se3.invert(
            se3.planar(odom_pose.x, odom_pose.y, odom_pose.yaw)
        )
        return True

    def on_scan(self, msg: Any, topic: str = "scan") -> bool:
        stamp = stamp_to_sec(msg.header.stamp)
        self._received("scan", stamp)
        try:
            self.scan = scan_from_msg(msg)
        except BadMessage as err:
            self._drop("scan", topic, err)
            return False
        return True

    def on_map(self, msg: Any, topic: str = "map") -> bool:
        self._received("map", stamp_to_sec(msg.header.stamp))
        try:
            self.map = grid_from_msg(msg)
        except BadMessage as err:
            self._drop("map", topic, err)
            return False
        return True

    @staticmethod
    def _insert(items: deque[_Stamped], item: _Stamped) -> None:
        if items and item.stamp < items[-1].stamp:  # out of order: keep the deque sorted by stamp
            items.append(item)
            ordered = sorted(items, key=lambda it: it.stamp)
            items.clear()
            items.extend(ordered)
        else:
            items.append(item)

    # -- outputs -----------------------------------------------------------------------------------
    @property
    def frame_seq(self) -> int:
        return self._image_seq

    def take_frame(self) -> Frame | None:
        """The newest image as a Frame (paired with intrinsics and depth), or None if nothing new arrived."""
        if self._image is None or self._image_seq == self._taken_seq:
            return None
        self._taken_seq = self._image_seq
        stamp, frame_id, image = self._image
        return Frame(
            image=image,
            stamp=stamp,
            frame_id=frame_id,
            intrinsics=self._intrinsics_for(stamp, image),
            depth=self._depth_for(stamp, image),
            exposure_s=self.exposure_s,
        )

    def _intrinsics_for(self, stamp: float, image: np.ndarray) -> CameraIntrinsics:
        h, w = image.shape[:2]
        if self.fixed_intrinsics is not None:
            problem = self.fixed_intrinsics.problem(w, h)
            if problem is None:
                return self.fixed_intrinsics
            self.stats.fallback_intrinsics += 1
            self.log("fallback_intrinsics", f"calibration file: {problem}; using the fallback pinhole fx = fy = 0.9·W")
            return CameraIntrinsics.fallback(w, h)
        near = _nearest(self._infos, stamp)
        if near is not None and abs(near.stamp - stamp) > self.info_tolerance_s:
            near = self._infos[-1]  # no info at this stamp: the newest calibration
        value = near.value if near is not None else "no camera info received"
        if isinstance(value, CameraIntrinsics):
            if value.width == 0 or value.height == 0:
                value = dataclasses.replace(value, width=w, height=h)
            problem = value.problem(w, h)  # the one check (core/types.py) the sources use too
            if problem is None:
                return value
            assert near is not None
            value = f"camera info on {near.topic}: {problem}"
        self.stats.fallback_intrinsics += 1
        self.log("fallback_intrinsics", f"{value}; using the fallback pinhole fx = fy = 0.9·{w}")
        return CameraIntrinsics.fallback(w, h)

    def _depth_for(self, stamp: float, image: np.ndarray) -> np.ndarray | None:
        near = _nearest(self._depths, stamp)
        if near is None or abs(near.stamp - stamp) > self.info_tolerance_s:
            return None
        if near.value.shape != image.shape[:2]:
            self.log("depth_shape", f"depth {near.value.shape} does not match the image {image.shape[:2]}; ignored")
            return None
        return near.value

    @property
    def map_from_odom(self) -> np.ndarray | None:
        """AMCL's map → odom correction from /amcl_pose (None before the first one)."""
        return self._T_map_odom

    def robot_state(self) -> RobotState | None:
        """The base pose in the map frame (AMCL-corrected odometry when /amcl_pose is available)."""
        if self.odom is None:
            return None
        if self._T_map_odom is None:
            return self.odom
        p = self.odom.pose
        t = self._T_map_odom @ se3.planar(p.x, p.y, p.yaw)
        return dataclasses.replace(self.odom, pose=Pose2D(float(t[0, 3]), float(t[1, 3]), se3.yaw_of(t)))
