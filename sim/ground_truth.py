"""What really happened at one instant of a simulated run: the yardstick metrics compare the tree against."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from mission.core.types import Pose2D


@dataclass
class GroundTruth:
    """Poses in the map frame (4×4 arrays are T_map_x, TF convention) and visibility facts.

    `T_map_target_marker` is the target marker that faces the camera best (all faces in
    `T_map_target_markers`); `target_in_los` says no solid body lies between the camera's optical centre
    and that marker's centre; `target_in_fov` says that centre projects inside the image, in front of
    the camera, within the camera's range, on a face turned towards the camera.
    """

    stamp: float
    robot: Pose2D
    robot_v: float
    robot_w: float
    T_map_optical: np.ndarray
    target: Pose2D | None
    target_moving: bool
    T_map_target_marker: np.ndarray | None
    target_in_los: bool
    target_in_fov: bool
    T_map_dock: np.ndarray | None
    dock_in_los: bool
    dock_in_fov: bool
    collisions: int
    nav_status: str
    T_map_target_markers: list[np.ndarray] = field(default_factory=list)
    collision_log: list[str] = field(default_factory=list)  # what the robot ran into, one entry per contact
    target_blocked: bool = False  # the target is waiting because the robot stands in its way
    target_gone: bool = False  # the target has left the map (target.leave_at_end); `target` is then None
    movers: list[Pose2D] = field(default_factory=list)  # where each moving obstacle is

    @property
    def target_visible(self) -> bool:
        """In view and not hidden: what an ideal detector would see."""
        return self.target_in_los and self.target_in_fov
