"""Benchmark: mission outcomes over many seeds per scenario, against the design notes' targets.

The runs are a `mission sweep` (mission/sweep: scenarios × seeds on a Dask LocalCluster bound to
127.0.0.1, one worker process per core, a progress bar on stderr), so this benchmark and ``mission sweep``
are one code path, and each run is ``run_scenario`` — the code path of ``mission run``. The sweep's
directory is ``<out>/missions_sweep/`` (results.parquet, runs.jsonl, summary.html, the failing runs'
pictures); its rows are copied to ``<out>/missions_runs.jsonl``. A cut-short sweep still leaves its data.

Per scenario: success rate (target ≥ 90 %), loss events and the fraction recovered (≥ 90 %),
occlusion-detection latency (≤ 0.5 s), re-acquisition time (≤ 10 s), goal jitter while the target
stands still (< 0.2 m s.d.), docking errors (lateral ≤ 3 cm, distance ≤ 2.5 cm, skew ≤ 10°), collisions,
and the failure reasons. The baseline of every figure is its design target (seeds/001 and 002).

Knobs (environment, for the lead's re-runs): ``MISSION_BENCH_SEEDS`` (default 20; --quick: 1),
``MISSION_BENCH_SCENARIOS`` (comma-separated), ``MISSION_BENCH_BUDGET_S`` (stop starting runs after
this many wall seconds and report what finished).
"""

from __future__ import annotations

import json
import os
import shutil
import time
from pathlib import Path
from typing import Any

import numpy as np

from bench.common import Figure, pct, progress, save_figure
from mission.core.files import atomic_write_text
from mission.sweep.engine import SweepOutcome, run_sweep
from mission.sweep.plan import SweepPlan

SCENARIOS = ("follow_occlusion", "search_corner", "explore_dock", "mission_full")
QUICK_SCENARIOS = ("follow_occlusion", "explore_dock")
QUICK_MAX_DURATION_S = 12.0
TARGETS = {
    "success_rate": 0.90,
    "loss_recovered": 0.90,
    "occlusion_latency_s": 0.5,
    "reacquisition_s": 10.0,
    "goal_jitter_m": 0.2,
    "dock_lateral_m": 0.03,
    "dock_distance_m": 0.025,
    "dock_skew_deg": 10.0,
}
DESIGN = "design target (seeds/001 follow coordinator, seeds/002 docking)"
SWEEP_DIR = "missions_sweep"  # the sweep directory (table, summary.html, failing runs' pictures); gitignored


def sweep(
    scenarios: tuple[str, ...], seeds: int, max_duration: float | None, out: Path, budget_s: float | None, workers: int
) -> tuple[list[dict[str, Any]], bool, SweepOutcome]:
    """The runs on `mission sweep`'s engine (a LocalCluster on loopback, one worker per core, a progress bar):
    (rows, cut short by the budget, the sweep's outcome). The sweep directory is made afresh — a benchmark
    measures, it never resumes — and every finished row is also copied to ``<out>/missions_runs.jsonl``."""
    plan = SweepPlan(scenarios, tuple(range(seeds)), max_duration=max_duration, pictures="failed")
    sweep_dir = out / SWEEP_DIR
    shutil.rmtree(sweep_dir, ignore_errors=True)
    outcome = run_sweep(plan, sweep_dir, workers=workers, progress=True, budget_s=budget_s)
    order = {r.run_id: i for i, r in enumerate(plan.runs())}
    rows = sorted(outcome.rows, key=lambda r: order.get(r["run_id"], len(order)))
    atomic_write_text(out / "missions_runs.jsonl", "".join(json.dumps(r, default=str) + "\n" for r in rows))
    return rows, outcome.cut_short or outcome.interrupted, outcome


def _total(runs: list[dict[str, Any]], key: str) -> float:
    return sum(float(r.get(key, 0)) for r in runs)


def _vals(runs: list[dict[str, Any]], path: tuple[str, ...]) -> list[float]:
    out = []
    for r in runs:
        v: Any = r.get("metrics", {})
        for p in path:
            v = v.get(p) if isinstance(v, dict) else None
        if isinstance(v, (int, float)):
            out.append(float(v))
    return out


def aggregate(name: str, runs: list[dict[str, Any]]) -> dict[str, Any]:
    """One scenario's figures over its runs (per-run stats pooled: medians of medians, max of maxima)."""
    n = len(runs)
    ok = sum(1 for r in runs if r.get("success"))
    losses = sum(_vals(runs, ("loss_events",)))
    recovered = sum(_vals(runs, ("loss_events_recovered",)))
    reasons: dict[str, int] = {}
    for r in runs:
        if not r.get("success"):
            key = str(r.get("reason", "?")).split(":")[0][:60]
            reasons[key] = reasons.get(key, 0) + 1
    docks = [r["metrics"]["dock"] for r in runs if isinstance(r.get("metrics", {}).get("dock"), dict)]
    return {
        "runs": n,
        "seeds": sorted(int(r["seed"]) for r in runs),
        "success_rate": round(ok / n, 3) if n else None,
        "loss_events": int(losses),
        "loss_events_recovered": int(recovered),
        "loss_recovered_fraction": round(recovered / losses, 3) if losses else None,
        "occlusion_latency_s_median": pct(_vals(runs, ("occlusion_detection_latency_s", "median")), 50),
        "occlusion_latency_s_max": max(_vals(runs, ("occlusion_detection_latency_s", "max")), default=None),
        "occlusions_detected": int(sum(_vals(runs, ("occlusions_detected",)))),
        "occlusions_over_0_5s": int(sum(_vals(runs, ("occlusions_over_0_5s",)))),
        "reacquisition_s_median": pct(_vals(runs, ("reacquisition_time_s", "median")), 50),
        "reacquisition_s_max": max(_vals(runs, ("reacquisition_time_s", "max")), default=None),
        "goal_jitter_m_median": pct(_vals(runs, ("goal_jitter_sd_m",)), 50, 4),
        "goal_jitter_m_max": max(_vals(runs, ("goal_jitter_sd_m",)), default=None),
        "docked_runs": len(docks),
        "dock_lateral_m_median": pct([d["lateral_m"] for d in docks], 50, 4),
        "dock_lateral_m_max": max((d["lateral_m"] for d in docks), default=None),
        "dock_distance_m_median": pct([d["distance_m"] for d in docks], 50, 4),
        "dock_distance_m_max": max((d["distance_m"] for d in docks), default=None),
        "dock_skew_deg_median": pct([d["skew_deg"] for d in docks], 50, 2),
        "dock_skew_deg_max": max((d["skew_deg"] for d in docks), default=None),
        "collisions": int(sum(_vals(runs, ("collisions",)))),
        "failure_reasons": reasons,
        "sim_s_per_wall_s": round(_total(runs, "sim_time_s") / max(1e-9, _total(runs, "wall_time_s")), 2),
    }


def _vs_target(label: str, value: float | None, unit: str, key: str, target: str) -> Figure:
    """A figure beside its design target; `target` reads "≥ x", "≤ x" or "< x" and decides the check."""
    goal = TARGETS[key]
    if value is None:
        meets = None
    elif target.startswith("≥"):
        meets = value >= goal
    elif target.startswith("<"):
        meets = value < goal
    else:
        meets = value <= goal
    return Figure(label, value, unit, baseline=DESIGN, baseline_value=goal, target=target, meets_target=meets)


def _figures(name: str, a: dict[str, Any]) -> list[Figure]:
    f = [
        _vs_target(f"{name}: success rate ({a['runs']} seeds)", a["success_rate"], "fraction", "success_rate", "≥ 0.90")
    ]
    if a["loss_events"]:
        f.append(
            _vs_target(
                f"{name}: loss events recovered ({a['loss_events_recovered']}/{a['loss_events']})",
                a["loss_recovered_fraction"],
                "fraction",
                "loss_recovered",
                "≥ 0.90",
            )
        )
    worst_runs = (
        ("occlusion_latency_s", "occlusion-detection latency", "s", "occlusion_latency_s", "≤ 0.5 s"),
        ("reacquisition_s", "re-acquisition time", "s", "reacquisition_s", "≤ 10 s"),
    )
    for field, what, unit, key, target in worst_runs:
        if a[f"{field}_max"] is not None:
            label = f"{name}: {what}, worst run (median of runs {a[f'{field}_median']} s)"
            f.append(_vs_target(label, a[f"{field}_max"], unit, key, target))
    if a["goal_jitter_m_max"] is not None:
        still = "goal jitter s.d. while the target stands still"
        label = f"{name}: {still}, worst run (median {a['goal_jitter_m_median']} m)"
        f.append(_vs_target(label, a["goal_jitter_m_max"], "m", "goal_jitter_m", "< 0.2 m"))
    if a["docked_runs"]:
        for key, unit, target in (
            ("lateral_m", "m", "≤ 0.03 m"),
            ("distance_m", "m", "≤ 0.025 m"),
            ("skew_deg", "°", "≤ 10°"),
        ):
            label = (
                f"{name}: docking {key.split('_')[0]} error, worst of {a['docked_runs']} docks "
                f"(median {a[f'dock_{key}_median']})"
            )
            f.append(_vs_target(label, a[f"dock_{key}_max"], unit, f"dock_{key}", target))
    return f


def run(quick: bool, out: Path) -> dict[str, Any]:
    scen_env = os.environ.get("MISSION_BENCH_SCENARIOS")
    scenarios = tuple(s.strip() for s in scen_env.split(",")) if scen_env else (QUICK_SCENARIOS if quick else SCENARIOS)
    seeds = int(os.environ.get("MISSION_BENCH_SEEDS", "1" if quick else "20"))
    budget = float(os.environ["MISSION_BENCH_BUDGET_S"]) if os.environ.get("MISSION_BENCH_BUDGET_S") else None
    max_duration = QUICK_MAX_DURATION_S if quick else None
    workers = max(1, min(os.cpu_count() or 1, seeds * len(scenarios)))
    progress(
        f"missions: {seeds * len(scenarios)} runs ({seeds} seeds × {len(scenarios)} scenarios) on "
        f"`mission sweep` with {workers} worker processes"
    )
    t0 = time.perf_counter()
    results, cut, outcome = sweep(scenarios, seeds, max_duration, out, budget, workers)
    wall = time.perf_counter() - t0
    per: dict[str, Any] = {}
    figures: list[Figure] = []
    for s in scenarios:
        runs = [r for r in results if r["scenario"] == s]
        if not runs:
            continue
        per[s] = aggregate(s, runs)
        figures += _figures(s, per[s])
    plot = _plot(per, out) if per else None
    return {
        "title": "Mission outcomes over seeds per scenario vs the design targets"
        + (" (QUICK: runs cut at 12 s simulated — a smoke test, not outcome figures)" if quick else ""),
        "figures": [f.to_json() for f in figures],
        "details": {
            "scenarios": per,
            "seeds_requested": seeds,
            "runs_finished": len(results),
            "runs_requested": outcome.planned,
            "cut_short_by_budget": cut,
            "workers": outcome.workers,
            "wall_s": round(wall, 1),
            "max_duration_s": max_duration,
            "runs_log": "missions_runs.jsonl",
            "sweep_dir": SWEEP_DIR,
            "engine": "mission sweep (mission/sweep), Dask LocalCluster on 127.0.0.1",
        },
        "plots": [plot] if plot else [],
    }


def _plot(per: dict[str, Any], out: Path) -> str:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = list(per)
    fig, axes = plt.subplots(1, 2, figsize=(11, 4))
    x = np.arange(len(names))
    axes[0].bar(x - 0.2, [per[n]["success_rate"] or 0 for n in names], 0.4, label="success rate")
    axes[0].bar(x + 0.2, [per[n]["loss_recovered_fraction"] or 0 for n in names], 0.4, label="losses recovered")
    axes[0].axhline(0.9, color="grey", ls="--", lw=0.8, label="target 0.9")
    axes[0].set_xticks(x, [f"{n}\n({per[n]['runs']} runs)" for n in names], fontsize=8)
    axes[0].set_ylim(0, 1.05)
    axes[0].legend(fontsize=7)
    axes[0].set_title("Outcomes")
    axes[1].bar(x - 0.2, [per[n]["reacquisition_s_max"] or 0 for n in names], 0.4, label="re-acquisition, worst (s)")
    axes[1].bar(
        x + 0.2,
        [(per[n]["occlusion_latency_s_max"] or 0) * 10 for n in names],
        0.4,
        label="occlusion latency, worst (×0.1 s)",
    )
    axes[1].axhline(10, color="grey", ls="--", lw=0.8, label="targets (10 s; 0.5 s)")
    axes[1].set_xticks(x, names, fontsize=8)
    axes[1].legend(fontsize=7)
    axes[1].set_title("Loss handling")
    fig.tight_layout()
    name = "missions.png"
    save_figure(fig, out / name)
    return name
