"""One quad per marker: the same id reported twice in one image is one marker, and its outer square wins."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from mission.core.types import Frame
from mission.perception_plugins.aruco import ArucoSource
from mission.perception_plugins.marker_quads import one_quad_per_marker

PHOTOS = Path(__file__).resolve().parents[3] / "shared" / "data" / "real-aruco"


def square(cx: float, cy: float, side: float) -> np.ndarray:
    h = side / 2
    return np.array([[cx - h, cy - h], [cx + h, cy - h], [cx + h, cy + h], [cx - h, cy + h]])


def test_an_inner_contour_of_the_same_id_is_dropped_and_the_outer_square_kept():
    # An 85 px marker and the inner edge of its black border, 8 px in, both decoded as id 3 (issue 34).
    quads = np.stack([square(200, 150, 69), square(200, 150, 85)])
    assert one_quad_per_marker(quads, np.array([3, 3])).tolist() == [1]


def test_two_quads_a_pixel_apart_are_one_marker():
    quads = np.stack([square(200, 150, 85), square(201, 150, 85)])
    assert len(one_quad_per_marker(quads, np.array([3, 3]))) == 1


def test_two_printed_markers_with_the_same_id_are_both_kept_and_other_ids_untouched():
    quads = np.stack([square(100, 150, 60), square(400, 150, 60), square(102, 150, 50)])
    assert one_quad_per_marker(quads, np.array([5, 5, 6])).tolist() == [0, 1, 2]


def test_the_aruco_source_reports_one_detection_per_marker_on_a_photo_of_many():
    path = PHOTOS / "contrib__singlemarkersoriginal.jpg"
    if not path.is_file():
        pytest.skip(f"{path} (the real photos) is not beside the checkout")
    source = ArucoSource({"dictionary": "DICT_6X6_250", "marker_size_m": 0.05})
    ids = [d.marker_id for d in source.process(Frame(image=cv2.imread(str(path)), stamp=0.0))]
    source.close()
    assert len(ids) == len(set(ids)) >= 5
