"""Benchmark: the mission over ROS 2 (sim-robot + the installed node, two processes, sim time) against the
same mission in process (`mission run`), on the same scenarios and seeds, scored by the same code.

Each (scenario, seed) runs twice, one after the other so both see the same machine:

* **in process** — ``run_scenario`` (what `mission run` does): the tree ticks in lockstep with the simulation,
  perception inside the step, no transport;
* **over ROS** — ``mission sim-robot`` (paced to the wall clock, ``--rate 1``) and
  ``install/mission/lib/mission/tree`` with ``use_sim_time``, over the shared-memory profile on a private
  domain: images, odometry, TF and /clock cross DDS, perception runs on image arrival, the tree ticks on its
  own timer, goals go through ``navigate_to_pose``.

Figures: success rate, re-acquisition time, dock errors side by side (ratio ROS / in process) and the wall
time per simulated second. Every run's outcome goes to ``<out>/ros_missions_runs.jsonl`` as it finishes.

Knobs (environment): ``MISSION_ROS_BENCH_SEEDS`` (default 10; --quick 1), ``MISSION_ROS_BENCH_SCENARIOS``
(default mission_full,follow_occlusion,explore_dock), ``MISSION_ROS_BENCH_BUDGET_S`` (stop starting pairs
after this many wall seconds), ``MISSION_ROS_BENCH_RESUME=1`` (keep the runs an earlier bench finished in
``<out>/ros_missions_runs.jsonl`` and run only the others).

    mission bench --only ros_missions          # long: about 3 wall minutes per ROS run on 2 busy cores
"""

from __future__ import annotations

import json
import os
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

from bench.common import Figure, progress, ratio
from bench.ros_feed import ROOT, TREE_EXE, Subprocess, build_ros, ros_env

CONFIG = ROOT / "mission" / "configs" / "sim_aruco.yaml"
DEFAULT_SCENARIOS = ("mission_full", "follow_occlusion", "explore_dock")


def _in_process(scenario: str, seed: int) -> dict[str, Any]:
    from mission.app.sim_run import run_scenario

    outcome, _, _ = run_scenario(scenario, config_file=CONFIG, seed=seed)
    return _row("in_process", outcome.to_json())


def _over_ros(scenario: str, seed: int, tree: str, env: dict[str, str], work: Path) -> dict[str, Any]:
    report = work / f"{scenario}_{seed}"
    node_cmd = [str(TREE_EXE), "--config", str(CONFIG), "--tree", tree, "--ros-args", "-p", "use_sim_time:=true"]
    robot_cmd = [
        sys.executable,
        "-m",
        "mission",
        "sim-robot",
        "--scenario",
        scenario,
        "--seed",
        str(seed),
        "--config",
        str(CONFIG),
        "--report",
        str(report),
    ]
    node = Subprocess(node_cmd, env, work / f"{scenario}_{seed}_node.log")
    robot = Subprocess(robot_cmd, {**os.environ, **ros_env_overrides(env)}, work / f"{scenario}_{seed}_robot.log")
    try:
        robot.proc.wait(timeout=1800)
    finally:
        robot.stop()
        node.stop()
    path = report / "report.json"
    if not path.is_file():
        return {"world": "ros", "success": False, "reason": f"no report (sim-robot log: {robot.log_tail()})"}
    return _row("ros", json.loads(path.read_text()))


def _finished_rows(path: Path) -> list[dict[str, Any]]:
    """The runs an earlier, interrupted bench finished (MISSION_ROS_BENCH_RESUME=1): a pair takes minutes,
    so a long bench is run in parts; a torn last line is dropped."""
    rows = []
    for line in path.read_text().splitlines() if path.is_file() else []:
        try:
            rows.append(json.loads(line))
        except json.JSONDecodeError:
            continue
    return rows


def ros_env_overrides(env: dict[str, str]) -> dict[str, str]:
    keys = ("FASTRTPS_DEFAULT_PROFILES_FILE", "RMW_IMPLEMENTATION", "ROS_DOMAIN_ID", "ROS_AUTOMATIC_DISCOVERY_RANGE")
    return {k: env[k] for k in keys if k in env}


def _row(world: str, o: dict[str, Any]) -> dict[str, Any]:
    m = o.get("metrics", {})
    reacq = (m.get("reacquisition_time_s") or {}).get("max")
    dock = m.get("dock") or {}
    return {
        "world": world,
        "success": bool(o.get("success")),
        "reason": o.get("reason", ""),
        "sim_time_s": o.get("sim_time_s"),
        "wall_time_s": o.get("wall_time_s"),
        "reacquisition_max_s": reacq,
        "loss_events": m.get("loss_events"),
        "loss_recovered": m.get("loss_events_recovered"),
        "dock_lateral_m": dock.get("lateral_m"),
        "dock_distance_m": dock.get("distance_m"),
        "dock_skew_deg": dock.get("skew_deg"),
        "collisions": m.get("collisions"),
    }


def _median(rows: list[dict[str, Any]], key: str) -> float | None:
    vals = [r[key] for r in rows if r.get(key) is not None]
    return round(float(np.median(vals)), 4) if vals else None


def run(quick: bool, out: Path) -> dict[str, Any]:
    from mission.sim.scenario import load_scenario

    scenarios = [s for s in os.environ.get("MISSION_ROS_BENCH_SCENARIOS", ",".join(DEFAULT_SCENARIOS)).split(",") if s]
    seeds = int(os.environ.get("MISSION_ROS_BENCH_SEEDS", "1" if quick else "10"))
    budget = float(os.environ.get("MISSION_ROS_BENCH_BUDGET_S", "inf"))
    build_ros()
    env = ros_env()
    out.mkdir(parents=True, exist_ok=True)
    runs_path = out / "ros_missions_runs.jsonl"
    rows = _finished_rows(runs_path) if os.environ.get("MISSION_ROS_BENCH_RESUME") == "1" else []
    runs_path.write_text("".join(json.dumps(r) + "\n" for r in rows))
    done = {(r["scenario"], r["seed"], r["world"]) for r in rows}
    work = Path(tempfile.mkdtemp(prefix="ros_missions_"))
    t0 = time.monotonic()
    for seed in range(seeds):
        for scenario in scenarios:
            if time.monotonic() - t0 > budget:
                break
            tree = load_scenario(scenario).tree
            for world in ("in_process", "ros"):
                if (scenario, seed, world) in done:
                    continue
                row = _over_ros(scenario, seed, tree, env, work) if world == "ros" else _in_process(scenario, seed)
                row.update(scenario=scenario, seed=seed)
                rows.append(row)
                with runs_path.open("a") as f:
                    f.write(json.dumps(row) + "\n")
                progress(
                    f"ros_missions: {scenario} seed {seed} {row['world']}: "
                    f"{'ok' if row['success'] else 'FAILED'} ({row['reason']})"
                )
    figs = []
    for scenario in scenarios:
        a = [r for r in rows if r["scenario"] == scenario and r["world"] == "ros"]
        b = [r for r in rows if r["scenario"] == scenario and r["world"] == "in_process"]
        if not a:
            continue
        sa, sb = sum(r["success"] for r in a) / len(a), sum(r["success"] for r in b) / max(1, len(b))
        figs.append(
            Figure(
                f"{scenario}: success rate over ROS ({len(a)} seeds)",
                round(sa, 3),
                "fraction",
                baseline="in-process mission run, same seeds",
                baseline_value=round(sb, 3),
                ratio=ratio(sa, sb),
            ).to_json()
        )
        for key, label, unit in (
            ("reacquisition_max_s", "re-acquisition (worst per run), median", "s"),
            ("dock_lateral_m", "dock lateral error, median", "m"),
            ("dock_distance_m", "dock distance error, median", "m"),
            ("dock_skew_deg", "dock skew, median", "°"),
        ):
            va, vb = _median(a, key), _median(b, key)
            if va is not None or vb is not None:
                figs.append(
                    Figure(
                        f"{scenario}: {label} over ROS",
                        va,
                        unit,
                        baseline="in process, same seeds",
                        baseline_value=vb,
                        ratio=ratio(va, vb),
                    ).to_json()
                )
        wa = [r["wall_time_s"] / r["sim_time_s"] for r in a if r.get("sim_time_s")]
        wb = [r["wall_time_s"] / r["sim_time_s"] for r in b if r.get("sim_time_s")]
        if wa and wb:
            figs.append(
                Figure(
                    f"{scenario}: wall s per simulated s over ROS",
                    round(float(np.median(wa)), 3),
                    "s/s",
                    baseline="in process (not paced)",
                    baseline_value=round(float(np.median(wb)), 3),
                    ratio=ratio(float(np.median(wa)), float(np.median(wb))),
                ).to_json()
            )
    return {
        "title": "The mission over ROS 2 (sim-robot + installed node) vs in process, same seeds",
        "figures": figs,
        "details": {
            "scenarios": scenarios,
            "seeds": seeds,
            "runs": len(rows),
            "wall_s": round(time.monotonic() - t0),
            "failures": [r for r in rows if not r["success"]],
            "runs_file": runs_path.name,
        },
        "plots": [],
    }
