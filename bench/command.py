"""The benchmark runner (`python -m bench`, also `mission bench` in a checkout): run the benchmarks in bench/
and write their figures (JSON per benchmark + plots).

Each benchmark writes ``<output>/<name>.json`` (its figures, the machine, the command, the elapsed
time) and its plots; ``<output>/results.json`` gathers the benchmarks of this invocation. A benchmark
that fails is reported on one line and the others still run (exit 1). The output is bench/results (the
committed figures BENCHMARKS.md is generated from by ``python -m bench.report``) for a full run, and
out/bench-quick/ (gitignored) for ``--quick``, which never writes into bench/results.

bench/ is never installed: it is a development tool of the source checkout. `mission bench` (an editable
install) starts this module as its own program with the checkout on its path (mission/commands/bench.py).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
import traceback
from collections.abc import Sequence
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

from bench.catalogue import Benchmark, default_output, is_committed_results, select
from bench.common import machine_info, progress
from mission.core.errors import MissionError
from mission.core.files import atomic_write_text, ensure_dir, unwritable


def build_parser() -> argparse.ArgumentParser:
    """The runner's arguments (`mission bench --help` shows these: that verb forwards its arguments here)."""
    p = argparse.ArgumentParser(prog="mission bench", description="run the benchmarks and write their figures")
    p.add_argument("--quick", action="store_true", help="small sweep, under 2 minutes on 2 cores")
    p.add_argument("--json", action="store_true", help="print machine-readable results")
    p.add_argument("--only", default=None, help="comma-separated benchmark names")
    p.add_argument(
        "-o",
        "--output",
        default=None,
        metavar="DIR",
        help="where figures go (default bench/results; with --quick out/bench-quick, never bench/results)",
    )
    return p


def command_line(args: argparse.Namespace) -> str:
    parts = ["mission", "bench"]
    if args.quick:
        parts.append("--quick")
    if args.only:
        parts += ["--only", args.only]
    if args.output is not None:
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


def output_dir(args: argparse.Namespace) -> Path:
    """-o DIR, else bench/results for a full run and out/bench-quick/ for --quick; created and checked
    writable. A quick run is refused the committed results directory (it would replace full-run figures)."""
    out = Path(args.output) if args.output is not None else default_output(args.quick)
    if args.quick and is_committed_results(out):
        raise MissionError(
            f"-o {args.output}: --quick figures never go into the committed full-run results; "
            f"expected another directory (the default is {_shown(default_output(True))})"
        )
    try:
        ensure_dir(out)
    except OSError as err:
        raise MissionError(f"-o {out}: {unwritable(err, out, directory=True)}") from None
    return out


def _shown(path: Path) -> str:
    """`path` relative to the working directory when it is inside it."""
    try:
        return str(path.resolve().relative_to(Path.cwd().resolve()))
    except ValueError:
        return str(path)


def run(args: argparse.Namespace) -> int:
    """Run the chosen benchmarks; the exit code (1 when one failed among several)."""
    chosen = select(args.only, args.quick)
    out = output_dir(args)
    cmd = command_line(args)
    machine = machine_info()
    t0 = time.perf_counter()
    entries = [_run_one(b, args.quick, out, machine, cmd) for b in chosen]
    total = round(time.perf_counter() - t0, 1)
    summary = {"command": cmd, "machine": machine, "elapsed_s": total, "benchmarks": {e["name"]: e for e in entries}}
    atomic_write_text(out / "results.json", json.dumps(summary, indent=2, default=str) + "\n")
    if args.json:
        print(json.dumps(summary, indent=2, default=str))
    else:
        _print_summary(entries)
        shown = _shown(out)
        report = "BENCHMARKS.md" if is_committed_results(out) else f"{shown}/BENCHMARKS.md"
        print(f"figures in {shown}/ ({total:.0f} s); {report}: python -m bench.report {shown}")
    failed = [e for e in entries if "error" in e]
    if failed and len(failed) == len(entries) == 1:
        raise MissionError(failed[0]["error"])
    return 1 if failed else 0


def main(argv: Sequence[str] | None = None) -> int:
    """`python -m bench [--quick] [--only A,B] [-o DIR] [--json]`: exit 0, 1 (a benchmark failed) or 2 (usage)."""
    args = build_parser().parse_args(argv)
    try:
        return run(args)
    except MissionError as err:
        for line in str(err).splitlines():
            print(f"mission: error: {line}", file=sys.stderr)  # as every verb says it
        return 2
    except KeyboardInterrupt:
        return 130
