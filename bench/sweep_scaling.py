"""Benchmark: `mission sweep` against `mission run` alone, and what a 1,000-seed regression would cost.

The same runs (scenarios × seeds, cut to a few simulated seconds) are measured four ways, in one
invocation so the machine's load is shared:

* ``mission run --report`` as a process per run (a shell loop: interpreter, imports and the run);
* the run alone in this process (``run_scenario`` + ``write_report``, warmed: the run's own cost);
* ``mission sweep`` on a LocalCluster with 1 worker and with 2 workers (cluster start, worker imports,
  report transfer, the table and the summary included — the wall clock a user waits).

Figures: the sweep's throughput on 2 workers against 1 (a ratio; 2.0 is perfect scaling), its per-run
wall time on 1 worker against the run alone (the engine's overhead) and against a loop of ``mission run``,
and a paper estimate of 1,000 seeds of the missions benchmark's four scenarios on a 32-core cluster,
from the per-run cost of full-length runs (the committed missions figures, else this run's simulation
speed) and the sweep's per-run CPU cost against the run alone (robust to a loaded machine), one worker
per core.
"""

from __future__ import annotations

import json
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from bench.common import Figure, load_average, progress, ratio
from bench.missions import SCENARIOS as REGRESSION_SCENARIOS
from mission.sweep.engine import run_sweep
from mission.sweep.plan import SweepPlan

FULL = {"scenarios": ("follow_occlusion", "explore_dock"), "seeds": (0, 1, 2), "max_duration": 10.0}
QUICK = {"scenarios": ("follow_open",), "seeds": (0, 1), "max_duration": 2.0}
REGRESSION_SEEDS = 1000
CLUSTER_CORES = 32
ROOT = Path(__file__).resolve().parents[1]


def _alone_in_process(plan: SweepPlan) -> dict[str, tuple[float, float]]:
    """run_id → wall and CPU seconds of the run as `mission run --report` runs it, in this process (warmed)."""
    import py_trees

    from mission.app.sim_run import run_scenario
    from mission.viz.run_report import report_observers, write_report

    run_scenario(plan.scenarios[0], seed=0, max_duration=0.5)  # imports and first-use costs out of the figure
    out = {}
    for spec in plan.runs():
        py_trees.blackboard.Blackboard.clear()
        with tempfile.TemporaryDirectory() as tmp:
            t0, c0 = time.perf_counter(), time.process_time()
            outcome, recorder, adapter = run_scenario(
                spec.scenario, seed=spec.seed, max_duration=spec.max_duration, observers=report_observers(tmp)
            )
            write_report(tmp, outcome, recorder, adapter)
            out[spec.run_id] = (time.perf_counter() - t0, time.process_time() - c0)
    return out


def _alone_as_processes(plan: SweepPlan) -> list[float]:
    """Wall seconds of `mission run --report` as one process per run (what a shell loop over seeds costs)."""
    walls = []
    for spec in plan.runs():
        with tempfile.TemporaryDirectory() as tmp:
            cmd = [
                sys.executable,
                "-m",
                "mission",
                "run",
                "--scenario",
                spec.scenario,
                "--seed",
                str(spec.seed),
                "--max-duration",
                str(spec.max_duration),
                "--report",
                tmp,
                "--quiet",
            ]
            t0 = time.perf_counter()
            subprocess.run(cmd, cwd=ROOT, capture_output=True, check=False, timeout=600)
            walls.append(time.perf_counter() - t0)
    return walls


def _swept(plan: SweepPlan, workers: int) -> dict[str, Any]:
    """The plan as `mission sweep --workers N` runs it, into a scratch directory (the figures are the point)."""
    with tempfile.TemporaryDirectory(prefix=f"sweep-scaling-{workers}w-") as folder:
        t0 = time.perf_counter()
        outcome = run_sweep(plan, folder, workers=workers, progress=False)
        wall = time.perf_counter() - t0
    n = len(outcome.rows)
    tasks = [float(r.get("task_s") or 0) for r in outcome.rows]
    cpus = [float(r.get("task_cpu_s") or 0) for r in outcome.rows]
    by_run = {r["run_id"]: (float(r.get("task_s") or 0), float(r.get("task_cpu_s") or 0)) for r in outcome.rows}
    return {
        "workers": outcome.workers,
        "runs": n,
        "wall_s": round(wall, 2),
        "runs_per_min": round(60 * n / wall, 3) if wall else None,
        "per_run_wall_s": round(wall / n, 3) if n else None,
        "task_s_mean": round(statistics.mean(tasks), 3) if tasks else None,
        "task_cpu_s_mean": round(statistics.mean(cpus), 3) if cpus else None,
        # what is not a run: cluster start, worker imports, transfer, recording, table and summary
        "fixed_s": round(wall - sum(tasks) / max(1, outcome.workers), 2),
        "unfinished": len(outcome.unfinished),
        "by_run": by_run,
    }


def _full_run_cost_s(sim_speed: float) -> tuple[float, str]:
    """Core-seconds of one full-length run of the regression's scenarios, on average, and where it came from."""
    committed = ROOT / "bench" / "results" / "missions_runs.jsonl"
    if committed.is_file():
        rows = [json.loads(line) for line in committed.read_text().splitlines() if line.strip()]
        per = [
            statistics.mean(float(r["wall_time_s"]) for r in rows if r["scenario"] == s)
            for s in REGRESSION_SCENARIOS
            if any(r["scenario"] == s for r in rows)
        ]
        if per:
            return statistics.mean(per), "mean wall time of a full run per scenario (bench/results/missions_runs.jsonl)"
    from mission.sim.scenario import load_scenario

    durations = [load_scenario(s).duration_s for s in REGRESSION_SCENARIOS]
    return statistics.mean(durations) / sim_speed, "scenario durations ÷ the simulation speed measured here"


def run(quick: bool, out: Path) -> dict[str, Any]:
    setup = QUICK if quick else FULL
    plan = SweepPlan(setup["scenarios"], setup["seeds"], max_duration=setup["max_duration"], pictures="all")
    n = len(plan.runs())
    progress(f"sweep: {n} runs of {setup['max_duration']:g} s, alone and as processes, then swept on 1 and 2 workers")
    load_before = load_average()
    alone_by_run = _alone_in_process(plan)
    processes = _alone_as_processes(plan)
    one = _swept(plan, 1)
    two = _swept(plan, 2)
    alone = [w for w, _ in alone_by_run.values()]
    alone_s, process_s = statistics.mean(alone), statistics.mean(processes)
    alone_cpu_s = statistics.mean(c for _, c in alone_by_run.values())
    scaling = ratio(two["runs_per_min"], one["runs_per_min"])
    overhead = ratio(one["per_run_wall_s"], alone_s)
    # The estimate. A run's CPU seconds in a worker against the same run alone is the engine's per-run cost
    # whatever the machine's load (wall-clock ratios on a shared 2-core machine are the neighbours' as much
    # as ours); the median over runs leaves out a worker's first run, which pays its imports (fixed cost).
    # A cluster's workers each have a core, so the runs scale with the cores; the fixed cost (cluster start,
    # worker imports, the table and summary) is paid once.
    paired = [one["by_run"][k][1] / c for k, (_, c) in alone_by_run.items() if k in one["by_run"] and c > 0]
    per_run = round(statistics.median(paired), 3) if paired else 1.0
    efficiency_here = min(1.0, ratio(one["task_s_mean"], two["task_s_mean"]) or 1.0)
    full_run_s, source = _full_run_cost_s(setup["max_duration"] / alone_s)
    runs = REGRESSION_SEEDS * len(REGRESSION_SCENARIOS)
    core_s = runs * full_run_s * per_run
    cluster_h = (core_s / CLUSTER_CORES + one["fixed_s"]) / 3600
    here_h = (core_s / 2 + one["fixed_s"]) / 3600
    figures = [
        Figure(
            "sweep throughput, 2 workers vs 1 (runs per minute)",
            two["runs_per_min"],
            "runs/min",
            baseline="the same sweep on 1 worker, this run",
            baseline_value=one["runs_per_min"],
            ratio=scaling,
            target="2.0 = perfect scaling on 2 idle cores",
        ),
        Figure(
            "sweep per-run wall time on 1 worker vs the run alone (run_scenario + report, in-process)",
            one["per_run_wall_s"],
            "s",
            baseline="the same runs alone in this process, warmed",
            baseline_value=round(alone_s, 3),
            ratio=overhead,
        ),
        Figure(
            "sweep per-run wall time on 1 worker vs `mission run --report` processes in a loop",
            one["per_run_wall_s"],
            "s",
            baseline="one `mission run --report` process per run",
            baseline_value=round(process_s, 3),
            ratio=ratio(one["per_run_wall_s"], process_s),
        ),
        Figure(
            "sweep CPU seconds per run on 1 worker vs the run alone (load-independent; ratio: median of "
            "the runs' own ratios)",
            one["task_cpu_s_mean"],
            "s",
            baseline="the same runs alone in this process, warmed",
            baseline_value=round(alone_cpu_s, 3),
            ratio=per_run,
        ),
        Figure(
            f"paper estimate: {REGRESSION_SEEDS} seeds × {len(REGRESSION_SCENARIOS)} scenarios on a "
            f"{CLUSTER_CORES}-core cluster",
            round(cluster_h, 2),
            "h",
            baseline="the same regression on this machine's 2 cores, idle",
            baseline_value=round(here_h, 1),
            ratio=ratio(cluster_h, here_h),
        ),
    ]
    return {
        "title": "mission sweep: throughput on 1 and 2 workers, per-run overhead, a 1,000-seed estimate"
        + (" (QUICK: 2 runs of 2 s — a smoke test)" if quick else ""),
        "figures": [f.to_json() for f in figures],
        "details": {
            "runs": {
                "scenarios": list(setup["scenarios"]),
                "seeds": list(setup["seeds"]),
                "max_duration_s": setup["max_duration"],
                "count": n,
            },
            "alone_in_process_s": [round(w, 3) for w in alone],
            "alone_in_process_cpu_s": [round(c, 3) for _, c in alone_by_run.values()],
            "alone_as_processes_s": [round(w, 3) for w in processes],
            "sweep_1_worker": {k: v for k, v in one.items() if k != "by_run"},
            "sweep_2_workers": {k: v for k, v in two.items() if k != "by_run"},
            "cpu_ratio_by_run": [round(r, 3) for r in paired],
            "estimate": {
                "runs": runs,
                "full_run_core_s": round(full_run_s, 1),
                "full_run_source": source,
                "per_run_cpu_vs_alone": round(per_run, 3),
                "fixed_s": one["fixed_s"],
                "parallel_efficiency_here": round(efficiency_here, 3),
                "cluster_hours_at_this_machines_efficiency": round(
                    (core_s / (CLUSTER_CORES * efficiency_here) + one["fixed_s"]) / 3600, 2
                ),
                "core_hours": round(core_s / 3600, 1),
                "cluster_cores": CLUSTER_CORES,
                "cluster_hours": round(cluster_h, 2),
                "method": "core_s = runs × full_run_core_s × per_run_cpu_vs_alone; hours = (core_s / cores "
                "+ fixed_s) / 3600 (one worker per core, each run on its own core)",
            },
            "load_average_1min": {"before": load_before, "after": load_average()},
        },
        "plots": [],
    }
