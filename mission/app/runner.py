"""The one loop every world runs: sense → perceive → tick → act → advance.

The simulation (`mission run`), replay and the benchmarks call :meth:`TreeRunner.run`; the ROS node
calls :meth:`TreeRunner.step` from its timer (and may call :meth:`TreeRunner.perceive` when an image
arrives). Nothing else writes this loop, so one tree behaves the same way in every world::

    runner = TreeRunner(config, world, observers=[...])
    runner.setup()                       # check the tree, create sources, build the tree, connect the world
    status = runner.run(until=60.0)      # steps until the tree finishes, 60 s of world time pass, or a signal
    runner.finish(outcome)               # observers' on_end (recordings finalized)
    runner.close()

One step: the world writes its newest inputs to the blackboard (``sense``); a new scan updates what the
lidar sees move (``/robot/movers``, core/movers.py); if a new frame arrived the
perception stage turns it into detections and tracks (``perceive``, perception_plugins/pipeline.py);
the tree ticks once; the world carries out the tree's commands (``act``); observers see the step.
Between steps a simulated world lets ``1 / run.tick_hz`` seconds pass (``advance``), optionally paced to
the wall clock.

SIGINT and SIGTERM during :meth:`run` end the loop after the current step (a second one stops at once):
the caller still evaluates, reports and finalizes what was measured so far, and exits 130 or 143.
"""

from __future__ import annotations

import contextlib
import logging
import signal
import threading
import time
from collections.abc import Callable, Iterator, Mapping
from pathlib import Path
from typing import Any, Protocol

import py_trees

from mission.app.behaviour_plugins import mission_factory
from mission.core import blackboard as bbk
from mission.core.config import MissionConfig
from mission.core.errors import TreeError
from mission.core.movers import MoverTracker
from mission.core.observers import RunObserver, Tick
from mission.core.perception import Perceived, PerceptionSource
from mission.core.snapshot import active_branch, snapshot
from mission.core.types import LaserScan, NavStatus, RobotState, Twist
from mission.core.world import WorldAdapter, waiting_for
from mission.perception_plugins import registry
from mission.perception_plugins.pipeline import PerceptionStage
from mission.trees import scopes
from mission.trees.factory import BehaviourFactory
from mission.trees.loader import check_targets, load_tree, resolve_tree_path, validate_tree

log = logging.getLogger(__name__)

STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM)
SETUP_TIMEOUT_S = 30.0  # the tree's setup() (py_trees raises when a behaviour's setup takes longer)


def failing_leaf(root: py_trees.behaviour.Behaviour) -> str:
    """Which leaf made a failed tree fail, and what it said: the last failed node in tick order that has no
    failed child (a Sequence's failing child; the last of a Fallback's), e.g.
    ``leaf 'see it' (IsTargetVisible) failed: port target: blackboard entry {tgt} was never written``."""
    failed = None
    for node in root.iterate():
        if node.status == py_trees.common.Status.FAILURE and not any(
            c.status == py_trees.common.Status.FAILURE for c in node.children
        ):
            failed = node
    if failed is None:
        return ""
    kind = "leaf" if not failed.children else "node"
    tag = type(failed).__name__
    said = str(getattr(failed, "feedback_message", "") or "").strip()
    return f"{kind} {failed.name!r} ({tag}) failed" + (f": {said}" if said else "")


def resolve_tree(tree: str, config_file: str | Path | None = None) -> Path:
    """A tree named in config: relative to the config file if it exists there, else a shipped tree."""
    if config_file is not None:
        candidate = Path(config_file).parent / tree
        if candidate.is_file():
            return candidate
    return resolve_tree_path(tree)


def checked_tree(
    config: MissionConfig, tree: str, factory: BehaviourFactory, config_file: str | Path | None = None
) -> Path:
    """The tree file a run of `config` uses, every check made (the file, its nodes and ports as `factory`
    builds them, the targets it names): what :meth:`TreeRunner.setup` does before anything heavy, and what
    a sweep does for every cell of its grid before any run starts. Raises TreeError."""
    try:
        path = resolve_tree(tree, config_file)
    except TreeError as err:
        if config_file is None or tree != config.tree:
            raise
        raise TreeError(f"{config_file}: tree: {err}") from None  # say which config named it
    validate_tree(path, factory)
    check_targets(path, config.perception.targets, factory)
    return path


class Pacer(Protocol):
    """How :meth:`TreeRunner.run` waits between steps (None: as fast as the machine goes)."""

    def wait(self, clock: float) -> None:
        """Return when the world's `clock` (seconds) is due on the wall clock."""


class WallClockPacer:
    """World time at `speed` × wall-clock time: a simulation you can watch, a bag at its recorded rate."""

    def __init__(self, speed: float = 1.0, should_stop: Callable[[], bool] = lambda: False) -> None:
        self.speed = max(1e-6, float(speed))
        self.should_stop = should_stop
        self._origin: tuple[float, float] | None = None  # (wall, world) at the first wait

    def wait(self, clock: float) -> None:
        now = time.monotonic()
        if self._origin is None:
            self._origin = (now, clock)
            return
        wall0, world0 = self._origin
        due = wall0 + (clock - world0) / self.speed
        while not self.should_stop() and (left := due - time.monotonic()) > 0:
            time.sleep(min(left, 0.1))  # short naps: a stop request is noticed within 0.1 s


Until = float | Callable[["TreeRunner"], bool] | None


class TreeRunner:
    """Owns the tree, the perception stage and the blackboard; borrows the world and the observers."""

    def __init__(
        self,
        config: MissionConfig,
        world: WorldAdapter,
        tree: str | None = None,
        *,
        config_file: str | Path | None = None,
        sources: list[PerceptionSource] | None = None,
        observers: list[RunObserver] | tuple[RunObserver, ...] = (),
        perception_only: bool = False,
    ) -> None:
        self.config = config
        self.world = world
        self.tree_name = tree or config.tree
        self.config_file = config_file
        self.perception_only = perception_only
        self.sources: list[PerceptionSource] = list(sources) if sources is not None else []
        self._own_sources = sources is None
        self.observers: list[RunObserver] = list(observers)
        self.tree_path: Path | None = None
        self.tree: py_trees.trees.BehaviourTree | None = None
        # the tree's first failure: which leaf failed and what it said ("" until the tree fails)
        self.failure = ""
        self.perception: PerceptionStage | None = None
        # The node types tree files may use: the shipped behaviours and installed packages' (entry-point
        # group mission.behaviours); register your own before setup().
        self.factory = mission_factory()
        self.bb = bbk.writer("runner")
        self.dt = 1.0 / float(config.run.tick_hz)
        self.ticks = 0
        self.movers = MoverTracker()
        self.status = py_trees.common.Status.INVALID
        self.start_clock: float | None = None
        self.stop_signal: int | None = None  # the signal that ended run(), if one did
        self._started = False
        self._finished = False

    # -- lifecycle ---------------------------------------------------------------------------------
    def setup(self) -> None:
        """Check the tree before anything heavy, then create sources, build the tree, connect the world."""
        if not self.perception_only:
            self.tree_path = checked_tree(self.config, self.tree_name, self.factory, self.config_file)
        if self._own_sources:
            file = None if self.config_file is None else str(self.config_file)
            self.sources = registry.create_all(self.config.perception.sources, file=file)
        perception = self.config.perception
        self.perception = PerceptionStage(self.sources, dict(perception.targets), perception.policy)
        self._seed_blackboard()
        if self.tree_path is not None:
            self.tree = self._built(self.tree_path, None)
        self.world.setup()
        self._started = True
        for o in self.observers:
            o.on_start(self)

    @staticmethod
    def _setup_timeout() -> float | py_trees.common.Duration:
        """py_trees arms its set-up timeout with a signal, which only the main thread may do; in another thread
        (a Dask worker runs each sweep run in one, rclpy an action server's callbacks) the tree is set up
        without it: the shipped behaviours' setup() is light wiring that never waits."""
        in_main = threading.current_thread() is threading.main_thread()
        return SETUP_TIMEOUT_S if in_main else py_trees.common.Duration.INFINITE

    def _built(self, path: Path, inputs: Mapping[str, Any] | None) -> py_trees.trees.BehaviourTree:
        tree = py_trees.trees.BehaviourTree(load_tree(path, self.factory, blackboard=inputs))
        tree.setup(timeout=self._setup_timeout())
        return tree

    # -- trees that come and go: an action server's goals ---------------------------------------------
    def start_tree(self, tree: str | Path, inputs: Mapping[str, Any] | None = None) -> Path:
        """Tick `tree` from the next step on, its root blackboard holding `inputs` (by their tree-file names):
        one goal of an action server. A tree already running is halted first and its commands withdrawn.
        The file is checked completely before anything stops; its path is returned. Observers hear of the
        new tree (``on_tree``)."""
        path = checked_tree(self.config, str(tree), self.factory, self.config_file)
        self._halt_tree()
        self.tree = self._built(path, inputs)
        self.tree_path = path
        self.status = py_trees.common.Status.INVALID
        for o in self.observers:
            o.on_tree(self)
        return path

    def stop_tree(self) -> None:
        """Halt the running tree (every running node's terminate), stop the robot and tick nothing until the
        next :meth:`start_tree`; perception goes on. Nothing happens when no tree runs."""
        if self.tree is None:
            return
        self._halt_tree()
        for o in self.observers:
            o.on_tree(self)

    def _halt_tree(self) -> None:
        if self.tree is None:
            return
        # py_trees' halt: every node not INVALID is stopped (a running one's terminate) and left INVALID.
        # (BehaviourTree.interrupt() only ends tick_tock(); it halts nothing.)
        self.tree.root.stop(py_trees.common.Status.INVALID)
        self.tree.shutdown()
        self.tree = None
        bbk.set_(self.bb, bbk.NAV_GOAL, None)
        bbk.set_(self.bb, bbk.TWIST, Twist(0.0, 0.0))

    def _seed_blackboard(self) -> None:
        assert self.perception is not None
        for key, value in (
            (bbk.NAV_GOAL, None),
            (bbk.TWIST, None),
            (bbk.NAV_STATUS, NavStatus.IDLE),
            (bbk.NAV_REASON, ""),
            (bbk.WORLD_FAULT, ""),
            (bbk.DOCK_SETPOINT, None),
            (bbk.STATE, ""),
            (bbk.REASON, ""),
            (bbk.TRACKS, self.perception.tracks),
            (bbk.DETECTIONS, []),
            (bbk.PERCEPTION_STATS, {}),
            (bbk.FRAME, None),
            (bbk.FRAME_SEQ, 0),
            (bbk.MOVERS, ()),
        ):
            bbk.set_(self.bb, key, value)

    def attach(self, observer: RunObserver) -> None:
        """Watch this run from now on (an observer attached after set-up starts at once)."""
        self.observers.append(observer)
        if self._started:
            observer.on_start(self)

    # -- one step ------------------------------------------------------------------------------------
    def perceive(self) -> Perceived | None:
        """The perception stage on the newest frame the world wrote (None when it was perceived already);
        observers are told. Safe to call more than once per step: the ROS node may call it on image arrival."""
        assert self.perception is not None, "call setup() first"
        perceived = self.perception.update(self.bb)
        if perceived is not None:
            for o in self.observers:
                o.on_perception(self, perceived)
        return perceived

    def step(self) -> py_trees.common.Status:
        """sense → track movers → perceive → tick → act, then the observers; returns the root's status."""
        assert self._started, "call setup() first"
        self.world.sense(self.bb)
        clock = float(bbk.get(self.bb, bbk.CLOCK, 0.0) or 0.0)
        self._track_movers(clock)
        waiting = waiting_for(self.world)  # a live robot whose camera or pose has not arrived yet: hold the tree
        if self.start_clock is None and not waiting:
            self.start_clock = clock
        perceived = self.perceive()
        if self.tree is not None and not waiting:
            self.tree.tick()
            self.status = self.tree.root.status
            if self.status == py_trees.common.Status.FAILURE and not self.failure:
                self.failure = failing_leaf(self.tree.root)
        self.world.act(self.bb)
        self.ticks += 1
        truth = getattr(self.world, "ground_truth", None)
        tick = Tick(self.ticks, clock, self.status, truth() if callable(truth) else None, perceived)
        for o in self.observers:
            o.on_tick(self, tick)
        return self.status

    def _track_movers(self, clock: float) -> None:
        """What the lidar sees move, for the tree to plan round (a new scan only; none without a pose)."""
        scan: LaserScan | None = bbk.get(self.bb, bbk.SCAN, None)
        state: RobotState | None = bbk.get(self.bb, bbk.ROBOT_STATE, None)
        if scan is not None and state is not None:
            movers = self.movers.update(scan, state.pose, bbk.get(self.bb, bbk.MAP, None), clock)
            bbk.set_(self.bb, bbk.MOVERS, movers)

    def elapsed(self) -> float:
        """World seconds since the first step."""
        if self.start_clock is None:
            return 0.0
        return float(bbk.get(self.bb, bbk.CLOCK, 0.0) or 0.0) - self.start_clock

    # -- the loop ------------------------------------------------------------------------------------
    def run(self, until: Until = None, pacer: Pacer | None = None) -> py_trees.common.Status:
        """Step until the tree finishes, `until` (world seconds, or a predicate) is reached, the world is
        exhausted (a bag at its end) or SIGINT/SIGTERM arrives; returns the root's last status."""
        done = until if callable(until) else (lambda r: until is not None and r.elapsed() >= until)
        running = py_trees.common.Status.RUNNING
        with self._stop_on_signals():
            while True:
                status = self.step()
                if self.tree is not None and status != running:
                    break
                if self.stop_signal is not None or done(self) or getattr(self.world, "exhausted", False):
                    break
                self.world.advance(self._step_towards(until))
                if getattr(self.world, "exhausted", False):
                    break
                if pacer is not None:
                    pacer.wait(float(self.world.now()))
        return self.status

    def _step_towards(self, until: Until) -> float:
        """The world time to advance: a tick, or less when a time limit falls inside it, so a tick slower than
        the limit (``--max-duration 3`` at 0.2 Hz) ends the run at the limit, not a whole tick later. A limit
        that a whole number of ticks reaches (up to rounding) keeps whole ticks, as it always did."""
        if until is None or callable(until):
            return self.dt
        remaining = float(until) - self.elapsed()
        return remaining if 1e-6 < remaining < self.dt - 1e-9 else self.dt

    def stop_requested(self) -> bool:
        return self.stop_signal is not None

    @contextlib.contextmanager
    def _stop_on_signals(self) -> Iterator[None]:
        """SIGINT/SIGTERM end the loop after the current step; a second one interrupts at once."""
        if threading.current_thread() is not threading.main_thread():
            yield
            return

        def handler(signum: int, _frame: Any) -> None:
            if self.stop_signal is not None:  # asked twice: stop now
                raise KeyboardInterrupt
            self.stop_signal = signum
            log.warning("%s: stopping after this step (again to stop at once)", signal.Signals(signum).name)

        previous = {s: signal.signal(s, handler) for s in STOP_SIGNALS}
        try:
            yield
        finally:
            for s, h in previous.items():
                signal.signal(s, h)

    def finish(self, outcome: Any = None) -> None:
        """Tell every observer the run is over (once). Each observer ends even if another one fails."""
        if self._finished or not self._started:
            return
        self._finished = True
        errors: list[BaseException] = []
        for o in self.observers:
            try:
                o.on_end(self, outcome)
            except Exception as err:  # finalize the others, then report the first failure
                errors.append(err)
        if errors:
            raise errors[0]

    def close(self) -> None:
        """Finish (if nobody did), shut the tree down, close the sources (when ours) and the world."""
        try:
            self.finish(None)
        finally:
            if self.tree is not None:
                self.tree.shutdown()
            if self._own_sources:
                for s in self.sources:
                    s.close()
            self.world.close()

    # -- what viewers read -------------------------------------------------------------------------
    @property
    def root(self) -> py_trees.behaviour.Behaviour:
        assert self.tree is not None, "no tree: call setup() first (or this runner perceives only)"
        return self.tree.root

    def snapshot(self) -> dict[str, Any]:
        """The tree with statuses and feedback, the mission state and perception's last line (JSON)."""
        last = self.perception.last if self.perception is not None else None
        return {
            "tick": self.ticks,
            "clock": bbk.get(self.bb, bbk.CLOCK, 0.0),
            "state": bbk.get(self.bb, bbk.STATE, ""),
            "perception": last.summary if last is not None else "",
            "tree": snapshot(self.root) if self.tree is not None else None,
        }

    def active_branch(self) -> list[str]:
        return active_branch(self.root) if self.tree is not None else []

    def tree_entry(self, name: str, default: Any = None) -> Any:
        """An entry of the tree's root blackboard by its tree-file name (``{attempt}``), or `default` when the
        tree never wrote it: what an action server reports of the goal's tree (its retries)."""
        path = scopes.Scope().entry_path(name)
        return scopes.read(path) if scopes.exists(path) else default

    def get(self, key: bbk.Key, default: Any = None) -> Any:
        return bbk.get(self.bb, key, default)
