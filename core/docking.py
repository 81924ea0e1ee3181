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


def floor_normal(T_ref_tag: np.ndarray) -> tuple[float, float]:
    """Unit floor-plane direction (nx, ny) of the tag's face normal; raises ValueError for a tag lying flat.

    On Python floats: the docking behaviours call it on every detection, and numpy's per-call overhead
    on a 2-vector is most of the cost (the tree benchmark)."""
    nx, ny = float(T_ref_tag[0, 2]), float(T_ref_tag[1, 2])
    norm = math.hypot(nx, ny)
    if norm < 1e-3:
        raise ValueError("tag normal is vertical: a tag lying flat has no approach direction on the floor")
    return nx / norm, ny / norm


def floor_pose(T_ref_target: np.ndarray) -> Pose2D:
    """Where a target is on the floor: its position, and the heading of its face normal (0 when it lies flat).

    For a marker this is the dock pose (the face it is approached from); for another target only x, y mean much.
    """
    try:
        nx, ny = floor_normal(T_ref_target)
        yaw = math.atan2(ny, nx)
    except ValueError:
        yaw = 0.0
    return Pose2D(float(T_ref_target[0, 3]), float(T_ref_target[1, 3]), yaw)


def dock_offsets(T_ref_optical: np.ndarray, T_ref_tag: np.ndarray, robot_yaw: float) -> DockOffsets:
    """Standoff, lateral offset and skew of the camera relative to the tag (poses in one z-up frame)."""
    camera = (float(T_ref_optical[0, 3]), float(T_ref_optical[1, 3]))
    tag = (float(T_ref_tag[0, 3]), float(T_ref_tag[1, 3]))
    return floor_offsets(camera, tag, floor_normal(T_ref_tag), robot_yaw)


def floor_offsets(
    camera_xy: tuple[float, float], tag_xy: tuple[float, float], normal: tuple[float, float], robot_yaw: float
) -> DockOffsets:
    """:func:`dock_offsets` from the floor-plane quantities alone: the optical centre, the tag and its unit
    normal (what a floor filter of the tag keeps)."""
    nx, ny = normal
    dx, dy = camera_xy[0] - tag_xy[0], camera_xy[1] - tag_xy[1]
    return DockOffsets(
        standoff_m=dx * nx + dy * ny,
        lateral_m=dx * -ny + dy * nx,
        skew_rad=se3.wrap_angle(robot_yaw - math.atan2(-ny, -nx)),
    )


def staging_pose(T_ref_tag: np.ndarray, offset_m: float) -> Pose2D:
    """The base pose `offset_m` in front of the tag along its normal, facing the tag (Nav2's staging pose)."""
    nx, ny = floor_normal(T_ref_tag)
    x, y = float(T_ref_tag[0, 3]) + offset_m * nx, float(T_ref_tag[1, 3]) + offset_m * ny
    return Pose2D(x, y, math.atan2(-ny, -nx))
