"""`mission run`: a mission in the pybullet simulation, headless; exit 0 on success, 1 on failure."""

from __future__ import annotations

import argparse
import signal
import sys
from pathlib import Path

from mission.app.overrides import RunOverrides, run_overrides
from mission.app.runner import WallClockPacer
from mission.app.sim_run import RunOutcome, check_prepared, prepare_run, run_scenario, unused_ports
from mission.core.errors import ConfigError, MissionError
from mission.core.files import ensure_dir, unwritable
from mission.core.observers import RunObserver
from mission.viz.report_trees import perception_label
from mission.viz.run_report import report_observers, verdict, write_report

DEFAULT_SCENARIO = "mission_full"


def _observers(args: argparse.Namespace, label: str) -> list[RunObserver]:
    observers: list[RunObserver] = []
    if not args.quiet:
        from mission.app.live_status import LiveStatus

        observers.append(LiveStatus(label, total_s=args.max_duration))
    # Viewers (mission.viz): each fails here, before the simulation starts, on a bad path or a busy port.
    if getattr(args, "serve", False):
        from mission.viz.web import LiveView

        observers.append(LiveView(args.port, hold=sys.stdin.isatty()))
    if getattr(args, "log", None):
        from mission.viz.tick_log import TickLog

        observers.append(TickLog(args.log))
    if getattr(args, "record", None):
        from mission.viz.recording import Recorder

        observers.append(Recorder(args.record))
    if getattr(args, "report", None):
        observers += report_observers(args.report)
    if getattr(args, "btlog", None):
        from mission.groot.btlog import BtLogWriter

        observers.append(BtLogWriter(args.btlog))
    if getattr(args, "groot", None) is not None:
        from mission.groot.publisher import Groot2Publisher

        observers.append(Groot2Publisher(args.groot))
    if getattr(args, "record_bag", None):
        from mission.ros.bag_record import BagObserver

        try:
            observers.append(BagObserver(args.record_bag))
        except MissionError as err:  # its messages start with the path: say which option gave it
            raise MissionError(f"--record-bag {err}") from None
    return observers


def _check_report_dir(args: argparse.Namespace) -> None:
    """--report DIR is created and checked writable now: the report is written after the whole simulation."""
    if args.report:
        try:
            ensure_dir(args.report)
        except OSError as err:
            raise MissionError(f"--report {args.report}: {unwritable(err, args.report, directory=True)}") from None


def checked_overrides(args: argparse.Namespace, scenario: str) -> RunOverrides:
    """--set KEY=VALUE …, every key and value checked against this run's files before anything runs.

    A port of a node type the tree does not use is a warning, not an error: it changes nothing, and a
    sweep's reproduce command for a scenario whose tree lacks that node must still run."""
    overrides = run_overrides(getattr(args, "set", None) or [])
    if overrides:
        prepared = prepare_run(scenario, config_file=args.config, tree=args.tree, overrides=overrides)
        try:
            unused_ports(overrides, check_prepared(prepared), Path(prepared.tree).name)
        except ConfigError as err:
            print(f"mission: warning: {err}", file=sys.stderr)
    return overrides


def main(args: argparse.Namespace) -> int:
    scenario = args.scenario or DEFAULT_SCENARIO
    overrides = checked_overrides(args, scenario)
    _check_report_dir(args)  # the other outputs are checked as their observers are made, also before the run
    label = f"{Path(scenario).stem} seed {args.seed}" + (f" ({overrides.label})" if overrides else "")
    # --serve, --groot: simulated time at wall-clock speed, so the run can be watched
    watched = getattr(args, "serve", False) or getattr(args, "groot", None) is not None
    pacer = WallClockPacer(1.0) if watched else None
    outcome, recorder, adapter = run_scenario(
        scenario,
        config_file=args.config,
        tree=args.tree,
        seed=args.seed,
        max_duration=args.max_duration,
        observers=_observers(args, label),
        pacer=pacer,
        overrides=overrides,
    )
    if args.report:
        write_report(args.report, outcome, recorder, adapter)
    return result_line(outcome, label, args.report)


def result_line(outcome: RunOutcome, label: str, report: str | None, *, perception: bool = True) -> int:
    """Print the one-line verdict of a simulated run; its exit code (0 success, 1 failure, 128 + signal).
    `perception`: name the perception plugins that ran (not for sim-robot: its perception is the node's)."""
    m = outcome.metrics
    plugins = perception_label(outcome.provenance) if perception else ""
    print(
        f"{verdict(outcome)}: {label}: {outcome.reason} "
        f"({outcome.sim_time_s:.1f} s simulated in {outcome.wall_time_s:.1f} s; "
        f"losses {m['loss_events_recovered']}/{m['loss_events']} recovered; collisions {m['collisions']}"
        + (f"; perception {plugins}" if plugins else "")
        + ")"
        + (f"; report in {report}/" if report else "")
    )
    sys.stdout.flush()
    if outcome.interrupted:  # the shell's convention: 128 + the signal (130 SIGINT, 143 SIGTERM)
        return 128 + int(signal.Signals[outcome.stop_signal or "SIGINT"])
    return 0 if outcome.success else 1
