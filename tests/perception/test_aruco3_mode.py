"""bench.aruco3_mode (issue 34): OpenCV's ArUco 3 mode and tracking's search pass against OpenCV's default, on a
rendered panning sequence, with real OpenCV."""

from __future__ import annotations

from bench.aruco3_mode import RATIOS, measure


def test_each_reduced_resolution_detector_is_measured_against_the_default_on_the_same_frames():
    rows = {r["detector"]: r for r in measure(640, 480, 3, n_frames=12)}
    default = rows.pop("OpenCV default")
    assert default["recall"] == 1.0 and default["speedup"] == 1.0
    # 32–90 px markers: the search pass (640×480 searched at 320×240, down to 12 sampled px) finds them all,
    # ArUco 3 mode keeps nothing under 32 + ratio × 640 px and so loses the small ones
    search = rows["search pass (every 2nd pixel)"]
    assert search["recall"] == 1.0
    for ratio in RATIOS:
        aruco3 = rows[f"ArUco 3 mode, ratio {ratio:g}"]
        assert aruco3["smallest_px"] >= 32 + ratio * 640 - 1 and aruco3["recall"] < 1.0
