"""`mission bench`: run the benchmarks in bench/ and write their figures (JSON per benchmark + plots).

Each benchmark writes ``<output>/<name>.json`` (its figures, the machine, the command, the elapsed
time) and its plots; ``<output>/results.json`` gathers the benchmarks of this invocation. A benchmark
that fails is reported on one line and the others still run (exit 1). BENCHMARKS.md is generated from
the output directory by ``python -m bench.report``.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
import traceback
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

from bench.common import machine_info, progress
from bench.registry import Benchmark, select
from mission.core.errors import MissionError
from mission.core.files import atomic_write_text


def command_line(args: argparse.Namespace) -> str:
    parts = ["mission", "bench"]
    if args.quick:
        parts.append("--quick")
    if args.only:
        parts += ["--only", args.only]
    if str(args.output) != "bench/results":
        parts += ["-o", str(args.output)]
    return " ".join(parts)


def _run_one(b: Benchmark, quick: bool, out: Path, machine: dict[str, Any], cmd: str) -> dict[str, Any]:
    entry: dict[str, Any] = {
        "name": b.name,
        "description": b.description,
        "command": cmd,
        "quick": quick,
        "started_utc": datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
        "machine": machine,
    }
    t0 = time.perf_counter()
    progress(f"{b.name}: {b.description}")
    try:
        run = b.load()
        entry["result"] = run(quick, out)
    except MissionError as err:
        entry["error"] = str(err)
    except Exception as err:  # a broken benchmark must not stop the others
        entry["error"] = f"{type(err).__name__}: {err}"
        traceback.print_exc(file=sys.stderr)
    entry["elapsed_s"] = round(time.perf_counter() - t0, 1)
    if "error" in entry:
        print(f"mission bench: {b.name}: {entry['error']}", file=sys.stderr)
    else:
        progress(f"{b.name}: done in {entry['elapsed_s']:.1f} s")
        atomic_write_text(out / f"{b.name}.json", json.dumps(entry, indent=2, default=str) + "\n")
    return entry


def _print_summary(entries: list[dict[str, Any]]) -> None:
    for e in entries:
        if "error" in e:
            print(f"{e['name']}: FAILED — {e['error']}")
            continue
        res = e["result"]
        print(f"{e['name']} ({e['elapsed_s']:.0f} s): {res.get('title', e['description'])}")
        for f in res.get("figures", []):
            val = f["value"]
            base = f.get("baseline_value")
            line = f"  {f['label']}: {val} {f['unit']}"
            if base is not None:
                line += f"  vs {base} ({f['baseline']})"
            else:
                line += f"  [baseline: {f['baseline']}]"
            if f.get("ratio") is not None:
                line += f"  ratio {f['ratio']}"
            if f.get("target"):
                line += f"  target {f['target']}" + {True: " ✓", False: " ✗", None: ""}[f.get("meets_target")]
            print(line)


def main(args: argparse.Namespace) -> int:
    chosen = select(args.only, args.quick)
    out = Path(args.output)
    out.mkdir(parents=True, exist_ok=True)
    cmd = command_line(args)
    machine = machine_info()
    t0 = time.perf_counter()
    entries = [_run_one(b, args.quick, out, machine, cmd) for b in chosen]
    total = round(time.perf_counter() - t0, 1)
    summary = {"command": cmd, "machine": machine, "elapsed_s": total,
               "benchmarks": {e["name"]: e for e in entries}}  # fmt: skip
    atomic_write_text(out / "results.json", json.dumps(summary, indent=2, default=str) + "\n")
    if args.json:
        print(json.dumps(summary, indent=2, default=str))
    else:
        _print_summary(entries)
        print(f"figures in {out}/ ({total:.0f} s); BENCHMARKS.md: python -m bench.report {out}")
    failed = [e for e in entries if "error" in e]
    if failed and len(failed) == len(entries) == 1:
        raise MissionError(failed[0]["error"])
    return 1 if failed else 0
