"""Docking geometry: where the camera is relative to a tag, measured the way the docking tolerances are.

One definition shared by the docking behaviours (to steer) and by whoever checks a dock (to score):

* the tag normal is the marker's z axis (out of the face) projected on the floor;
* standoff = distance from the camera optical centre to the tag plane along that normal
  (positive in front of the tag);
* lateral = offset of the optical centre perpendicular to the normal in the floor plane
  (signed: positive on the tag's +t side, t = normal rotated +90° about z);
* skew = robot heading − heading of the reversed normal (signed, wrapped; 0 = facing the tag squarely).

Works in any frame whose z is up (map, odom, base): pass both poses in the same frame.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from mission.core import se3
from mission.core.types import Pose2D


@dataclass(frozen=True)
class DockOffsets:
    """Signed offsets of the camera from a tag (see the module doc for the conventions)."""

    standoff_m: float
    lateral_m: float
    skew_rad: float

    @property
    def skew_deg(self) -> float:
        return math.degrees(self.skew_rad)


def tag_floor_normal(T_ref_tag: np.ndarray) -> np.ndarray:
    """Unit (2,) floor-plane direction of the tag's face normal; raises ValueError for a tag lying flat."""
    n = np.asarray(T_ref_tag, dtype=np.float64)[:2, 2]
    norm = float(np.linalg.norm(n))
    if norm < 1e-3:
        raise ValueError("tag normal is vertical: a tag lying flat has no approach direction on the floor")
    return n / norm


def floor_pose(T_ref_target: np.ndarray) -> Pose2D:
    """Where a target is on the floor: its position, and the heading of its face normal (0 when it lies flat).

    For a marker this is the dock pose (the face it is approached from); for another target only x, y mean much.
    """
    T = np.asarray(T_ref_target, dtype=np.float64)
    try:
        n = tag_floor_normal(T)
        yaw = math.atan2(n[1], n[0])
    except ValueError:
        yaw = 0.0
    return Pose2D(float(T[0, 3]), float(T[1, 3]), yaw)


def dock_offsets(T_ref_optical: np.ndarray, T_ref_tag: np.ndarray, robot_yaw: float) -> DockOffsets:
    """Standoff, lateral offset and skew of the camera relative to the tag (poses in one z-up frame)."""
    n = tag_floor_normal(T_ref_tag)
    t = np.array([-n[1], n[0]])
    d = np.asarray(T_ref_optical, dtype=np.float64)[:2, 3] - np.asarray(T_ref_tag, dtype=np.float64)[:2, 3]
    facing = math.atan2(-n[1], -n[0])
    return DockOffsets(
        standoff_m=float(d @ n),
        lateral_m=float(d @ t),
        skew_rad=se3.wrap_angle(robot_yaw - facing),
    )


def staging_pose(T_ref_tag: np.ndarray, offset_m: float) -> Pose2D:
    """The base pose `offset_m` in front of the tag along its normal, facing the tag (Nav2's staging pose)."""
    n = tag_floor_normal(T_ref_tag)
    p = np.asarray(T_ref_tag, dtype=np.float64)[:2, 3] + offset_m * n
    return Pose2D(float(p[0]), float(p[1]), math.atan2(-n[1], -n[0]))
