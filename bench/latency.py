"""Benchmark: end-to-end latency — a frame on the blackboard → a command on the blackboard.

From the live `mission_full` run recorded in bench/tick_recording.py (the loop of ``mission run``):
for every tick on which the sim adapter delivered a new camera frame, the wall time from the end of
``sense()`` (the frame is on the blackboard) to the end of ``tree.tick()`` (the goal / twist / dock
setpoint the frame led to is on the blackboard): the perception stage, then the tick. The baseline is the
detector alone: the perception source's ``process()`` time on the same frames. p50 and p99 of both;
their difference is what the tree adds to the reaction time.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from bench.common import Figure, pct, plot_cdf, progress
from bench.tick_recording import record


def run(quick: bool, out: Path) -> dict[str, Any]:
    seconds = 12.0 if quick else 60.0
    rec = record("mission_full", seconds)
    e2e = [t.e2e_s * 1000 for t in rec.ticks if t.new_frame and t.detector_s is not None]
    det = [t.detector_s * 1000 for t in rec.ticks if t.new_frame and t.detector_s is not None]
    added = [a - b for a, b in zip(e2e, det, strict=True)]
    progress(f"latency: {len(e2e)} frames; e2e p50 {pct(e2e, 50)} ms, detector p50 {pct(det, 50)} ms")
    by_state: dict[str, list[float]] = {}
    for t in rec.ticks:
        if t.new_frame and t.detector_s is not None:
            by_state.setdefault(t.state, []).append(t.e2e_s * 1000)
    figures = []
    for q in (50, 99):
        a, b = pct(e2e, q, 2), pct(det, q, 2)
        figures.append(
            Figure(
                f"frame → command on the blackboard, p{q}",
                a,
                "ms",
                baseline="the perception source's process() alone on the same frames",
                baseline_value=b,
                ratio=round(a / b, 3) if a and b else None,
            ).to_json()
        )
    figures.append(
        Figure(
            "tree's share of the reaction time (e2e − detector), p50",
            pct(added, 50, 2),
            "ms",
            baseline="the detector time it is added to (p50 above)",
            baseline_value=pct(det, 50, 2),
        ).to_json()
    )
    plot = _plot(e2e, det, out)
    return {
        "title": "End-to-end latency: frame → command on the blackboard vs the detector alone",
        "figures": figures,
        "details": {
            "scenario": rec.scenario,
            "sim_seconds": seconds,
            "frames": len(e2e),
            "config": rec.config,
            "image": "scenario camera (640x480)",
            "e2e_ms_by_state_p50": {k: pct(v, 50, 2) for k, v in by_state.items()},
            "e2e_ms_p50_p90_p99": [pct(e2e, q, 2) for q in (50, 90, 99)],
            "detector_ms_p50_p90_p99": [pct(det, q, 2) for q in (50, 90, 99)],
        },
        "plots": [plot],
    }


def _plot(e2e: list[float], det: list[float], out: Path) -> str:
    series = {"detector alone": det, "frame → command (perception stage + tree tick)": e2e}
    return plot_cdf(series, "Latency CDF (mission_full, live sim run)", out / "latency_cdf.png")
