"""Benchmark: Nav2's docking and following actions served by our trees, against the same trees in process.

For each seed, two tasks, each run twice, one after the other so both see the same machine:

* **dock** — explore_dock, a DockRobot goal for ``home_dock`` of mission/ros/params/explore_dock.yaml (a Nav2
  user's docking_server section): stage, first sight, visual servoing. Scored against ground truth: success,
  the camera's lateral and distance error from the tag's 0.30 m standoff, its skew, the time the goal took.
* **follow** — follow_occlusion with an ``external_detector`` (a person tracker's stand-in: line of sight,
  3 cm noise, 5 % dropouts) and a FollowObject goal on its pose topic for 40 s: success, losses and their
  re-acquisition, from the same ground truth.

The two worlds:

* **through the actions** — ``mission sim-robot --serve`` (paced to the wall clock), the installed node in
  server mode (``--tree none --params-file``), and a client written from the .action files only
  (bench/nav2_task_client.py), three processes over shared-memory DDS; dock figures come from the result and
  ``/sim/ground_truth`` at that moment, follow figures from the sim-robot's report (the node's
  ``/mission/status`` states, scored as ``mission run`` scores them);
* **in process** — ``run_scenario`` with a goal tree that writes the inputs the server would (from the same
  params file, through mission/ros/nav2_tasks.py) and includes the same shipped tree.

A follow goal over the actions starts a few seconds into the sim-robot's run (DDS discovery), so it covers a
slightly later part of the target's path than the in-process run; the dock goal starts from the same pose.

Every run's row goes to ``<out>/nav2_actions_runs.jsonl`` as it finishes. Knobs (environment):
``MISSION_NAV2_BENCH_SEEDS`` (default 20; --quick 1), ``MISSION_NAV2_BENCH_TASKS`` (default dock,follow),
``MISSION_NAV2_BENCH_RESUME=1`` (keep finished rows and run the others).

    mission bench --only nav2_actions          # about 30 wall minutes for 20 seeds on 2 cores
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import textwrap
import time
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from bench.common import Figure, progress, ratio
from bench.ros_feed import ROOT, TREE_EXE, Subprocess, build_ros, ros_env
from bench.ros_missions import _finished_rows, _median, ros_env_overrides

CONFIG = ROOT / "mission" / "configs" / "sim_aruco.yaml"
PARAMS = ROOT / "mission" / "ros" / "params" / "explore_dock.yaml"
CLIENT = ROOT / "bench" / "nav2_task_client.py"
FOLLOW_S = 40.0
DETECTOR = {"topic": "/target_pose", "frame": "target"}  # the scenario key's defaults otherwise


def _tracked_scenario(work: Path) -> Path:
    data = yaml.safe_load((ROOT / "sim" / "scenarios" / "follow_occlusion.yaml").read_text())
    data["external_detector"] = DETECTOR
    path = work / "follow_occlusion_tracked.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def _external_config(work: Path) -> Path:
    """The sim config plus what server mode adds for a follow goal: the external_pose source as `target`."""
    data = yaml.safe_load(CONFIG.read_text())
    data["perception"]["sources"].append({"plugin": "external_pose"})
    data["perception"]["targets"]["target"] = {"source": "external_pose"}
    path = work / "external.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def _literal(value: Any) -> str:
    if hasattr(value, "yaw"):
        return f"'{value.x!r};{value.y!r};{value.yaw!r}'"
    if isinstance(value, bool):
        return "true" if value else "false"
    return repr(value)


def _goal_tree(work: Path, name: str, include: str, inputs: dict[str, Any], after: str = "") -> Path:
    """A tree that writes a goal's inputs as the server does, then runs the shipped tree `include`."""
    code = "; ".join(f"{k} := {_literal(v)}" for k, v in inputs.items())
    main = Path(include).stem.title().replace("_", "")
    path = work / f"{name}.xml"
    path.write_text(
        textwrap.dedent(f"""\
        <root BTCPP_format="4" main_tree_to_execute="Goal">
          <include path="{include}"/>
          <BehaviorTree ID="Goal">
            <Sequence>
              <Script code="{code}"/>
              <SubTree ID="{main}" _autoremap="true"/>
              {after}
            </Sequence>
          </BehaviorTree>
        </root>
    """)
    )
    return path


# --- in process -----------------------------------------------------------------------------------------


def _dock_in_process(seed: int, work: Path) -> dict[str, Any]:
    from mission.app.sim_run import run_scenario
    from mission.ros import nav2_tasks as tasks
    from mission.ros.nav2_params import docking_params, read_params_file

    params = docking_params(read_params_file(PARAMS, "docking_server"))
    plan = tasks.plan_dock(tasks.DockGoal(dock_id="home_dock"), params, None)
    tree = _goal_tree(work, "dock_goal", "dock_robot.xml", dict(plan.inputs), '<SetMissionState state="DONE"/>')
    outcome, _, _ = run_scenario("explore_dock", config_file=CONFIG, tree=str(tree), seed=seed, max_duration=120.0)
    o = outcome.to_json()
    dock = o["metrics"].get("dock") or {}
    return {
        "success": bool(o["success"]),
        "reason": o["reason"],
        "task_s": o["sim_time_s"],
        "dock_lateral_m": dock.get("lateral_m"),
        "dock_distance_m": dock.get("distance_m"),
        "dock_skew_deg": dock.get("skew_deg"),
    }


def _follow_in_process(seed: int, work: Path) -> dict[str, Any]:
    from mission.app.sim_run import run_scenario

    tree = _goal_tree(work, "follow_goal", "follow_object.xml", {"detection_timeout": 2.0, "desired_distance": 1.0})
    outcome, _, _ = run_scenario(
        str(_tracked_scenario(work)),
        config_file=str(_external_config(work)),
        tree=str(tree),
        seed=seed,
        max_duration=FOLLOW_S,
    )
    return _follow_row(outcome.to_json())


def _follow_row(o: dict[str, Any]) -> dict[str, Any]:
    m = o.get("metrics", {})
    reacq = (m.get("reacquisition_time_s") or {}).get("max")
    return {
        "success": bool(o.get("success")),  # `mission run`'s follow criteria (tracking, occlusion latency, …)
        "reason": o.get("reason", ""),
        "loss_events": m.get("loss_events"),
        "loss_recovered": m.get("loss_events_recovered"),
        "reacquisition_max_s": reacq,
        "tracking_fraction": m.get("tracking_fraction"),
    }


# --- through the actions --------------------------------------------------------------------------------


def _served(scenario: str, seed: int, duration: float, env: dict[str, str], work: Path, tag: str):
    report = work / f"{tag}_{seed}"
    node = Subprocess(
        [
            str(TREE_EXE),
            "--config",
            str(CONFIG),
            "--tree",
            "none",
            "--params-file",
            str(PARAMS),
            "--ros-args",
            "-p",
            "use_sim_time:=true",
        ],
        env,
        work / f"{tag}_{seed}_node.log",
    )
    robot = Subprocess(
        [
            sys.executable,
            "-m",
            "mission",
            "sim-robot",
            "--scenario",
            scenario,
            "--seed",
            str(seed),
            "--serve",
            "--config",
            str(CONFIG),
            "--max-duration",
            str(duration),
            "--report",
            str(report),
        ],
        {**os.environ, **ros_env_overrides(env)},
        work / f"{tag}_{seed}_robot.log",
    )
    return node, robot, report


def _client(env: dict[str, str], plan: list[dict], timeout: float) -> list[dict]:
    proc = subprocess.run(
        [sys.executable, str(CLIENT), json.dumps(plan), str(timeout)],
        env=env,
        capture_output=True,
        text=True,
        timeout=timeout + 90,
        check=False,
    )
    return [json.loads(line) for line in proc.stdout.splitlines() if line.startswith("{")]


def _dock_actions(seed: int, env: dict[str, str], work: Path) -> dict[str, Any]:
    node, robot, _ = _served("explore_dock", seed, 150.0, env, work, "dock")
    try:
        t0 = time.monotonic()
        events = _client(env, [{"dock": {"id": "home_dock"}}], 140.0)
    finally:
        robot.stop()
        node.stop()
    results = [e for e in events if e["event"] == "result"]
    if not results:
        return {"success": False, "reason": f"no result (client events: {events[-3:]}; node: {node.log_tail()})"}
    r = results[0]
    accepted_t = next((e.get("t") for e in events if e["event"] == "feedback" and e.get("t") is not None), None)
    dock = (r.get("truth") or {}).get("dock") or {}
    task_s = None
    if accepted_t is not None and r.get("truth", {}).get("t") is not None:
        task_s = round(r["truth"]["t"] - accepted_t, 3)
    return {
        "success": r["status"] == "SUCCEEDED",
        "reason": r["error_msg"] or r["status"],
        "error_code": r["error_code"],
        "num_retries": r["num_retries"],
        "task_s": task_s,
        "wall_s": round(time.monotonic() - t0, 1),
        "dock_lateral_m": dock.get("lateral_m"),
        "dock_distance_m": dock.get("distance_m"),
        "dock_skew_deg": dock.get("skew_deg"),
    }


def _follow_actions(seed: int, env: dict[str, str], work: Path) -> dict[str, Any]:
    scenario = str(_tracked_scenario(work))
    node, robot, report = _served(scenario, seed, FOLLOW_S + 15.0, env, work, "follow")
    try:
        events = _client(env, [{"follow": {"topic": DETECTOR["topic"], "max_duration": FOLLOW_S}}], FOLLOW_S + 60)
        robot.proc.wait(timeout=120)
    finally:
        robot.stop()
        node.stop()
    results = [e for e in events if e["event"] == "result"]
    path = report / "report.json"
    if not results or not path.is_file():
        return {"success": False, "reason": f"no result or report (sim-robot log: {robot.log_tail()})"}
    row = _follow_row(json.loads(path.read_text()))
    r = results[0]
    row.update(
        goal_succeeded=r["status"] == "SUCCEEDED",  # the action's own verdict; `success` is the mission criteria
        reason=r["error_msg"] or row["reason"],
        error_code=r["error_code"],
        num_retries=r["num_retries"],
    )
    return row


# --- the bench ------------------------------------------------------------------------------------------


def _p95(rows: list[dict[str, Any]], key: str) -> float | None:
    vals = [r[key] for r in rows if r.get(key) is not None]
    return round(float(np.percentile(vals, 95)), 4) if vals else None


def run(quick: bool, out: Path) -> dict[str, Any]:
    seeds = int(os.environ.get("MISSION_NAV2_BENCH_SEEDS", "1" if quick else "20"))
    tasks = [t for t in os.environ.get("MISSION_NAV2_BENCH_TASKS", "dock,follow").split(",") if t]
    build_ros()
    env = ros_env()
    out.mkdir(parents=True, exist_ok=True)
    runs_path = out / "nav2_actions_runs.jsonl"
    rows = _finished_rows(runs_path) if os.environ.get("MISSION_NAV2_BENCH_RESUME") == "1" else []
    runs_path.write_text("".join(json.dumps(r) + "\n" for r in rows))
    done = {(r["task"], r["seed"], r["world"]) for r in rows}
    work = Path(tempfile.mkdtemp(prefix="nav2_actions_"))
    runners = {
        ("dock", "in_process"): lambda s: _dock_in_process(s, work),
        ("dock", "actions"): lambda s: _dock_actions(s, env, work),
        ("follow", "in_process"): lambda s: _follow_in_process(s, work),
        ("follow", "actions"): lambda s: _follow_actions(s, env, work),
    }
    for seed in range(seeds):
        for task in tasks:
            for world in ("in_process", "actions"):
                if (task, seed, world) in done:
                    continue
                row = {"task": task, "seed": seed, "world": world, **runners[(task, world)](seed)}
                rows.append(row)
                with runs_path.open("a") as f:
                    f.write(json.dumps(row) + "\n")
                progress(
                    f"nav2_actions: {task} seed {seed} {world}: {'ok' if row['success'] else 'FAILED'} "
                    f"({row['reason']})"
                )
    figs = []
    for task in tasks:
        a = [r for r in rows if r["task"] == task and r["world"] == "actions"]
        b = [r for r in rows if r["task"] == task and r["world"] == "in_process"]
        if not a:
            continue
        sa, sb = sum(r["success"] for r in a) / len(a), sum(r["success"] for r in b) / max(1, len(b))
        figs.append(
            Figure(
                f"{task}: success through the actions ({len(a)} seeds)",
                round(sa, 3),
                "fraction",
                baseline="the same tree in process, same seeds",
                baseline_value=round(sb, 3),
                ratio=ratio(sa, sb),
            ).to_json()
        )
        keys = (
            [
                ("dock_lateral_m", "lateral error", "m"),
                ("dock_distance_m", "distance error", "m"),
                ("dock_skew_deg", "skew", "°"),
                ("task_s", "time to dock", "s"),
            ]
            if task == "dock"
            else [
                ("reacquisition_max_s", "re-acquisition (worst per run)", "s"),
                ("tracking_fraction", "tracking fraction", "fraction"),
            ]
        )
        for key, label, unit in keys:
            for stat, fn in (("median", _median), ("p95", _p95)):
                va, vb = fn(a, key), fn(b, key)
                if va is None and vb is None:
                    continue
                figs.append(
                    Figure(
                        f"{task}: {label}, {stat}, through the actions",
                        va,
                        unit,
                        baseline="in process, same seeds",
                        baseline_value=vb,
                        ratio=ratio(va, vb),
                    ).to_json()
                )
        if task == "follow":
            goals = sum(bool(r.get("goal_succeeded")) for r in a)
            figs.append(
                Figure(
                    "follow: FollowObject goals SUCCEEDED (max_duration reached)",
                    f"{goals}/{len(a)}",
                    "",
                    baseline="the action's own result",
                ).to_json()
            )
            lost = sum(r.get("loss_events") or 0 for r in a)
            back = sum(r.get("loss_recovered") or 0 for r in a)
            lost_b = sum(r.get("loss_events") or 0 for r in b)
            back_b = sum(r.get("loss_recovered") or 0 for r in b)
            figs.append(
                Figure(
                    "follow: losses recovered through the actions",
                    f"{back}/{lost}",
                    "",
                    baseline="in process",
                    baseline_value=f"{back_b}/{lost_b}",
                ).to_json()
            )
    return {
        "figures": figs,
        "config": {"seeds": seeds, "tasks": tasks, "follow_s": FOLLOW_S, "params": str(PARAMS.relative_to(ROOT))},
        "failed": [r for r in rows if not r["success"]],
    }
