"""A sweep directory: what was asked, what finished, and each run's report.

    OUT/sweep.json              the plans run into it, and what their outcomes depend on (config, tree, limit)
    OUT/runs.jsonl              one row per finished run, appended as each arrives: the table's record
    OUT/results.parquet         the same rows as one Parquet table (rewritten as runs finish and at the end)
    OUT/runs/<cell>/seed-NNNN/  that run's report: report.json, trajectories.png, timeline.png, trees/, report.html
    OUT/summary.html            the summary (mission/sweep/summary.py), pictures in OUT/summary/

Only the driver writes here, one run at a time: the run's folder first (written aside, then renamed into
place), then its row. A run is finished when its row is in runs.jsonl; a second result for a name
already there (a task Dask ran twice) is dropped, so no run counts twice, and a run without a row (the
driver stopped before writing it) runs again when the sweep is resumed.
"""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path
from typing import Any

from mission.core.errors import MissionError
from mission.core.files import atomic_write_bytes, atomic_write_text, ensure_dir, unwritable
from mission.sweep.plan import SweepPlan
from mission.sweep.table import append_jsonl, read_jsonl, write_parquet
from mission.sweep.task import RunResult

SWEEP_FILE = "sweep.json"
ROWS_FILE = "runs.jsonl"
TABLE_FILE = "results.parquet"
RUNS_DIR = "runs"


class SweepStore:
    """The sweep directory `out`; :meth:`open` it for a plan, then :meth:`record` each result."""

    def __init__(self, out: str | Path) -> None:
        self.out = Path(out)
        self.rows: dict[str, dict[str, Any]] = {}
        self.duplicates = 0  # results dropped because their run was recorded already

    @property
    def rows_path(self) -> Path:
        return self.out / ROWS_FILE

    @property
    def table_path(self) -> Path:
        return self.out / TABLE_FILE

    def load(self) -> SweepStore:
        """Read what is recorded (for a summary or a comparison); MissionError when `out` holds no sweep."""
        if not self.rows_path.is_file() and not (self.out / SWEEP_FILE).is_file():
            raise MissionError(
                f"{self.out}: not a sweep directory (no {ROWS_FILE}); expected the --out of a `mission sweep`"
            )
        self.rows = {r["run_id"]: r for r in read_jsonl(self.rows_path)}
        return self

    def info(self) -> dict[str, Any]:
        """sweep.json: the plans and the identity they share ({} when absent)."""
        try:
            data = json.loads((self.out / SWEEP_FILE).read_text(encoding="utf-8"))
        except (OSError, json.JSONDecodeError):
            return {}
        return data if isinstance(data, dict) else {}

    def open(self, plan: SweepPlan) -> None:
        """Make or resume the directory for `plan`: refused when it holds runs made with another config,
        tree or --max-duration (their outcomes would not be comparable)."""
        try:
            ensure_dir(self.out)
            ensure_dir(self.out / RUNS_DIR)
        except OSError as err:
            raise MissionError(f"--out {self.out}: {unwritable(err, self.out, directory=True)}") from None
        info = self.info()
        identity = plan.identity()
        previous = info.get("identity")
        if previous is not None and previous != identity:
            changed = [k for k in identity if identity.get(k) != previous.get(k)]
            raise MissionError(
                f"--out {self.out}: holds a sweep made with another {', '.join(changed)} "
                f"({_shown(previous, changed)}; this one: {_shown(identity, changed)}); resume it with the same "
                "options, or choose another --out"
            )
        self.rows = {r["run_id"]: r for r in read_jsonl(self.rows_path)}
        plans = [*info.get("plans", []), plan.describe()]
        atomic_write_text(self.out / SWEEP_FILE, json.dumps({"identity": identity, "plans": plans}, indent=2) + "\n")

    def finished(self, run_id: str) -> bool:
        return run_id in self.rows

    def record(self, result: RunResult) -> bool:
        """Write a run's report folder and row; False (nothing written) when the run was recorded already."""
        if result.run_id in self.rows:
            self.duplicates += 1
            return False
        final = self.out / RUNS_DIR / result.run_id
        partial = final.with_name(f".{final.name}.partial-{os.getpid()}")
        shutil.rmtree(partial, ignore_errors=True)
        for rel, data in result.files.items():
            target = (partial / rel).resolve()
            if partial.resolve() not in target.parents:  # a name from the worker never leaves the run's folder
                raise MissionError(f"{result.run_id}: report file {rel!r} points outside its folder")
            atomic_write_bytes(target, data)
        ensure_dir(partial)
        shutil.rmtree(final, ignore_errors=True)  # a folder left by an attempt that never got its row
        os.replace(partial, final)
        append_jsonl(self.rows_path, result.row)
        self.rows[result.run_id] = result.row
        return True

    def write_table(self, *, reread: bool = True) -> None:
        """results.parquet from every row in runs.jsonl: the file is the record, so a Ctrl-C that landed
        between a row's line and its entry here still leaves that run in the table. `reread=False` (the
        refreshes while runs arrive) writes the rows held here without reading the file again."""
        if reread:
            self.rows = {r["run_id"]: r for r in read_jsonl(self.rows_path)}
        write_parquet(self.table_path, list(self.rows.values()))


def _shown(identity: dict[str, Any], keys: list[str]) -> str:
    def one(key: str) -> str:
        value = identity.get(key)
        if isinstance(value, dict):
            value = f"{value.get('path')} sha256 {str(value.get('sha256'))[:12]}"
        return f"{key} {value}"

    return ", ".join(one(k) for k in keys)
