"""What watches a run: the live terminal, the tick log, the web view, recordings, metrics, the ROS outputs.

One protocol for every world. The runner (mission/app/runner.py) calls, in order of attachment:

* ``on_start(run)`` once, after set-up and before the first step;
* ``on_tree(run)`` when the run's tree is replaced or stopped (an action server's goal starts or ends;
  ``run.tree`` is then the new tree, or None);
* ``on_perception(run, perceived)`` after the perception stage processed (or dropped) a frame — inside a
  step, or when the ROS node perceives an image as it arrives;
* ``on_tick(run, tick)`` after every step (sense → perceive → tick → act);
* ``on_end(run, outcome)`` once, when the run ends for any reason (finished, interrupted, crashed:
  ``outcome`` is then None), so recordings are always finalized.

An observer never changes what the tree does: it reads the run (:class:`Run`: ``run.get(key)``,
``run.world``, ``run.snapshot()``). Subclass :class:`RunObserver` and override what you need.

The protocol lives in the foundation, as the world and perception contracts do, because the floors that
implement it — the run itself (metrics, the live terminal), Groot2's monitor, the pictures, the ROS outputs —
must not import each other to share it.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol

import py_trees

if TYPE_CHECKING:
    from mission.core.blackboard import Key
    from mission.core.config import MissionConfig
    from mission.core.perception import Perceived
    from mission.core.world import WorldAdapter


class Run(Protocol):
    """What an observer may read of the run it watches. The runner (mission/app/runner.py, TreeRunner) is
    the one implementation; observers are written against this, so they need nothing above the foundation."""

    config: MissionConfig
    world: WorldAdapter
    tree: py_trees.trees.BehaviourTree | None  # None when the run is perception only
    tree_path: Path | None  # the tree file, when the tree came from one
    factory: Any  # the trees floor's BehaviourFactory the tree was built with (Groot2's palette)

    @property
    def root(self) -> py_trees.behaviour.Behaviour: ...

    def snapshot(self) -> dict[str, Any]: ...

    def get(self, key: Key, default: Any = None) -> Any: ...


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

    def on_start(self, run: Run) -> None:
        """The run is set up; the first step follows."""

    def on_tree(self, run: Run) -> None:
        """The run's tree was replaced (``run.tree``, ``run.tree_path``) or stopped (``run.tree`` is None)."""

    def on_perception(self, run: Run, perceived: Perceived) -> None:
        """The perception stage has finished with a frame."""

    def on_tick(self, run: Run, tick: Tick) -> None:
        """One step is done."""

    def on_end(self, run: Run, outcome: Any) -> None:
        """The run is over (``outcome`` as the caller evaluated it, or None)."""
