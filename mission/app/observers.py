"""What watches a run: the live terminal, the tick log, the web view, recordings, metrics, the ROS outputs.

One protocol for every world. The runner (mission/app/runner.py) calls, in order of attachment:

* ``on_start(run)`` once, after set-up and before the first step;
* ``on_perception(run, perceived)`` after the perception stage processed (or dropped) a frame — inside a
  step, or when the ROS node perceives an image as it arrives;
* ``on_tick(run, tick)`` after every step (sense → perceive → tick → act);
* ``on_end(run, outcome)`` once, when the run ends for any reason (finished, interrupted, crashed:
  ``outcome`` is then None), so recordings are always finalized.

An observer never changes what the tree does: it reads the runner (``run.get(key)``, ``run.world``,
``run.snapshot()``). Subclass :class:`RunObserver` and override what you need.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import py_trees

if TYPE_CHECKING:
    from mission.app.runner import TreeRunner
    from mission.perception_plugins.pipeline import Perceived


@dataclass(frozen=True)
class Tick:
    """One step of the loop as observers see it."""

    index: int  # steps so far, this one included
    clock: float  # the world's time after sensing (sim or ROS time), seconds
    status: py_trees.common.Status  # the root's status after the tick (INVALID when perception only)
    ground_truth: Any = None  # what the world really is, when it knows (the simulation): metrics, pictures
    perceived: Perceived | None = None  # the frame this step perceived, if a new one arrived


class RunObserver:
    """Base of every observer: each hook does nothing unless overridden."""

    def on_start(self, run: TreeRunner) -> None:
        """The run is set up; the first step follows."""

    def on_perception(self, run: TreeRunner, perceived: Perceived) -> None:
        """The perception stage has finished with a frame."""

    def on_tick(self, run: TreeRunner, tick: Tick) -> None:
        """One step is done."""

    def on_end(self, run: TreeRunner, outcome: Any) -> None:
        """The run is over (``outcome`` as the caller evaluated it, or None)."""
