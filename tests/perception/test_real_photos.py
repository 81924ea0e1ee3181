"""The ArUco source on real photographs (OpenCV's tutorial photos in ../shared/data, beside the checkout as CI
has it): the ids raw OpenCV finds, corners that stay on the markers, a custom dictionary from its file."""

from __future__ import annotations

import json
import subprocess
import sys

import cv2
import numpy as np
import pytest

from bench.real_images import PHOTO_SETS, aruco_corner_study, read_grey
from mission.core.types import Frame
from mission.perception_plugins.aruco import ArucoSource

SHARED_SETS = [ps for ps in PHOTO_SETS if ps.shared]


@pytest.fixture(scope="module")
def studies():
    return {ps.name: aruco_corner_study(ps.files(), ps.dictionary_value()) for ps in SHARED_SETS}


def test_the_shared_photos_are_there():
    """CI has ../shared/data; without it these tests must fail, not pass vacuously."""
    for ps in SHARED_SETS:
        assert len(ps.files()) >= 2, f"{ps.name}: no photos under {ps.root()}"


def test_the_source_finds_the_ids_raw_opencv_finds_in_every_photo(studies):
    for name, s in studies.items():
        assert s.images >= 2 and s.markers_raw >= 20, name
        assert s.same_ids == s.images, f"{name}: ids differ from raw OpenCV's in {s.images - s.same_ids} photos"


def test_no_more_corners_leave_the_refiners_consensus_than_unrefined_opencvs(studies):
    """The reference corner is where OpenCV's contour and AprilTag refiners agree within 1 px; a corner more
    than 2 px from it is off the marker's corner."""
    compared = sum(s.compared["ours"] for s in studies.values())
    ours = sum(s.outliers["ours"] for s in studies.values())
    unrefined = sum(s.outliers["unrefined"] for s in studies.values())
    assert compared >= 150  # most corners have a consensus to be judged by
    assert ours <= unrefined
    assert max(s.worst_px["ours"] for s in studies.values()) < 2.0 + 1.0  # nothing dragged into the marker


def test_refined_corners_sit_closer_to_the_consensus_than_unrefined_ones():
    """On the tutorial's single-marker photo: the refinement earns its keep on real images too."""
    ps = SHARED_SETS[0]
    path = next(p for p in ps.files() if "singlemarkers" in p.name)
    grey = read_grey(path)
    dictionary = cv2.aruco.getPredefinedDictionary(cv2.aruco.DICT_6X6_250)

    def corners(method: int) -> dict[int, np.ndarray]:
        params = cv2.aruco.DetectorParameters()
        params.cornerRefinementMethod = method
        c, ids, _ = cv2.aruco.ArucoDetector(dictionary, params).detectMarkers(grey)
        return {int(i): x.reshape(4, 2) for x, i in zip(c, ids.reshape(-1), strict=True)}

    contour, april, raw = corners(2), corners(3), corners(0)
    ours = {d.marker_id: d.corners for d in ArucoSource({"dictionary": "DICT_6X6_250"}).process(Frame(grey, 0.0))}
    assert sorted(ours) == sorted(raw)
    err_ours, err_raw = [], []
    for i in ours:
        reference = (contour[i] + april[i]) / 2
        err_ours += np.linalg.norm(ours[i] - reference, axis=1).tolist()
        err_raw += np.linalg.norm(raw[i] - reference, axis=1).tolist()
    assert np.median(err_ours) < np.median(err_raw)


def test_a_custom_dictionary_from_its_file_reads_the_board_printed_with_it(studies):
    """OpenCV's tutorial grid board: 35 markers of its own 6×6 dictionary (contrib__tutorial_dict.yml)."""
    ps = next(p for p in SHARED_SETS if p.dictionary.endswith(".yml"))
    board = next(p for p in ps.files() if "gboriginal" in p.name)
    dets = ArucoSource({"dictionary": ps.dictionary_value()}).process(Frame(read_grey(board), 0.0))
    assert sorted(d.marker_id for d in dets) == list(range(35))
    assert all(d.extra["dictionary"] == ps.dictionary_value() for d in dets)


def test_mission_detect_reads_a_real_photo_with_a_dictionary_file():
    ps = next(p for p in SHARED_SETS if p.dictionary.endswith(".yml"))
    board = next(p for p in ps.files() if "gboriginal" in p.name)
    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "mission",
            "detect",
            str(board),
            "--source",
            "aruco",
            "--set",
            f"dictionary={ps.dictionary_value()}",
            "--json",
        ],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 0, proc.stderr
    (record,) = [json.loads(line) for line in proc.stdout.splitlines()]
    assert len(record["detections"]) == 35
