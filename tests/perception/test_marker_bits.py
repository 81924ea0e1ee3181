"""A tracked marker's quad is checked by reading the marker inside it (issue 34): the pattern of the id it is
expected to hold, and its four edges where the quad puts them. Rendered views with exact corners."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from mission.perception_plugins.marker_bits import PatternCheck, aruco_pattern
from tools import synthetic_views as sv

DICTIONARY = cv2.aruco.getPredefinedDictionary(cv2.aruco.DICT_4X4_250)
CHECK = PatternCheck(6, aruco_pattern(DICTIONARY))


def view(distance_m: float, tilt: float = 0.3) -> sv.SyntheticView:
    T = sv.pose_facing_camera(np.array([0.05, -0.03, distance_m]), tilt_axis_angle=0.8, tilt=tilt, roll=0.4)
    return sv.render_marker_view(T, marker_id=7, marker_size_m=0.15, rng=np.random.default_rng(1))


def grey(v: sv.SyntheticView) -> np.ndarray:
    return v.image if v.image.ndim == 2 else cv2.cvtColor(v.image, cv2.COLOR_BGR2GRAY)


@pytest.mark.parametrize("distance_m", [4.0, 1.5, 0.5])  # ~25, ~65 and ~200 px
def test_the_true_quad_holds_its_marker_and_no_other_id(distance_m):
    v = view(distance_m)
    quads = np.stack([v.corners, v.corners])
    assert CHECK(grey(v), quads, np.array([7, 8])).tolist() == [True, False]


@pytest.mark.parametrize("distance_m", [1.5, 0.5])
def test_a_quad_a_third_of_a_module_off_is_not_the_marker_though_every_cell_reads_right(distance_m):
    # cells are read in their central half, so a quad up to half a module off still reads the id's pattern;
    # the edges are read too (1.5 px or 0.35 module either side), so it does not pass
    v = view(distance_m)
    module = np.linalg.norm(v.corners[1] - v.corners[0]) / 6
    shifted = v.corners + np.array([module / 3, 0.0])
    assert CHECK(grey(v), shifted[None], np.array([7])).tolist() == [False]


def test_the_marker_turned_a_quarter_in_its_quad_is_not_the_marker():
    # the corners' order is the pose: a quad whose corners are rolled by one is the same square, the wrong pose
    v = view(1.5)
    assert CHECK(grey(v), np.roll(v.corners, 1, axis=0)[None], np.array([7])).tolist() == [False]


def test_a_quad_on_a_plain_wall_holds_nothing():
    v = view(1.5)
    blank = np.full_like(grey(v), 128)
    assert CHECK(blank, v.corners[None], np.array([7])).tolist() == [False]
