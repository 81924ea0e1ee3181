"""The results table of a sweep: one row per finished run, as JSON lines and as Parquet.

A row holds the run's name and matrix cell, its outcome as `mission run` judges it, the figures the
summary plots (flat columns: loss and re-acquisition, occlusions, docking errors, collisions) and the
whole metrics of report.json. In ``runs.jsonl`` nested values stay nested; in ``results.parquet`` each
``--set`` key is a text column ``set:<key>`` (its value as typed) and the nested values are JSON text
columns (``params_json``, ``metrics_json``, ``perception_stats_json``, ``faults_json``), so any tool reads
the table with one schema.
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Iterable, Sequence
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

from mission.app.overrides import format_value
from mission.core.files import atomic_path

NESTED = ("params", "metrics", "perception_stats", "faults")

#: the fixed columns, in order, with their Parquet types (pyarrow type names)
COLUMNS: tuple[tuple[str, str], ...] = (
    ("run_id", "string"),
    ("scenario", "string"),
    ("seed", "int64"),
    ("cell", "string"),
    ("set", "string"),
    ("success", "bool"),
    ("reason", "string"),
    ("crashed", "bool"),
    ("interrupted", "bool"),
    ("tree_status", "string"),
    ("final_state", "string"),
    ("sim_time_s", "float64"),
    ("wall_time_s", "float64"),
    ("task_s", "float64"),
    ("task_cpu_s", "float64"),
    ("ticks", "int64"),
    ("loss_events", "int64"),
    ("loss_events_recovered", "int64"),
    ("reacquisition_times_s", "list<float64>"),
    ("reacquisition_max_s", "float64"),
    ("occlusions_over_0_5s", "int64"),
    ("occlusions_missed", "int64"),
    ("occlusion_latency_max_s", "float64"),
    ("goal_jitter_sd_m", "float64"),
    ("collisions", "int64"),
    ("docked", "bool"),
    ("dock_lateral_m", "float64"),
    ("dock_distance_m", "float64"),
    ("dock_skew_deg", "float64"),
    ("dock_standoff_m", "float64"),
    ("report_dir", "string"),
    ("pictures", "bool"),
    ("command", "string"),
    ("worker", "string"),
    ("finished_utc", "string"),
)


def _num(value: Any) -> float | None:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        return None
    return float(value)


def outcome_row(
    spec: Any, outcome: dict[str, Any], reacquisitions: Sequence[float], *, pictures: bool, worker: str
) -> dict[str, Any]:
    """The row of a run: `spec` (plan.RunSpec), its outcome (RunOutcome.to_json()) and every re-acquisition
    time (s) of the run, for the CDFs."""
    m = outcome.get("metrics") or {}
    dock = m.get("dock") or {}
    reacq = m.get("reacquisition_time_s") or {}
    latency = m.get("occlusion_detection_latency_s") or {}
    return {
        "run_id": spec.run_id,
        "scenario": spec.scenario,
        "seed": int(spec.seed),
        "cell": spec.cell,
        "set": spec.overrides.label,
        "success": bool(outcome.get("success")),
        "reason": str(outcome.get("reason", "")),
        "crashed": bool(outcome.get("crashed", False)),
        "interrupted": bool(outcome.get("interrupted", False)),
        "tree_status": outcome.get("tree_status"),
        "final_state": outcome.get("final_state"),
        "sim_time_s": _num(outcome.get("sim_time_s")),
        "wall_time_s": _num(outcome.get("wall_time_s")),
        "task_s": None,  # the whole task on the worker (run, report, files): set by task.run_one
        "task_cpu_s": None,  # the CPU seconds of the worker process meanwhile (load-independent)
        "ticks": outcome.get("ticks"),
        "loss_events": m.get("loss_events"),
        "loss_events_recovered": m.get("loss_events_recovered"),
        "reacquisition_times_s": [round(float(t), 3) for t in reacquisitions],
        "reacquisition_max_s": _num(reacq.get("max")),
        "occlusions_over_0_5s": m.get("occlusions_over_0_5s"),
        "occlusions_missed": m.get("occlusions_missed"),
        "occlusion_latency_max_s": _num(latency.get("max")),
        "goal_jitter_sd_m": _num(m.get("goal_jitter_sd_m")),
        "collisions": m.get("collisions"),
        "docked": bool(dock),
        "dock_lateral_m": _num(dock.get("lateral_m")),
        "dock_distance_m": _num(dock.get("distance_m")),
        "dock_skew_deg": _num(dock.get("skew_deg")),
        "dock_standoff_m": _num(dock.get("standoff_m")),
        "report_dir": f"runs/{spec.run_id}",
        "pictures": pictures,
        "command": spec.command(),
        "worker": worker,
        "finished_utc": datetime.now(timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ"),
        "params": spec.overrides.as_dict(),
        "metrics": m,
        "perception_stats": outcome.get("perception_stats") or {},
        "faults": outcome.get("faults") or {},
    }


# ------------------------------------------------------------------------------------ JSON lines
def read_jsonl(path: Path) -> list[dict[str, Any]]:
    """The rows of runs.jsonl, first of each run_id kept. A line cut short (the writer killed mid-line) is
    skipped: its run is not finished and runs again on resume."""
    rows: dict[str, dict[str, Any]] = {}
    if not path.is_file():
        return []
    with path.open(encoding="utf-8") as f:
        for line in f:
            try:
                row = json.loads(line)
            except json.JSONDecodeError:
                continue
            if isinstance(row, dict) and isinstance(row.get("run_id"), str):
                rows.setdefault(row["run_id"], row)
    return list(rows.values())


def append_jsonl(path: Path, row: dict[str, Any]) -> None:
    """One row at the end of runs.jsonl, on disk before this returns (a crash after it keeps the run).

    A line is written whole in one call after a newline check, so a torn line left by a killed writer
    ends where the next row begins, and read_jsonl drops only the torn one."""
    line = json.dumps(row, default=_json_default, separators=(",", ":")) + "\n"
    with path.open("ab") as f:
        if f.tell() > 0:
            with path.open("rb") as r:
                r.seek(-1, 2)
                if r.read(1) != b"\n":
                    line = "\n" + line
        f.write(line.encode("utf-8"))
        f.flush()
        os.fsync(f.fileno())


def _json_default(o: Any) -> Any:
    if hasattr(o, "item"):  # numpy scalars
        return o.item()
    if hasattr(o, "tolist"):
        return o.tolist()
    return str(o)


# ------------------------------------------------------------------------------------ Parquet
def parquet_schema(param_keys: Iterable[str]) -> Any:
    import pyarrow as pa

    types = {
        "string": pa.string(),
        "int64": pa.int64(),
        "float64": pa.float64(),
        "bool": pa.bool_(),
        "list<float64>": pa.list_(pa.float64()),
    }
    fields = [pa.field(name, types[kind]) for name, kind in COLUMNS]
    fields += [pa.field(f"set:{key}", pa.string()) for key in param_keys]
    fields += [pa.field(f"{name}_json", pa.string()) for name in NESTED]
    return pa.schema(fields)


def param_keys(rows: Iterable[dict[str, Any]]) -> list[str]:
    """Every --set key of the rows, in the order first seen."""
    return list(dict.fromkeys(k for r in rows for k in (r.get("params") or {})))


def write_parquet(path: Path, rows: Sequence[dict[str, Any]]) -> None:
    """The rows as one Parquet file, replaced whole (a reader never sees half a table)."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    keys = param_keys(rows)
    flat = []
    for r in rows:
        out = {name: r.get(name) for name, _ in COLUMNS}
        params = r.get("params") or {}
        out.update({f"set:{k}": format_value(params[k]) if k in params else None for k in keys})
        out.update({f"{n}_json": json.dumps(r.get(n), default=_json_default) for n in NESTED})
        flat.append(out)
    table = pa.Table.from_pylist(flat, schema=parquet_schema(keys))
    with atomic_path(path) as tmp:
        pq.write_table(table, tmp)


def read_parquet(path: Path) -> list[dict[str, Any]]:
    """Rows from results.parquet, nested values restored (as runs.jsonl holds them)."""
    import pyarrow.parquet as pq

    rows = []
    for r in pq.read_table(path).to_pylist():
        for n in NESTED:
            r[n] = json.loads(r.pop(f"{n}_json") or "null")
        for k in [k for k in r if k.startswith("set:")]:
            r.pop(k)
        rows.append(r)
    return rows
