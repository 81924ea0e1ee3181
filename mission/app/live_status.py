"""The compact terminal status of a running mission: sim time, state, target distance, active branch.

On a terminal it is one line redrawn in place (rich); in a log (CI, a pipe) it prints a line per state
change and a heartbeat every `every_s` simulated seconds — progress without flooding. When the run has a
known length (`total_s`, else the scenario's duration) the line starts with a progress bar. A run whose trees
come and go (an action server's goals) shows ``no tree`` in place of the branch while none runs, and a log gets
a line at the first tick after each change.
"""

from __future__ import annotations

import sys
from typing import Any, TextIO

from rich.console import Console
from rich.live import Live
from rich.text import Text

from mission.core import blackboard as bbk
from mission.core.observers import RunObserver, Tick


class LiveStatus(RunObserver):
    """A run observer (mission.core.observers) that shows progress on the terminal."""

    def __init__(
        self, label: str, stream: TextIO | None = None, every_s: float = 10.0, total_s: float | None = None
    ) -> None:
        self.label = label
        self.total_s = total_s
        self._t0: float | None = None
        self.stream = stream or sys.stderr
        self.every_s = every_s
        self._console = Console(file=self.stream, highlight=False)
        self._live: Live | None = None
        self._last_state = None
        self._last_print = -1e9
        self._tree_changed = False

    def _line(self, runner: Any, tick: Tick) -> str:
        state = runner.get(bbk.STATE, "") or "…"
        gt = tick.ground_truth
        target = getattr(gt, "target", None)
        dist = "" if target is None else f"target {gt.robot.distance_to(target):4.1f} m  "
        branch = " › ".join(runner.active_branch()[-3:]) if runner.tree is not None else "no tree"
        return f"[{self.label}] {self._bar(tick.clock)}t={tick.clock:6.1f}s  {state:<7} {dist}{branch}"

    def _bar(self, stamp: float, width: int = 16) -> str:
        """`▕██████░░░░▏ 40% ` of the run's known length, or nothing when the length is not known."""
        if not self.total_s or self.total_s <= 0:
            return ""
        if self._t0 is None:
            self._t0 = stamp
        frac = min(1.0, max(0.0, (stamp - self._t0) / self.total_s))
        full = round(frac * width)
        return f"▕{'█' * full}{'░' * (width - full)}▏{frac * 100:3.0f}% "

    def on_start(self, runner: Any) -> None:
        adapter = runner.world
        if self.total_s is None:  # a scenario's own length, when the world has one
            self.total_s = getattr(getattr(adapter, "scenario", None), "duration_s", None)
        if self._console.is_terminal:
            self._live = Live(Text(""), console=self._console, refresh_per_second=8, transient=True)
            self._live.start()

    def on_tick(self, runner: Any, tick: Tick) -> None:
        line = self._line(runner, tick)
        if self._live is not None:
            self._live.update(Text(line))
            return
        state = runner.get(bbk.STATE, "")
        if self._tree_changed or state != self._last_state or tick.clock - self._last_print >= self.every_s:
            print(line, file=self.stream, flush=True)
            self._last_state = state
            self._last_print = tick.clock
            self._tree_changed = False

    def on_tree(self, runner: Any) -> None:
        self._tree_changed = True  # a log says so at the next tick (a terminal's line shows it anyway)

    def on_end(self, runner: Any, outcome: Any) -> None:
        if self._live is not None:
            self._live.stop()
            self._live = None
