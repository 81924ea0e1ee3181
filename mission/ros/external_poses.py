"""The object a FollowObject goal names, as others report it: poses on a ``geometry_msgs/PoseStamped`` topic
(``pose_topic``: a person detector, an upstream fiducial node), or a TF frame (``tracked_frame``: another
robot, a tracker that broadcasts its estimate).

Each pose is placed in the map at its own stamp (TF, as the robot's own pose; the header frame may be any
frame on /tf) and handed to perception on the next camera frame as a :class:`Sighting`, where the
``external_pose`` source (perception_plugins/external_pose.py) makes it a detection. A pose TF cannot place
is counted and its reason kept: the server reports TF_ERROR when nothing could be placed for a while.
"""

from __future__ import annotations

from collections import deque
from typing import Any

import numpy as np

from mission.core.types import Sighting
from mission.ros.conversions import pose_stamped_to_matrix
from mission.ros.frames import RobotFrames
from mission.ros.sensor_cache import SensorCache

MAX_PENDING = 64  # poses kept between two camera frames (a detector much faster than the camera)


class ExternalPoses:
    """One followed object's poses, from a topic or a TF frame, waiting for the next camera frame."""

    def __init__(self, node: Any, pose_type: type, qos: Any) -> None:
        self.node, self.pose_type, self.qos = node, pose_type, qos
        self.origin = ""  # the topic or frame followed now ('' = none)
        self.tracked_frame = ""
        self._sub: Any = None
        self._pending: deque[tuple[float, str, np.ndarray]] = deque(maxlen=MAX_PENDING)
        self._last_frame_stamp: float | None = None
        self.received = 0
        self.placed = 0
        self.last_placed: float | None = None  # stamp of the newest pose placed in the map
        self.error = ""  # why the newest pose could not be placed ('' when it was)

    # -- what the server asks ----------------------------------------------------------------------------
    def follow_topic(self, topic: str) -> None:
        """Take poses from `topic` from now on (the previous topic or frame is let go)."""
        self.stop()
        self.origin = topic
        self._sub = self.node.create_subscription(self.pose_type, topic, self._on_pose, self.qos)

    def follow_frame(self, frame: str) -> None:
        """Take the TF frame `frame`'s pose each time TF has a newer one."""
        self.stop()
        self.origin = self.tracked_frame = frame.lstrip("/")

    def stop(self) -> None:
        if self._sub is not None:
            self.node.destroy_subscription(self._sub)
        self._sub = None
        self.origin = self.tracked_frame = self.error = ""
        self._pending.clear()
        self._last_frame_stamp = None
        self.received = self.placed = 0
        self.last_placed = None

    # -- input -------------------------------------------------------------------------------------------
    def _on_pose(self, msg: Any) -> None:
        try:
            t, stamp, frame_id = pose_stamped_to_matrix(msg)
        except ValueError as err:
            self.error = f"dropped a pose on {self.origin}: {err}"
            return
        self.received += 1
        self._pending.append((stamp, frame_id, t))

    # -- the adapter, at each camera frame ----------------------------------------------------------------
    def take(self, frames: RobotFrames, cache: SensorCache) -> tuple[Sighting, ...]:
        """The poses reported since the last call, in the map frame (those TF cannot place are dropped)."""
        if self.tracked_frame:
            self._take_frame(frames)
        out = []
        while self._pending:
            stamp, frame_id, t = self._pending.popleft()
            t_map_frame, why = frames.frame_in_map(cache, frame_id, stamp)
            if t_map_frame is None:
                self.error = f"cannot place the pose from {self.origin} (frame {frame_id!r}): {why}"
                continue
            self.error = ""
            self.placed += 1
            self.last_placed = stamp
            out.append(Sighting(stamp, t_map_frame @ t, self.origin))
        return tuple(out)

    def _take_frame(self, frames: RobotFrames) -> None:
        stamp = frames.tf.newest_stamp(self.tracked_frame)
        if not frames.tf.has_frame(self.tracked_frame):
            self.error = f"no frame {self.tracked_frame!r} on /tf"
            return
        if stamp is not None and stamp == self._last_frame_stamp:
            return  # nothing new from the tracker
        self._last_frame_stamp = stamp
        self.received += 1
        # the tracked frame's pose in itself: the identity, placed by TF at the tracker's stamp
        self._pending.append((stamp if stamp is not None else 0.0, self.tracked_frame, np.eye(4)))
