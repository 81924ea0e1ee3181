"""mission.core.docking: the one definition of stand-off, lateral offset and skew (signed), and the staging pose."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mission.core import se3
from mission.core.docking import dock_offsets, floor_normal, staging_pose


def wall_tag(x: float, y: float, facing: float) -> np.ndarray:
    return se3.transform(se3.rot_z(facing) @ se3.rot_y(math.pi / 2), (x, y, 0.3))


def camera_at(x: float, y: float, yaw: float) -> np.ndarray:
    return se3.transform(se3.rot_z(yaw) @ se3.R_BODY_OPTICAL, (x, y, 0.3))


def test_square_in_front_of_the_tag_has_only_a_standoff():
    off = dock_offsets(camera_at(1.7, 0.0, 0.0), wall_tag(2.0, 0.0, math.pi), robot_yaw=0.0)
    assert math.isclose(off.standoff_m, 0.3, abs_tol=1e-12)
    assert abs(off.lateral_m) < 1e-12 and abs(off.skew_rad) < 1e-12


def test_signs_lateral_along_the_normal_turned_left_and_skew_counter_clockwise():
    # tag facing −x: its normal turned +90° points to −y, so a camera at y = −0.05 has lateral +0.05
    off = dock_offsets(camera_at(1.7, -0.05, math.radians(5)), wall_tag(2.0, 0.0, math.pi), math.radians(5))
    assert math.isclose(off.lateral_m, 0.05, abs_tol=1e-12)
    assert math.isclose(off.skew_deg, 5.0, abs_tol=1e-9)


def test_staging_pose_is_offset_along_the_normal_facing_the_tag():
    p = staging_pose(wall_tag(2.0, 1.0, math.radians(90)), 0.7)
    assert math.isclose(p.x, 2.0, abs_tol=1e-12) and math.isclose(p.y, 1.7, abs_tol=1e-12)
    assert math.isclose(p.yaw, math.radians(-90), abs_tol=1e-12)


def test_a_tag_lying_flat_has_no_approach_direction():
    with pytest.raises(ValueError, match="tag normal is vertical"):
        floor_normal(np.eye(4))
