"""`mission sweep`: scenarios × seeds × --set values on Dask; a results table and a summary.

    mission sweep --scenarios follow_open,follow_occlusion --seeds 0-19 --set SearchSweep.angular_speed=0.6,1.0
    mission sweep --scenarios mission_full --seeds 0-999 --scheduler tcp://scheduler:8786 --out out/regression
    mission sweep --compare out/before out/after

Exit 0 when every run finished and every mission succeeded, 1 when a mission failed or a run could not
finish, 2 on a usage or config error (before anything runs), 130/143 when interrupted (the table and
the summary then hold every run that finished; the same command resumes).
"""

from __future__ import annotations

import argparse
import contextlib
import signal
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from mission.core.errors import MissionError

DEFAULT_OUT = "out/sweep"


@contextlib.contextmanager
def _signals_interrupt() -> Iterator[list[int]]:
    """SIGTERM as Ctrl-C: the sweep stops, writes what finished, exits 143 (SIGINT: 130)."""
    caught: list[int] = []

    def handler(signum: int, _frame: Any) -> None:
        caught.append(signum)
        raise KeyboardInterrupt

    previous = {s: signal.signal(s, handler) for s in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield caught
    finally:
        for s, h in previous.items():
            signal.signal(s, h)


def main(args: argparse.Namespace) -> int:
    if args.compare:
        return _compare(args)
    if not args.scenarios or args.seeds is None:
        raise MissionError("mission sweep needs --scenarios and --seeds (or --compare A B)")
    from mission.sweep.engine import run_sweep
    from mission.sweep.plan import SweepPlan

    plan = SweepPlan.from_args(
        args.scenarios,
        args.seeds,
        args.set,
        config_file=args.config,
        tree=args.tree,
        max_duration=args.max_duration,
        pictures=args.pictures,
    )
    with _signals_interrupt() as caught:
        outcome = run_sweep(
            plan,
            args.out,
            scheduler=args.scheduler,
            workers=args.workers,
            dashboard=args.dashboard,
            progress=not args.quiet,
        )
    out = Path(args.out)
    rows = outcome.rows
    ok = sum(1 for r in rows if r.get("success"))
    where = "local cluster" if outcome.scheduler == "local" else outcome.scheduler
    print(
        f"sweep: {ok}/{len(rows)} runs succeeded, {len(rows) - ok} failed"
        + (
            f", {len(outcome.unfinished)} {'not run' if outcome.interrupted else 'unfinished'}"
            if outcome.unfinished
            else ""
        )
        + (f" ({outcome.skipped} finished before, skipped)" if outcome.skipped else "")
        + f"; {outcome.recorded} run now on {outcome.workers} worker(s) ({where}) in {outcome.wall_s:.0f} s"
        + ("; INTERRUPTED: run the same command to resume" if outcome.interrupted else "")
    )
    print(f"table {out / 'results.parquet'} (and runs.jsonl); summary {out / 'summary.html'}")
    for line in outcome.errors[:10]:
        print(f"unfinished: {line}", file=sys.stderr)
    errored = {line.split(":", 1)[0] for line in outcome.errors}
    for run_id in [r for r in outcome.unfinished if r not in errored][:10] if not outcome.interrupted else []:
        print(f"unfinished: {run_id} (its workers died; it runs again on resume)", file=sys.stderr)
    if outcome.interrupted:
        return 128 + (caught[0] if caught else int(signal.SIGINT))
    return 0 if ok == len(rows) and not outcome.unfinished else 1


def _compare(args: argparse.Namespace) -> int:
    from mission.sweep.compare import compare_sweeps, text_table, write_html

    a, b = args.compare
    rows, notes = compare_sweeps(a, b)
    print(text_table(a, b, rows, notes))
    if args.output:
        print(f"written {write_html(args.output, a, b, rows, notes)}")
    return 0
