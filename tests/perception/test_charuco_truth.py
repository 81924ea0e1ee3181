"""Our ArUco corners against ground truth from a ChArUco board's saddle points (bench/charuco_truth.py,
issue 34), on the two real ChArUco photos in ../shared/data/real-aruco: never wrong where OpenCV is right —
our worst corner within 3.5 px wherever raw OpenCV is within 2 px, our p95 no worse than raw OpenCV's, and no
id reported twice."""

from __future__ import annotations

import json

import cv2
import numpy as np
import pytest

from bench.charuco_truth import TUTORIAL_BOARD, charuco_truth, corner_errors, duplicates, main
from mission.core.types import CameraIntrinsics, Frame
from mission.perception_plugins.aruco import ArucoSource
from tests.helpers.shared_photos import real_aruco_photo

PHOTOS = ("contrib__choriginal.jpg", "contrib__chocclusion_original.jpg")


def photo(name: str) -> np.ndarray:
    return cv2.imread(str(real_aruco_photo(name)), cv2.IMREAD_GRAYSCALE)


def raw_opencv(grey: np.ndarray) -> list[tuple[int, np.ndarray]]:
    dictionary = cv2.aruco.getPredefinedDictionary(cv2.aruco.DICT_6X6_250)
    corners, ids, _ = cv2.aruco.ArucoDetector(dictionary, cv2.aruco.DetectorParameters()).detectMarkers(grey)
    return [] if ids is None else [(int(i), c) for i, c in zip(ids.ravel(), corners, strict=True)]


def ours(grey: np.ndarray) -> list[tuple[int, np.ndarray]]:
    source = ArucoSource({"dictionary": "DICT_6X6_250", "marker_size_m": 0.02})
    h, w = grey.shape
    frame = Frame(image=grey, stamp=0.0, intrinsics=CameraIntrinsics.fallback(w, h))
    return [(d.marker_id, d.corners) for d in source.process(frame)]


def test_the_truth_is_the_saddle_points_not_a_detector():
    grey = photo("contrib__choriginal.jpg")
    truth = charuco_truth(grey, TUTORIAL_BOARD)
    assert sorted(truth) == list(range(17))  # every marker of the 5 × 7 board has saddle points round it
    side = np.hypot(*(truth[8][1] - truth[8][0]))
    assert 20 < side < 60  # a 2 cm marker in a 640 × 480 photo of the board
    raw = dict(raw_opencv(grey))
    assert np.abs(np.asarray(raw[8]).reshape(4, 2) - truth[8]).max() < 2.5  # the library agrees to ~1 px


@pytest.mark.parametrize("name", PHOTOS)
def test_never_wrong_where_opencv_is_right_against_charuco_truth(name):
    grey = photo(name)
    truth = charuco_truth(grey, TUTORIAL_BOARD)
    raw, mine = raw_opencv(grey), ours(grey)
    assert duplicates(mine) == 0
    raw_by_id, mine_by_id = dict(raw), dict(mine)
    for marker_id in truth:
        if marker_id in raw_by_id and corner_errors([(marker_id, raw_by_id[marker_id])], truth).max() <= 2.0:
            assert marker_id in mine_by_id, f"marker {marker_id}: OpenCV finds it, we do not"
            assert corner_errors([(marker_id, mine_by_id[marker_id])], truth).max() <= 3.5
    assert np.percentile(corner_errors(mine, truth), 95) <= np.percentile(corner_errors(raw, truth), 95)


def test_the_command_line_measures_the_tutorial_photos(tmp_path, capsys):
    """`python -m bench.charuco_truth` (for public ChArUco sets kept off the repository) gives the figures
    the tests above check, for both photos at once; a file it cannot read is a line naming it."""
    paths = [str(real_aruco_photo(name)) for name in PHOTOS]  # skips when ../shared/data is not there
    (tmp_path / "broken.jpg").write_bytes(b"not a jpeg")
    out = tmp_path / "figures.json"
    argv = ["--board", "5x7", "--square-m", "0.04", "--marker-m", "0.02", "--dictionary", "dict_6x6_250"]
    assert main([*paths, str(tmp_path / "broken.jpg"), *argv, "--json", str(out)]) == 1  # the rest still measured
    printed = capsys.readouterr()
    assert printed.err.strip() == f"{tmp_path / 'broken.jpg'}: cannot be read as an image"
    figures = json.loads(out.read_text())
    assert figures["images"] == 2 and figures["images_without_board"] == []
    assert figures["markers_with_truth"] == 17 + 10  # the occluded photo: 10 markers with saddle points round them
    ours, raw = figures["ours"], figures["raw_opencv"]
    assert ours["corners"] == raw["corners"] == 4 * 27
    assert ours["p95_px"] <= raw["p95_px"] < 2.0 and ours["worst_px"] < 2.0
    assert ours["duplicates"] == ours["off_board"] == 0
    assert figures["ours_corners_over_3_5px_where_raw_within_2px"] == 0 and figures["cases"] == []
    assert all(figures["acceptance"].values())
    assert "acceptance: never wrong where OpenCV is right: yes; p95 no worse: yes; no duplicates: yes" in printed.out

    assert main([paths[0], *argv[:-1], "DICT_6X6_2500"]) == 2  # one line naming the bad name, and no figures
    printed = capsys.readouterr()
    assert printed.out == "" and printed.err.startswith("--dictionary DICT_6X6_2500: unknown; one of DICT_4X4_50")
