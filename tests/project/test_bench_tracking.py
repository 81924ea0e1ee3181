"""The tracking benchmark (bench/tracking_bench.py). Its new-marker latency (track_sequence): how many frames after
the full-frame baseline first sees a marker the tracked source reports it. What each side reports is scripted
here per frame (the metric is under test, not a detector); the frames are real images the bench converts.
And its speed-up figures as BENCHMARKS shows them."""

from __future__ import annotations

from dataclasses import dataclass, field
from types import SimpleNamespace

import numpy as np

from bench.marker_sequences import SequenceFrame
from bench.report import figure_table
from bench.tracking_bench import _speedup_figure, track_sequence
from mission.core.types import Frame

QUAD = np.array([[10.0, 10.0], [30.0, 10.0], [30.0, 30.0], [10.0, 30.0]])


@dataclass
class Scripted:
    """A source that reports, on frame i, the ids in script[i] (and has the tracker counters the bench reads)."""

    script: list[set[int]]
    tracker: SimpleNamespace = field(default_factory=lambda: SimpleNamespace(full_passes=1, window_passes=0))
    frame: int = 0

    def process(self, frame: Frame) -> list[SimpleNamespace]:
        ids = self.script[self.frame]
        self.frame += 1
        return [SimpleNamespace(marker_id=m, corners=QUAD) for m in sorted(ids)]


def measure(baseline: list[set[int]], tracked: list[set[int]]) -> dict:
    frames = [SequenceFrame(np.zeros((40, 40, 3), np.uint8), {}) for _ in baseline]
    script = iter(baseline)
    return track_sequence(frames, None, Scripted(tracked), lambda grey, frame: dict.fromkeys(next(script), QUAD))


def test_a_marker_the_tracked_source_reports_two_frames_late_waited_two_frames():
    r = measure([set(), {7}, {7}, {7}, {7}], [set(), set(), set(), {7}, {7}])
    assert r["new_marker_wait_max_frames"] == 2 and r["new_markers"] == 1 and r["new_markers_unfound"] == 0
    assert r["recall"] == 0.5


def test_a_marker_the_baseline_saw_once_and_tracking_never_is_a_miss_not_a_wait_to_the_end():
    # one sighting on frame 1 of a 40-frame sequence: counted as a wait to the end, it read 39 frames
    baseline = [set(), {7}] + [set()] * 38
    r = measure(baseline, [set()] * 40)
    assert r["new_marker_wait_max_frames"] == 0
    assert r["new_markers"] == 1 and r["new_markers_unfound"] == 1
    assert r["recall"] == 0.0


def test_a_marker_still_in_view_and_never_reported_at_the_end_is_unfound():
    r = measure([{3}, {3, 9}, {3, 9}], [{3}, {3}, {3}])
    assert r["new_markers"] == 2 and r["new_markers_unfound"] == 1 and r["new_marker_wait_max_frames"] == 0


def test_the_report_gives_a_speed_up_figures_baseline_in_milliseconds_not_as_a_ratio():
    # BENCHMARKS printed the baseline's 6.40 ms a frame as "6.40×", in the speed-up's unit
    r = measure([{7}] * 4, [{7}] * 4)
    line = figure_table([_speedup_figure("aruco 1280×720, 8 markers", r, "OpenCV, full frame", 3.0).to_json()])[2]
    baseline_cell = line.split(" | ")[3]
    assert baseline_cell == f"{r['baseline_ms']} ms a frame (tracked: {r['tracked_ms']} ms)"
