"""external_pose: targets that someone else detects — a person detector publishing poses, another robot's TF
frame, an upstream fiducial node — made into detections, so the tree follows them exactly as it follows what
our own camera sees (FOLLOW, LOST, SEARCH, FOLLOW again).

The world adapter collects those poses and hands them over on the next camera frame (``Frame.sightings``,
already in the frame's anchor frame, see mission/ros/external_poses.py). This source turns each into a
Detection in the camera's optical frame, which is what the perception contract carries; the perception
stage places it back in the map with the same camera pose, so the target lands exactly where it was reported.
A pose that stops coming is a target no longer seen: the tracks miss it frame after frame, and the tree's
ladder takes over.

The detections carry ``label`` (a target is matched by it, or by this source's instance name:
``perception.targets.target: {source: external_pose}``) and no marker id, corners or depth.
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from mission.core import se3
from mission.core.config import StrictModel, validate_model
from mission.core.types import Detection, Frame


class ExternalPoseParams(StrictModel):
    """Params of the ``external_pose`` source."""

    label: str = "external"  # the label its detections carry (what a target spec can match)


class ExternalPoseSource:
    """Detections from the poses others reported since the previous frame (module doc)."""

    description: ClassVar[str] = "poses of targets detected elsewhere (a pose topic, a TF frame), as detections"

    def __init__(self, params: dict, name: str = "external_pose") -> None:
        self.name = name
        self.params = validate_model(ExternalPoseParams, params)
        self.unplaced = 0  # sightings dropped because the frame did not say where the camera was

    def process(self, frame: Frame) -> list[Detection]:
        if not frame.sightings:
            return []
        if frame.T_anchor_camera is None:
            self.unplaced += len(frame.sightings)
            return []
        T_camera_anchor = se3.invert(np.asarray(frame.T_anchor_camera, dtype=np.float64))
        out = []
        for s in frame.sightings:
            t = T_camera_anchor @ np.asarray(s.T_anchor_object, dtype=np.float64)
            out.append(
                Detection(
                    source=self.name,
                    marker_id=None,
                    label=self.params.label,
                    corners=None,
                    position=t[:3, 3].copy(),
                    orientation=se3.matrix_to_quat(t[:3, :3]),
                    confidence=1.0,
                    reprojection_error=0.0,
                    stamp=float(s.stamp),
                    frame_id=frame.frame_id,
                    extra={"origin": s.origin},
                )
            )
        return out

    def close(self) -> None:
        """Nothing to release: the poses are the world adapter's."""
