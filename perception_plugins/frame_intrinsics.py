"""The camera model a pose source uses for a frame: the frame's own calibration when it is usable,
else the design notes' degraded pinhole (fx = fy = 0.9·width, principal point at the centre).

Shared by the square-marker sources (aruco, apriltag) so both fall back for the same reasons
(CameraIntrinsics.problem: missing, bad focal length, a distortion vector OpenCV rejects, a calibration
for another image size) and say so the same way: one warning per reason, not one per frame.
"""

from __future__ import annotations

import logging

from mission.core.types import CameraIntrinsics, Frame


class FrameIntrinsics:
    """Picks (intrinsics, degraded) per frame for the source named `source_name`, warning on `log`."""

    def __init__(self, source_name: str, log: logging.Logger) -> None:
        self.source_name = source_name
        self.log = log
        self._warned: set[str] = set()

    def __call__(self, frame: Frame) -> tuple[CameraIntrinsics, bool]:
        k = frame.intrinsics
        problem = None if k is None else k.problem(frame.width, frame.height)
        if k is not None and problem is None:
            return k, k.is_fallback  # an adapter's fallback (it warned already): a valid but degraded pose
        reason = "missing" if k is None else "invalid"
        if reason not in self._warned:
            self._warned.add(reason)
            detail = "" if problem is None else f" ({problem})"
            self.log.warning(
                "%s: camera intrinsics %s%s; using the fallback pinhole fx = fy = 0.9·width, principal point at "
                "the image centre (degraded pose accuracy)",
                self.source_name,
                reason,
                detail,
            )
        return CameraIntrinsics.fallback(frame.width, frame.height), True
