"""Are two sweeps the same, run by run? ``python -m tools.same_runs A/runs.jsonl B/runs.jsonl``.

A refactor must not move a mission: the same scenario and seed must end the same way, for the same reason,
with every metric equal key for key. ``mission sweep --compare`` asks whether two sweeps' *rates* differ by more
than the seeds' luck; this asks whether any single run differs at all. Only what the wall clock and the machine
decide is ignored (times in seconds of wall or CPU, the worker, when it finished, where its report went).

Exit 0 when every run of A is in B and equal, 1 otherwise, with one line per difference.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

#: Keys of a runs.jsonl row that the machine decides, not the mission.
MACHINE_KEYS = frozenset({"wall_time_s", "task_s", "task_cpu_s", "worker", "finished_utc", "report_dir", "pictures"})


def read_runs(path: Path) -> dict[str, dict[str, Any]]:
    """run_id → row (the last row of a run wins, as `mission sweep` resumes)."""
    rows: dict[str, dict[str, Any]] = {}
    for line in path.read_text(encoding="utf-8").splitlines():
        if line.strip():
            row = json.loads(line)
            rows[row["run_id"]] = {k: v for k, v in row.items() if k not in MACHINE_KEYS}
    return rows


def differences(a: Any, b: Any, where: str = "") -> list[str]:
    """Every path at which `a` and `b` differ, as ``key.sub[2]: A != B``."""
    if isinstance(a, dict) and isinstance(b, dict):
        out = []
        for key in sorted(set(a) | set(b), key=str):
            here = f"{where}.{key}" if where else str(key)
            if key not in a or key not in b:
                out.append(f"{here}: only in {'B' if key not in a else 'A'}")
            else:
                out += differences(a[key], b[key], here)
        return out
    if isinstance(a, list) and isinstance(b, list) and len(a) == len(b):
        return [d for i, (x, y) in enumerate(zip(a, b, strict=True)) for d in differences(x, y, f"{where}[{i}]")]
    return [] if a == b else [f"{where}: {a!r} != {b!r}"]


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("a", type=Path, help="runs.jsonl of the sweep before")
    parser.add_argument("b", type=Path, help="runs.jsonl of the sweep after")
    args = parser.parse_args(argv)
    a, b = read_runs(args.a), read_runs(args.b)
    problems = [f"{run}: missing in B" for run in sorted(set(a) - set(b))]
    problems += [f"{run}: {d}" for run in sorted(set(a) & set(b)) for d in differences(a[run], b[run])]
    for line in problems:
        print(line)
    same = sum(1 for run in set(a) & set(b) if not differences(a[run], b[run]))
    outcomes = sum(1 for run in set(a) & set(b) if a[run]["success"] == b[run]["success"])
    print(f"{same} of {len(a)} runs identical (outcome, reason, every metric); {outcomes} with the same outcome")
    return 0 if not problems else 1


if __name__ == "__main__":
    sys.exit(main())
