"""The corner refinement and the pattern check are compiled (numba) because they run on every marker of every
frame (issue 34); what they compute is still the numpy definition (tests/perception/numpy_definitions.py), to
the bit, so compiling them moved no corner, no pose and no mission. Rendered views of markers at 0.4–4 m, the
detector's quads and those quads moved by up to a few pixels (what tracking refines: a prediction)."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from mission.perception_plugins.corner_refinement import refined_corners
from mission.perception_plugins.marker_bits import PatternCheck, aruco_pattern
from tests.perception import numpy_definitions
from tools import synthetic_views as sv

DICTIONARY = cv2.aruco.getPredefinedDictionary(cv2.aruco.DICT_4X4_250)


def _views() -> list[tuple[np.ndarray, np.ndarray]]:
    """(grey, quads M×4×2) of rendered markers at several distances and tilts, each quad as the detector found
    it and moved by 0.5, 1.5 and 4 px of noise."""
    rng = np.random.default_rng(34)
    detector = cv2.aruco.ArucoDetector(DICTIONARY)
    out = []
    for distance in (0.4, 0.8, 1.5, 2.5, 4.0):
        for tilt in (0.0, 0.5, 0.9):
            T = sv.pose_facing_camera(np.array([0.05, -0.03, distance]), tilt_axis_angle=0.8, tilt=tilt, roll=0.4)
            v = sv.render_marker_view(T, marker_id=7, marker_size_m=0.15, rng=rng)
            grey = v.image if v.image.ndim == 2 else cv2.cvtColor(v.image, cv2.COLOR_BGR2GRAY)
            corners, ids, _ = detector.detectMarkers(grey)
            quads = np.asarray(corners, dtype=np.float64).reshape(-1, 4, 2) if ids is not None else v.corners[None]
            for noise in (0.0, 0.5, 1.5, 4.0):
                out.append((grey, quads + rng.normal(0.0, noise, quads.shape)))
    return out


VIEWS = _views()


def test_the_compiled_refinement_computes_its_numpy_definition_to_the_bit():
    refined = 0
    for grey, quads in VIEWS:
        got, ok = refined_corners(grey, quads, 6)
        want, want_ok = numpy_definitions.refined_corners(grey, quads, 6)
        assert np.array_equal(got, want) and np.array_equal(ok, want_ok)
        refined += int(ok.sum())
    assert refined > len(VIEWS)  # most corners refine: the comparison is not between two unrefined copies


def test_several_quads_at_once_refine_as_each_does_alone():
    grey, quads = VIEWS[5]
    many = np.concatenate([quads, quads + 0.7, quads - 1.3])
    got, _ = refined_corners(grey, many, 6)
    alone = np.concatenate([refined_corners(grey, q[None], 6)[0] for q in many])
    assert np.array_equal(got, alone)


@pytest.mark.parametrize("ids", [[7], [8]])  # its own id, and another one's
def test_the_compiled_pattern_check_computes_its_numpy_definition(ids):
    check = PatternCheck(6, aruco_pattern(DICTIONARY))
    held = 0
    for grey, quads in VIEWS:
        marker_ids = np.array(ids * len(quads), dtype=np.int64)
        got = check(grey, quads, marker_ids)
        assert got.tolist() == numpy_definitions.pattern_holds(check, grey, quads, marker_ids).tolist()
        held += int(got.sum())
    assert (held > 0) == (ids == [7])  # the comparison covers quads that hold the marker and quads that do not


def test_no_quads_is_no_work():
    grey = np.zeros((32, 32), np.uint8)
    corners, ok = refined_corners(grey, np.zeros((0, 4, 2)), 6)
    assert corners.shape == (0, 4, 2) and ok.shape == (0, 4)
    assert PatternCheck(6, aruco_pattern(DICTIONARY))(grey, np.zeros((0, 4, 2)), np.zeros(0)).shape == (0,)


def test_forty_tags_followed_at_once_are_checked_as_each_alone():
    # one row of samples for every quad would be 40 × 1,004 points, over cv2.remap's 32,767 columns
    # (an OpenCV assertion, before the samples were laid out a row per quad)
    check = PatternCheck(10, aruco_pattern(cv2.aruco.getPredefinedDictionary(cv2.aruco.DICT_APRILTAG_36h11)))
    grey, quads = VIEWS[5]
    many = np.concatenate([quads + 0.1 * k for k in range(40)])
    ids = np.arange(40, dtype=np.int64)
    alone = [bool(check(grey, q[None], ids[k : k + 1])[0]) for k, q in enumerate(many)]
    assert check(grey, many, ids).tolist() == alone
    refined, _ = refined_corners(grey, many, 10)
    assert np.array_equal(refined, np.concatenate([refined_corners(grey, q[None], 10)[0] for q in many]))
