"""Soak: does a long run stay flat? Memory growth and tick-time drift of the mission and of the ROS node.

(a) sim: ``mission_full`` (dock, then follow the looping target) for 30 simulated minutes through the same
    ``run_scenario`` as ``mission run``; every simulated minute the process RSS, the tracemalloc total and the
    wall time of the ticks in that minute are sampled (tracemalloc only in quick mode: it doubles the cost).
(b) ros: the installed node (``install/mission/lib/mission/tree``, perception mode, 30 Hz ticks) in its own
    process on the shared-memory FastDDS profile and a private ROS_DOMAIN_ID (nothing leaves the machine),
    fed rendered marker frames at 30 Hz for 10 minutes; every 10 s its RSS (from /proc) and the
    frame → /detected_aruco_pose latency are sampled, and its 1 Hz heartbeat counters are read.

Flat means: RSS growth over the run small next to the RSS itself, and the last 5 minutes' tick p50/p99 within
noise of the first 5. Quick mode: 2 simulated minutes and 30 s of ROS.

    python -m bench.soak [--quick] [--part sim|ros|both] [--out DIR]   # DIR: bench/results, --quick: out/bench-quick
"""

from __future__ import annotations

import argparse
import json
import sys
import time
import tracemalloc
from pathlib import Path
from typing import Any

import numpy as np

from bench.catalogue import default_output
from bench.common import Figure, load_average, pct
from bench.ros_feed import Feeder, Subject, Subprocess, build_ros, node_command, ros_env, rss_mb
from mission.core.files import atomic_write_text
from mission.core.observers import RunObserver, Tick


def slope_per_min(xs: list[float], ys: list[float]) -> float | None:
    """Least-squares slope of ys over xs (minutes)."""
    if len(xs) < 2:
        return None
    return round(float(np.polyfit(np.asarray(xs, float), np.asarray(ys, float), 1)[0]), 4)


def _write(out: Path, name: str, data: dict[str, Any]) -> None:
    atomic_write_text(out / name, json.dumps(data, indent=1, default=str))


# --------------------------------------------------------------------------------------------------
# (a) the simulated mission
# --------------------------------------------------------------------------------------------------


class _Sampler(RunObserver):
    """A run observer sampling memory and tick wall time once per simulated minute."""

    def __init__(self, period_s: float, trace: bool, out: Path | None) -> None:
        self.period_s = period_s
        self.trace = trace
        self.out = out
        self.samples: list[dict[str, Any]] = []
        self.tick_ms: list[float] = []  # this minute's cycle times (tick + world advance + metrics)
        self.all_ticks: list[tuple[float, float]] = []  # (sim minute, ms) — a float pair per tick, bounded by the run
        self._last = time.perf_counter()
        self._next = period_s
        self._t0: float | None = None
        self._snap0: Any = None

    def on_start(self, runner: Any) -> None:
        if self.trace:
            tracemalloc.start(1)
        self._last = time.perf_counter()

    def on_tick(self, runner: Any, tick: Tick) -> None:
        gt = tick.ground_truth
        now = time.perf_counter()
        ms = (now - self._last) * 1e3
        self._last = now
        self._t0 = gt.stamp if self._t0 is None else self._t0
        t = gt.stamp - self._t0
        self.tick_ms.append(ms)
        self.all_ticks.append((t / 60.0, ms))
        if t + 1e-9 >= self._next:
            self._next += self.period_s
            self._sample(runner, t)
        self._last = time.perf_counter()  # the sampling itself is not tick time

    def _sample(self, runner: Any, t: float) -> None:
        from mission.core import blackboard as bbk

        s: dict[str, Any] = {
            "sim_min": round(t / 60.0, 3),
            "rss_mb": round(rss_mb(), 2),
            "tick_p50_ms": pct(self.tick_ms, 50),
            "tick_p99_ms": pct(self.tick_ms, 99),
            "ticks": runner.ticks,
            "state": runner.get(bbk.STATE, ""),
        }
        if self.trace:
            cur, _peak = tracemalloc.get_traced_memory()
            s["traced_mb"] = round(cur / 1e6, 2)
            snap = tracemalloc.take_snapshot()
            if self._snap0 is None:
                self._snap0 = snap
            else:
                top = snap.compare_to(self._snap0, "lineno")[:5]
                s["top_growth"] = [
                    f"{st.traceback[0].filename.split('/')[-1]}:{st.traceback[0].lineno} {st.size_diff / 1e3:+.0f} kB"
                    for st in top
                ]
        self.tick_ms = []
        self.samples.append(s)
        if self.out is not None:
            _write(self.out, ".soak_sim_partial.json", {"samples": self.samples})

    def on_end(self, runner: Any, outcome: Any) -> None:
        if self.trace:
            tracemalloc.stop()


def run_sim(minutes: float, trace: bool, out: Path | None = None) -> dict[str, Any]:
    """mission_full for `minutes` simulated minutes; samples every simulated minute (every 15 s in short runs)."""
    from mission.app.sim_run import run_scenario

    period = 60.0 if minutes >= 5 else 15.0
    sampler = _Sampler(period, trace, out)
    wall0 = time.perf_counter()
    outcome, recorder, _ = run_scenario("mission_full", seed=0, max_duration=minutes * 60.0, observers=[sampler])
    wall = time.perf_counter() - wall0
    samples = sampler.samples
    ticks = np.asarray(sampler.all_ticks) if sampler.all_ticks else np.zeros((0, 2))
    window = min(5.0, minutes / 2)
    first = ticks[ticks[:, 0] < window, 1] if len(ticks) else []
    last = ticks[ticks[:, 0] >= ticks[-1, 0] - window, 1] if len(ticks) else []
    rss = [s["rss_mb"] for s in samples]
    # Growth after the first sample: the first minute includes one-off warm-up (renderer, noise bank, caches).
    result = {
        "sim_minutes": round(outcome.sim_time_s / 60.0, 2),
        "wall_s": round(wall, 1),
        "ticks": outcome.ticks,
        "outcome": {"success": outcome.success, "reason": outcome.reason, "final_state": outcome.final_state},
        "rss_first_mb": rss[0] if rss else None,
        "rss_last_mb": rss[-1] if rss else None,
        "rss_growth_mb": round(rss[-1] - rss[0], 2) if len(rss) > 1 else None,
        "rss_slope_mb_per_min": slope_per_min([s["sim_min"] for s in samples], rss),
        "tick_slope_ms_per_min": slope_per_min(list(ticks[:, 0]), list(ticks[:, 1])) if len(ticks) else None,
        "window_min": window,
        "tick_first_p50_ms": pct(first, 50),
        "tick_first_p99_ms": pct(first, 99),
        "tick_last_p50_ms": pct(last, 50),
        "tick_last_p99_ms": pct(last, 99),
        "recorder_ticks_kept": len(getattr(recorder, "_rows", []) or []),
        "samples": samples,
    }
    if trace and samples and "traced_mb" in samples[0]:
        result["traced_growth_mb"] = round(samples[-1]["traced_mb"] - samples[0]["traced_mb"], 2)
        result["top_growth"] = samples[-1].get("top_growth", [])
    return result


# --------------------------------------------------------------------------------------------------
# (b) the ROS node
# --------------------------------------------------------------------------------------------------

MARKER_ID = 7
MARKER_SIZE = 0.15


def run_ros(seconds: float, out: Path | None = None) -> dict[str, Any]:
    """The node fed marker / empty frames alternately (1 s each) at 30 Hz for `seconds` (bench/ros_feed.py)."""
    from mission.core import se3
    from tools.synthetic_views import R_FRONTAL, default_intrinsics, render_marker_view

    build_ros()
    env = ros_env()
    K = default_intrinsics()
    rng = np.random.default_rng(5)
    T = se3.transform(R_FRONTAL @ se3.rot_y(0.3), (0.12, -0.06, 1.6))
    views = [
        render_marker_view(T, marker_id=MARKER_ID, marker_size_m=MARKER_SIZE, intrinsics=K, rng=rng).image,
        render_marker_view(
            se3.transform(R_FRONTAL, (30.0, 0.0, 2.0)),
            marker_id=MARKER_ID,
            marker_size_m=MARKER_SIZE,
            intrinsics=K,
            rng=rng,
        ).image,
    ]
    node = Subject("node")
    proc = Subprocess(node_command(MARKER_ID, MARKER_SIZE, 30.0), env, (out or Path("/tmp")) / ".soak_ros_node.log")
    feeder = Feeder([node], views, K, hz=30.0, frames_per_view=30, heartbeat_topic="/aruco/debug", name="soak_feeder")
    samples: list[dict[str, Any]] = []
    try:
        deadline = time.monotonic() + 30
        feeder.active = node.name
        while not feeder.newest_heartbeat() and time.monotonic() < deadline and proc.alive():
            time.sleep(0.1)
        start = time.monotonic()
        period = 10.0
        next_t = start + period
        while time.monotonic() - start < seconds and proc.alive():
            time.sleep(max(0.0, min(1.0, next_t - time.monotonic())))
            if time.monotonic() >= next_t:
                next_t += period
                chunk, beat = feeder.take(node.name), feeder.newest_heartbeat()
                samples.append(
                    {
                        "t_min": round((time.monotonic() - start) / 60.0, 3),
                        "rss_mb": round(rss_mb(proc.pid), 2),
                        "latency_p50_ms": pct(chunk, 50),
                        "latency_p99_ms": pct(chunk, 99),
                        "answers": len(chunk),
                        "published": feeder.published[node.name],
                        "frames_received": beat.get("frames_received"),
                        "frames_processed": beat.get("frames_processed"),
                        "frames_dropped": beat.get("frames_dropped"),
                        "tick": beat.get("tick"),
                    }
                )
                if out is not None:
                    _write(out, ".soak_ros_partial.json", {"samples": samples})
    finally:
        feeder.close()
        alive = proc.stop()
    published = feeder.published[node.name]
    if not samples:
        return {"error": f"node gave no heartbeat; log: {proc.log_path}: {proc.log_tail()}", "alive": alive}
    rss = [s["rss_mb"] for s in samples]
    n5 = max(1, len(samples) // 2 if seconds < 600 else 30)  # 30 samples of 10 s = 5 min
    first = [s["latency_p50_ms"] for s in samples[:n5] if s["latency_p50_ms"] is not None]
    last = [s["latency_p50_ms"] for s in samples[-n5:] if s["latency_p50_ms"] is not None]
    first99 = [s["latency_p99_ms"] for s in samples[:n5] if s["latency_p99_ms"] is not None]
    last99 = [s["latency_p99_ms"] for s in samples[-n5:] if s["latency_p99_ms"] is not None]
    return {
        "seconds": seconds,
        "node_alive_at_end": alive,
        "frames_published": published,
        "rss_first_mb": rss[0],
        "rss_last_mb": rss[-1],
        "rss_growth_mb": round(rss[-1] - rss[0], 2),
        "rss_slope_mb_per_min": slope_per_min([s["t_min"] for s in samples], rss),
        "latency_slope_ms_per_min": slope_per_min(
            [s["t_min"] for s in samples if s["latency_p50_ms"] is not None],
            [s["latency_p50_ms"] for s in samples if s["latency_p50_ms"] is not None],
        ),
        "latency_first_p50_ms": pct(first, 50),
        "latency_last_p50_ms": pct(last, 50),
        "latency_first_p99_ms": pct(first99, 50),
        "latency_last_p99_ms": pct(last99, 50),
        "samples": samples,
    }


# --------------------------------------------------------------------------------------------------
# the benchmark
# --------------------------------------------------------------------------------------------------


def figures(sim: dict[str, Any] | None, ros: dict[str, Any] | None) -> list[Figure]:
    figs: list[Figure] = []
    if sim and "rss_growth_mb" in sim:
        figs += [
            Figure(
                "sim: RSS growth after the first simulated minute",
                sim["rss_growth_mb"],
                "MB",
                "RSS at the first sample",
                sim["rss_first_mb"],
                target="flat (< 5% of RSS)",
                meets_target=None
                if sim["rss_growth_mb"] is None
                else sim["rss_growth_mb"] < 0.05 * sim["rss_first_mb"],
            ),
            Figure(
                "sim: tick p50, last window",
                sim["tick_last_p50_ms"],
                "ms",
                "tick p50, first window",
                sim["tick_first_p50_ms"],
                None,
            ),
            Figure(
                "sim: tick p99, last window",
                sim["tick_last_p99_ms"],
                "ms",
                "tick p99, first window",
                sim["tick_first_p99_ms"],
                None,
            ),
        ]
    if ros and "rss_growth_mb" in ros:
        figs += [
            Figure(
                "ros node: RSS growth",
                ros["rss_growth_mb"],
                "MB",
                "node RSS at the first sample",
                ros["rss_first_mb"],
                target="flat (< 5% of RSS)",
                meets_target=ros["rss_growth_mb"] < 0.05 * ros["rss_first_mb"],
            ),
            Figure(
                "ros node: frame → pose latency p50, last window",
                ros["latency_last_p50_ms"],
                "ms",
                "same, first window",
                ros["latency_first_p50_ms"],
            ),
        ]
    for f in figs:
        if isinstance(f.value, float | int) and isinstance(f.baseline_value, float | int) and f.baseline_value:
            f.ratio = round(f.value / f.baseline_value, 3)
    return figs


def run(quick: bool, out: Path, part: str = "both") -> dict[str, Any]:
    """The soak benchmark (quick: 2 simulated minutes + 30 s of ROS; full: 30 min + 10 min)."""
    sim = run_sim(2.0 if quick else 30.0, trace=quick, out=out) if part in ("sim", "both") else None
    ros = run_ros(30.0 if quick else 600.0, out=out) if part in ("ros", "both") else None
    return {
        "title": "Soak: memory and tick time over a long run",
        "figures": [f.to_json() for f in figures(sim, ros)],
        "details": {"quick": quick, "load_average": load_average(), "sim": sim, "ros": ros},
        "plots": [],
    }


def sim_from_samples(samples: list[dict[str, Any]], planned_min: float) -> dict[str, Any]:
    """The sim figures from the per-minute samples alone (a run stopped before its end: its partial file)."""
    rss = [s["rss_mb"] for s in samples]
    mins = [s["sim_min"] for s in samples]
    n = min(5, max(1, len(samples) // 2))
    return {
        "partial": True,
        "planned_sim_minutes": planned_min,
        "sim_minutes": mins[-1] if mins else 0,
        "ticks": samples[-1]["ticks"] if samples else 0,
        "outcome": {"final_state": samples[-1]["state"] if samples else ""},
        "rss_first_mb": rss[0] if rss else None,
        "rss_last_mb": rss[-1] if rss else None,
        "rss_growth_mb": round(rss[-1] - rss[0], 2) if len(rss) > 1 else None,
        "rss_slope_mb_per_min": slope_per_min(mins, rss),
        "tick_slope_ms_per_min": slope_per_min(mins, [s["tick_p50_ms"] for s in samples]),
        "window_min": n,
        "tick_first_p50_ms": pct([s["tick_p50_ms"] for s in samples[:n]], 50),
        "tick_first_p99_ms": pct([s["tick_p99_ms"] for s in samples[:n]], 50),
        "tick_last_p50_ms": pct([s["tick_p50_ms"] for s in samples[-n:]], 50),
        "tick_last_p99_ms": pct([s["tick_p99_ms"] for s in samples[-n:]], 50),
        "samples": samples,
    }


def merge(out: Path) -> dict[str, Any]:
    """soak.json from the separately run parts (``--part sim`` / ``--part ros``; a sim part still running
    contributes its per-minute samples so far)."""
    sim = ros = None
    loads: dict[str, Any] = {}  # each part's load average when it ran (not the merge's)
    if (out / "soak_sim.json").exists():
        part = json.loads((out / "soak_sim.json").read_text())["details"]
        sim, loads["sim"] = part["sim"], part.get("load_average")
    elif (out / ".soak_sim_partial.json").exists():
        sim = sim_from_samples(json.loads((out / ".soak_sim_partial.json").read_text())["samples"], 30.0)
    if (out / "soak_ros.json").exists():
        part = json.loads((out / "soak_ros.json").read_text())["details"]
        ros, loads["ros"] = part["ros"], part.get("load_average")
    return {
        "title": "Soak: memory and tick time over a long run",
        "figures": [f.to_json() for f in figures(sim, ros)],
        "details": {"quick": False, "load_average_of_parts": loads, "sim": sim, "ros": ros},
        "plots": [],
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m bench.soak", description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--part", choices=("sim", "ros", "both"), default="both")
    ap.add_argument("--out", type=Path, default=None, help="default bench/results; with --quick out/bench-quick")
    ap.add_argument("--merge", action="store_true", help="write soak.json from the parts' results in --out")
    args = ap.parse_args(argv)
    args.out = args.out or default_output(args.quick)  # a quick soak never replaces the committed one
    if args.merge:
        _write(args.out, "soak.json", merge(args.out))
        return 0
    result = run(args.quick, args.out, args.part)
    name = "soak.json" if args.part == "both" else f"soak_{args.part}.json"
    _write(args.out, name, result)
    print(json.dumps(result["figures"], indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
