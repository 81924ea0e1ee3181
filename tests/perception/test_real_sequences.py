"""python -m bench.real_sequences (issue 34): the aruco source's tracking mode on a real sequence, against OpenCV's
default detector and against tracking off, with ChArUco saddle-point truth — here the two tutorial ChArUco
photos in ../shared/data/real-aruco, repeated as a short sequence (the board, then a hand over part of it, then
the board again: tracked markers vanish and come back)."""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest

from bench.real_sequences import main
from tests.helpers.shared_photos import real_aruco_photo

BOARD = ["--dictionary", "DICT_6X6_250", "--board", "5x7", "--square-m", "0.04", "--marker-m", "0.02"]
ORIGINAL, OCCLUDED = "contrib__choriginal.jpg", "contrib__chocclusion_original.jpg"


def photo(name: str) -> Path:
    return real_aruco_photo(name)


def run(args: list[str], out: Path) -> dict:
    assert main([*args, *BOARD, "--json", str(out)]) == 0
    return json.loads(out.read_text())


def test_tracking_loses_no_marker_and_places_them_as_well_as_tracking_off(tmp_path, capsys):
    names = [ORIGINAL] * 3 + [OCCLUDED] * 3 + [ORIGINAL] * 2
    r = run([str(photo(n)) for n in names], tmp_path / "out.json")
    assert r["frames"] == 8 and r["frames_with_truth"] == 8
    for key in ("opencv_default", "tracking_off"):
        x = r[key]
        assert x["markers_baseline"] >= 100  # 17 markers on the board, some under the hand for three frames
        assert x["recall"] == 1.0, x["missed"]
        assert x["recall_on_board"] == 1.0 and x["baseline_off_board"] == 0
        assert x["missed"] == [] and x["less_accurate"] == []
        assert x["new_marker_wait_max_frames"] == 0 and x["longest_miss_run_frames"] == 0  # found again at once
        assert x["corner_p95_tracked_px"] < 1.6 and x["corner_max_tracked_px"] < 2.0
        assert x["window_passes"] >= 3  # tracking did track, not run the full frame every time
    off, cv = r["tracking_off"], r["opencv_default"]
    assert off["corner_p95_tracked_px"] == pytest.approx(off["corner_p95_baseline_px"], abs=0.05)
    assert cv["corner_p95_tracked_px"] <= cv["corner_p95_baseline_px"]
    table = capsys.readouterr().out
    assert "recall" in table and "corner p95 px" in table


def test_a_video_of_an_inverted_board_read_every_other_frame(tmp_path):
    images = [cv2.imread(str(photo(n))) for n in [ORIGINAL] * 4 + [OCCLUDED] * 4]
    video = tmp_path / "board.avi"
    writer = cv2.VideoWriter(str(video), cv2.VideoWriter_fourcc(*"MJPG"), 10.0, (640, 480))
    for image in images:
        writer.write(255 - image)  # printed inverted, as caliscope's boards are
    writer.release()
    r = run([str(video), "--invert", "--every", "2"], tmp_path / "out.json")
    assert r["frames"] == 4 and r["frames_with_truth"] == 4
    assert r["opencv_default"]["recall"] == 1.0 and r["opencv_default"]["markers_baseline"] >= 50
    assert r["opencv_default"]["corner_max_tracked_px"] < 2.5  # MJPG on top of the photo's own JPEG


def test_unreadable_input_and_unknown_dictionary_are_one_line_and_exit_2(tmp_path, capsys):
    bad = tmp_path / "frame_001.png"
    bad.write_bytes(b"not a png")
    for args, named in (
        ([str(bad), "--dictionary", "DICT_6X6_250"], str(bad)),
        ([str(tmp_path / "missing.mp4"), "--dictionary", "DICT_6X6_250"], "missing.mp4"),
        ([str(bad), "--dictionary", "DICT_9X9_1"], "DICT_9X9_1"),
    ):
        assert main(args) == 2
        out, err = capsys.readouterr()
        assert out == ""  # nothing measured, no table
        assert len(err.strip().splitlines()) == 1 and named in err


def test_an_id_the_board_does_not_carry_is_the_baselines_false_detection_not_a_miss():
    # caliscope's webcam videos, DICT_4X4_1000: OpenCV's full frame decodes ids 660, 17 and 441 from 6–12 px specks
    # beside a 4×5 board of ids 0–9; tracking does not repeat them, and the recall of the board's markers is
    # what says whether it lost a marker
    from types import SimpleNamespace

    from bench.real_sequences import cases

    quad = np.array([[0.0, 0.0], [20.0, 0.0], [20.0, 20.0], [0.0, 20.0]])
    refs = [{1: quad, 2: quad + 40}, {1: quad, 2: quad + 40, 660: quad + 80}, {1: quad, 2: quad + 40}]
    founds = [{1: quad, 2: quad + 40}, {1: quad, 2: quad + 40}, {1: quad}]
    seq = SimpleNamespace(frames=[SimpleNamespace(truth={}) for _ in refs], labels=[f"f{i}" for i in range(3)])
    mine = SimpleNamespace(found=founds, full=[True, False, False])
    r = cases(seq, mine, refs, board_ids=set(range(10)))
    assert r["baseline_off_board"] == 1
    assert r["recall_on_board"] == round(5 / 6, 4)  # frame 2's marker 2 is the one real miss
    assert [(m["frame"], m["marker_id"], m["why"].split(":")[0]) for m in r["missed"]] == [
        (1, 660, "not on the board"),
        (2, 2, "tracked last frame, window pass did not find it"),
    ]
    assert cases(seq, mine, refs, board_ids=None)["recall_on_board"] is None  # no board, no truth to tell by
