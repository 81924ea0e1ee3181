"""One run of a sweep, in a worker process: `mission run`'s code path and report, returned as data.

The worker writes nothing into the sweep directory. The report (report.json, the pictures, the trees
at each transition, report.html) is written by the same functions `mission run --report` calls, into a
scratch folder on the worker, and comes back as bytes with the row; the sweep's driver then writes the
folder and the row. So a worker on another machine needs no shared filesystem, and a worker that dies
mid-run leaves nothing behind: its run is simply run again elsewhere.
"""

from __future__ import annotations

import os
import socket
import tempfile
import time
import traceback
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from mission.sweep.plan import RunSpec
from mission.sweep.table import outcome_row


@dataclass
class RunResult:
    """What a worker sends back: the run's name, its row, and its report files (path in its folder → bytes)."""

    run_id: str
    row: dict[str, Any]
    files: dict[str, bytes]


def worker_name() -> str:
    return f"{socket.gethostname()}:{os.getpid()}"


def run_one(spec: RunSpec) -> RunResult:
    """Run `spec` as `mission run --report` would and return its row and report. A run that raises is a
    failed row saying so ("crashed: …"): the same seed would raise again, so it is not retried."""
    import py_trees

    from mission.app.sim_run import run_scenario
    from mission.viz.run_report import report_observers, write_report

    # A worker process runs many runs; each starts from an empty blackboard, as a fresh `mission run`
    # process does (a key one run wrote must not be what the next one reads before its world writes it).
    py_trees.blackboard.Blackboard.clear()
    wall0, cpu0 = time.perf_counter(), time.process_time()
    with tempfile.TemporaryDirectory(prefix="mission-sweep-") as tmp:
        out = Path(tmp)
        observers = report_observers(out) if spec.pictures != "none" else []
        try:
            outcome, recorder, adapter = run_scenario(
                spec.scenario,
                config_file=spec.config_file,
                tree=spec.tree,
                seed=spec.seed,
                max_duration=spec.max_duration,
                observers=observers,
                overrides=spec.overrides,
            )
        except Exception as err:  # a crash is this run's outcome, recorded like any failure
            last = traceback.format_exception_only(type(err), err)[-1].strip()
            data = {
                "success": False,
                "reason": f"crashed: {last}",
                "crashed": True,
                "wall_time_s": round(time.perf_counter() - wall0, 3),
                "metrics": {},
            }
            row = outcome_row(spec, data, [], pictures=False, worker=worker_name())
            row["task_s"], row["task_cpu_s"] = data["wall_time_s"], round(time.process_time() - cpu0, 3)
            return RunResult(spec.run_id, row, {})
        keep_pictures = spec.pictures == "all" or (spec.pictures == "failed" and not outcome.success)
        if keep_pictures:
            write_report(out, outcome, recorder, adapter)
        else:  # report.json only: the pictures (and the trees' report.html) are dropped
            from mission.viz.run_report import write_json

            for path in out.rglob("*"):
                if path.is_file():
                    path.unlink()
            write_json(out / "report.json", outcome.to_json())
        files = {str(p.relative_to(out)): p.read_bytes() for p in sorted(out.rglob("*")) if p.is_file()}
    reacquisitions = [e.end - e.start for e in recorder.losses if e.end is not None]
    row = outcome_row(spec, outcome.to_json(), reacquisitions, pictures=keep_pictures, worker=worker_name())
    row["task_s"], row["task_cpu_s"] = round(time.perf_counter() - wall0, 3), round(time.process_time() - cpu0, 3)
    return RunResult(spec.run_id, row, files)


def worker_identity() -> dict[str, Any]:
    """Which mission a worker runs (its version and source commit): every worker of a sweep must run the
    same code, or the same seed could give another outcome."""
    from importlib import metadata

    from mission.app.provenance import source_revision

    try:
        version: str | None = metadata.version("mission")
    except metadata.PackageNotFoundError:
        version = None
    revision = source_revision()
    return {"mission": version, "commit": revision["commit"] if revision else None}
