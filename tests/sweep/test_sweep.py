"""`mission sweep` on a real Dask cluster on loopback: what a user running a regression relies on.

Every run is a real simulation (cut to a few simulated seconds so the suite stays lean) in a real
worker process; workers are killed with SIGKILL and the driver is interrupted with SIGINT, as an
operator or the kernel's OOM killer would. Nothing here asserts a speed.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any

import psutil
import pytest

from mission import cli
from mission.sweep.engine import connect, run_sweep
from mission.sweep.plan import SweepPlan
from mission.sweep.table import read_jsonl, read_parquet

ROOT = Path(__file__).resolve().parents[2]
SHORT_S = 2.0  # simulated seconds per run: enough for follow_open to follow and explore_dock not to dock
DETERMINISTIC = (
    "success",
    "reason",
    "tree_status",
    "final_state",
    "sim_time_s",
    "ticks",
    "metrics",
    "perception_stats",
    "faults",
    "interrupted",
)


@pytest.fixture(scope="module")
def cluster() -> Any:
    """An existing Dask cluster, as `--scheduler tcp://…` finds one: two worker processes on 127.0.0.1."""
    from distributed import LocalCluster

    c = LocalCluster(
        n_workers=2,
        threads_per_worker=1,
        processes=True,
        host="127.0.0.1",
        dashboard_address="127.0.0.1:0",
        silence_logs=40,
    )
    yield c
    c.close()


def _listening(pids: list[int]) -> list[tuple[int, str, int]]:
    out = []
    for pid in pids:
        proc = psutil.Process(pid)
        conns = proc.net_connections(kind="inet") if hasattr(proc, "net_connections") else proc.connections("inet")
        out += [(pid, c.laddr.ip, c.laddr.port) for c in conns if c.status == psutil.CONN_LISTEN]
    return out


def test_the_local_cluster_listens_on_loopback_only():
    with connect(workers=1) as client:
        workers = list(client.run(os.getpid).values())
        here = psutil.Process()
        pids = [here.pid, *(p.pid for p in here.children(recursive=True))]
        sockets = _listening(pids)
        assert set(workers) <= set(pids)
        assert {pid for pid, _, _ in sockets} >= set(workers), "every worker process serves on a socket"
        assert sockets and all(ip == "127.0.0.1" for _, ip, _ in sockets), sockets


def test_a_sweeps_runs_equal_mission_run_with_the_same_seeds_and_settings(cluster, tmp_path, capsys):
    sets = ["run.tick_hz=12", "FollowTarget.offset_m=0.6"]
    plan = SweepPlan.from_args("follow_open,explore_dock", "3-4", sets, max_duration=SHORT_S)
    outcome = run_sweep(plan, tmp_path / "sweep", scheduler=cluster.scheduler_address, progress=False)
    assert outcome.recorded == 4 and not outcome.unfinished and not outcome.interrupted
    rows = {r["run_id"]: r for r in read_parquet(tmp_path / "sweep" / "results.parquet")}
    assert len(rows) == 4
    assert {r["success"] for r in rows.values()} == {True, False}  # follow_open follows; explore_dock never docks
    for run in plan.runs():
        folder = tmp_path / "sweep" / "runs" / run.run_id
        swept = json.loads((folder / "report.json").read_text())
        report = tmp_path / f"run-{run.scenario}-{run.seed}"
        args = [
            "run",
            "--scenario",
            run.scenario,
            "--seed",
            str(run.seed),
            "--max-duration",
            str(SHORT_S),
            "--report",
            str(report),
            "--quiet",
        ] + [a for s in sets for a in ("--set", s)]
        assert cli.main(args) == (0 if swept["success"] else 1)
        alone = json.loads((report / "report.json").read_text())
        assert {k: swept[k] for k in DETERMINISTIC} == {k: alone[k] for k in DETERMINISTIC}, run.run_id
        assert swept["provenance"]["set"] == {"run.tick_hz": 12, "FollowTarget.offset_m": 0.6}
        assert rows[run.run_id]["success"] == swept["success"]
        # what `mission run --report` writes, the sweep keeps for the run
        assert {p.name for p in folder.iterdir()} >= {
            "report.json",
            "trajectories.png",
            "timeline.png",
            "report.html",
            "trees",
        }
        assert rows[run.run_id]["command"].startswith(f"mission run --scenario {run.scenario} --seed {run.seed}")
    capsys.readouterr()
    summary = (tmp_path / "sweep" / "summary.html").read_text()
    for run in plan.runs():
        if not rows[run.run_id]["success"]:  # every failing run is linked to its pictures
            assert f"runs/{run.run_id}/trajectories.png" in summary
            assert f"runs/{run.run_id}/report.html" in summary
    assert (tmp_path / "sweep" / "summary" / "success_by_cell.png").is_file()


def test_a_worker_killed_mid_run_means_the_run_is_retried_and_counted_once(cluster, tmp_path):
    from distributed import Client

    killed: dict[str, Any] = {}

    def kill_a_busy_worker() -> None:
        with Client(cluster.scheduler_address, timeout="10s") as spy:
            pids = spy.run(os.getpid)
            deadline = time.monotonic() + 120
            while time.monotonic() < deadline and not killed:
                busy = {w: ks for w, ks in spy.processing().items() if any("mission-run-" in str(k) for k in ks)}
                if busy:
                    time.sleep(1.5)  # well into the run (each takes seconds)
                    worker, keys = next(iter(busy.items()))
                    killed.update(pid=pids[worker], keys=[str(k) for k in keys])
                    os.kill(pids[worker], signal.SIGKILL)
                time.sleep(0.2)

    plan = SweepPlan.from_args("follow_open", "0-2", max_duration=3.0, pictures="none")
    killer = threading.Thread(target=kill_a_busy_worker, daemon=True)
    killer.start()
    outcome = run_sweep(plan, tmp_path / "sweep", scheduler=cluster.scheduler_address, progress=False)
    killer.join(timeout=5)
    assert killed, "no worker was busy with a run"
    lines = (tmp_path / "sweep" / "runs.jsonl").read_text().splitlines()
    ids = [json.loads(line)["run_id"] for line in lines]
    assert sorted(ids) == sorted(r.run_id for r in plan.runs())  # every run once: none lost, none twice
    assert not outcome.unfinished and outcome.recorded == 3
    rows = {r["run_id"]: r for r in read_parquet(tmp_path / "sweep" / "results.parquet")}
    lost = [run_id for run_id in rows if any(k.endswith(run_id) for k in killed["keys"])]
    assert lost, (killed, list(rows))
    for run_id in lost:  # finished by another worker process than the one killed
        assert not rows[run_id]["worker"].endswith(f":{killed['pid']}")


def _sweep_cli(out: Path) -> list[str]:
    return [
        sys.executable,
        "-m",
        "mission",
        "sweep",
        "--scenarios",
        "follow_open",
        "--seeds",
        "0-2",
        "--max-duration",
        "1.5",
        "--workers",
        "1",
        "--pictures",
        "none",
        "--quiet",
        "--out",
        str(out),
    ]


def test_ctrl_c_leaves_a_complete_table_and_the_same_command_resumes(tmp_path):
    out = tmp_path / "sweep"
    proc = subprocess.Popen(
        _sweep_cli(out), cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True
    )
    deadline = time.monotonic() + 180
    while time.monotonic() < deadline and proc.poll() is None and not read_jsonl(out / "runs.jsonl"):
        time.sleep(0.2)
    assert proc.poll() is None, proc.communicate()
    os.kill(proc.pid, signal.SIGINT)  # the driver only, as Ctrl-C in its terminal would reach it
    stdout, stderr = proc.communicate(timeout=120)
    assert proc.returncode == 130, stderr[-2000:]
    assert "INTERRUPTED" in stdout
    finished = {r["run_id"]: r for r in read_jsonl(out / "runs.jsonl")}
    table = read_parquet(out / "results.parquet")
    assert 1 <= len(finished) < 3
    assert sorted(r["run_id"] for r in table) == sorted(finished)  # the table holds exactly what finished
    assert (out / "summary.html").is_file()

    again = subprocess.run(_sweep_cli(out), cwd=ROOT, capture_output=True, text=True, timeout=300, check=False)
    assert again.returncode in (0, 1), again.stderr[-2000:]
    assert f"({len(finished)} finished before, skipped)" in again.stdout
    rows = {r["run_id"]: r for r in read_parquet(out / "results.parquet")}
    assert len(rows) == 3 and len((out / "runs.jsonl").read_text().splitlines()) == 3
    for run_id, row in finished.items():  # not run again
        assert rows[run_id]["finished_utc"] == row["finished_utc"] and rows[run_id]["worker"] == row["worker"]


@pytest.mark.parametrize(
    ("setting", "named", "nearest"),
    [
        ("SearchSweep.angular_sped=0.6,1.0", "SearchSweep.angular_sped", "SearchSweep.angular_speed"),
        ("run.tick_hzz=10,15", "run.tick_hzz", "run.tick_hz"),
        ("target.sped_mps=0.2", "target.sped_mps", "target.speed_mps"),
        ("tick_hz=10", "tick_hz", "run.tick_hz"),
    ],
)
def test_a_bad_set_key_is_one_line_naming_it_and_the_nearest_key_before_anything_runs(
    setting, named, nearest, tmp_path, capsys
):
    out = tmp_path / "sweep"
    code = cli.main(["sweep", "--scenarios", "follow_open", "--seeds", "0-999", "--set", setting, "--out", str(out)])
    err = capsys.readouterr().err
    assert code == 2
    assert err.count("\n") == 1 and err.startswith("mission: error: "), err
    assert named in err and f"did you mean {nearest}?" in err
    assert not out.exists()  # nothing ran, nothing was written


def test_a_bad_set_value_and_a_port_no_tree_uses_are_errors_before_anything_runs(tmp_path, capsys):
    out = tmp_path / "sweep"
    assert (
        cli.main(
            ["sweep", "--scenarios", "follow_open", "--seeds", "0-9", "--set", "run.tick_hz=10,500", "--out", str(out)]
        )
        == 2
    )
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "run.tick_hz" in err and "500" in err, err
    assert (
        cli.main(
            [
                "sweep",
                "--scenarios",
                "explore_dock",
                "--seeds",
                "0-9",
                "--set",
                "SearchSweep.angular_speed=0.6,1.0",
                "--out",
                str(out),
            ]
        )
        == 2
    )
    err = capsys.readouterr().err
    assert "no SearchSweep node in explore_dock.xml" in err, err
    assert not out.exists()
