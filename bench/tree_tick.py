"""Benchmark: what one tick of the shipped mission tree costs, against a bare py_trees tree of its shape.

Inputs are scripted: a live `mission_full` run (bench/tick_recording.py) is recorded tick by tick —
everything the tree reads from the blackboard (what the sim adapter wrote, and the tracks the
perception stage kept). The replay feeds those inputs to a fresh ``mission.xml`` (built by the real
loader, stepped by the real TreeRunner with a replaying world, so no detector and no renderer runs)
and, tick for tick, to a *bare* tree: the same composites and decorators (py_trees classes, same memory
flags) with leaves that do nothing but return the status the real leaf returned on that tick; and, in a
third pass, to the real leaves themselves under py_trees' composites and py_trees' own tick. Only
``py_trees.trees.BehaviourTree.tick`` is timed (pre/post tick handlers), on the same machine load.
Perception is a stage before the tick and is not in it.

Target: ratio ≤ 1.2 against the py_trees tree with the same leaves — the price of the tree machinery
(loader, BT.CPP semantics, ports, SubTrees) over py_trees' doing the same work. Against the status-only
tree the ratio is that plus the leaves' own work (blackboard reads, goal smoothing, the dock's control
law, raytraces), which a bare leaf does not do by construction; it is reported beside it.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import py_trees
from py_trees.common import Status

from bench.common import Figure, pct, progress
from bench.tick_recording import Recording, record
from mission.app.runner import TreeRunner
from mission.app.sim_run import shipped_config
from mission.core import blackboard as bbk
from mission.core.config import load_config
from mission.core.observers import RunObserver, Tick
from mission.trees import decorators

TARGET = 1.2


class ReplayWorld:
    """A WorldAdapter whose sense() writes the recorded inputs of tick `i`; advance() moves to the next."""

    def __init__(self, rec: Recording) -> None:
        self.rec = rec
        self.i = 0
        self.exhausted = not rec.ticks

    def setup(self) -> None:
        pass

    def sense(self, bb: py_trees.blackboard.Client) -> None:
        for path, value in self.rec.ticks[self.i].inputs.items():
            if value is not None:
                bb.set(path, value, overwrite=True)

    def act(self, bb: py_trees.blackboard.Client) -> None:
        pass

    def advance(self, dt: float) -> None:
        self.i += 1
        self.exhausted = self.i >= len(self.rec.ticks)

    def now(self) -> float:
        return float(self.rec.ticks[min(self.i, len(self.rec.ticks) - 1)].inputs.get(bbk.CLOCK.path) or 0.0)

    def close(self) -> None:
        pass


class TickTimer(RunObserver):
    """µs of each ``tree.tick()`` alone (py_trees' pre/post tick handlers), and each leaf's status after it."""

    def __init__(self) -> None:
        self.us: list[float] = []
        self.leaves: list[py_trees.behaviour.Behaviour] = []
        self.scripts: dict[int, list[Status]] = {}
        self.roots: list[Status] = []
        self.states: list[str] = []
        self._t0 = 0.0

    def on_start(self, run: TreeRunner) -> None:
        assert run.tree is not None
        self.leaves = _leaves(run.tree.root)
        self.scripts = {id(leaf): [] for leaf in self.leaves}
        run.tree.add_pre_tick_handler(self._before)
        run.tree.add_post_tick_handler(self._after)

    def _before(self, _tree: Any) -> None:
        self._t0 = time.perf_counter()

    def _after(self, _tree: Any) -> None:
        self.us.append((time.perf_counter() - self._t0) * 1e6)

    def on_tick(self, run: TreeRunner, tick: Tick) -> None:
        for leaf in self.leaves:
            self.scripts[id(leaf)].append(leaf.status)
        self.roots.append(tick.status)
        self.states.append(str(run.get(bbk.STATE, "")))


def _replay_tree(rec: Recording, observers: list[RunObserver]) -> TreeRunner:
    """mission.xml stepped by the runner over the recorded inputs (the caller closes it)."""
    config_path = shipped_config(rec.config)
    py_trees.blackboard.Blackboard.clear()
    runner = TreeRunner(
        load_config(config_path), ReplayWorld(rec), rec.tree, config_file=config_path, sources=[], observers=observers
    )
    runner.setup()
    runner.run()
    return runner


class _Clock:
    i = 0


class ScriptedLeaf(py_trees.behaviour.Behaviour):
    """A bare leaf: returns the status its real counterpart had after tick `clock.i`, and nothing else."""

    def __init__(self, name: str, script: list[Status], clock: type[_Clock]) -> None:
        super().__init__(name)
        self.script = script
        self.clock = clock

    def update(self) -> Status:
        s = self.script[self.clock.i]
        return Status.FAILURE if s == Status.INVALID else s


Leaf = Callable[[py_trees.behaviour.Behaviour], py_trees.behaviour.Behaviour]


def scripted(scripts: dict[int, list[Status]], clock: type[_Clock]) -> Leaf:
    """Leaves that replay `scripts[id(real leaf)]`: the bare tree."""
    return lambda leaf: ScriptedLeaf(leaf.name, scripts[id(leaf)], clock)


def py_trees_ticked(leaf: py_trees.behaviour.Behaviour) -> py_trees.behaviour.Behaviour:
    """The real leaf itself, ticked by py_trees' own ``Behaviour.tick`` (the loader's installed tick removed)."""
    leaf.__dict__.pop("tick", None)
    leaf.parent = None  # adopted by the mirror's composite
    return leaf


def bare_mirror(node: py_trees.behaviour.Behaviour, leaf: Leaf) -> py_trees.behaviour.Behaviour:
    """The same shape with py_trees' own composites and decorators; each leaf is ``leaf(real leaf)``."""
    comp, deco = py_trees.composites, py_trees.decorators
    if isinstance(node, comp.Composite):
        children = [bare_mirror(c, leaf) for c in node.children]
        if isinstance(node, comp.Parallel):
            return comp.Parallel(node.name, policy=node.policy, children=children)
        cls = comp.Sequence if isinstance(node, comp.Sequence) else comp.Selector
        return cls(node.name, memory=node.memory, children=children)
    if isinstance(node, deco.Decorator):
        child = bare_mirror(node.decorated, leaf)
        if isinstance(node, decorators.RetryUntilSuccessful):  # the loader's BT.CPP decorators → py_trees' own
            limit = int(node.input("num_attempts" if not isinstance(node, decorators.Repeat) else "num_cycles"))
            if isinstance(node, decorators.Repeat):
                return deco.Repeat(node.name, child, limit)
            return deco.Retry(node.name, child, limit)
        bare = {
            decorators.Inverter: deco.Inverter,
            decorators.ForceFailure: deco.SuccessIsFailure,
            decorators.ForceSuccess: deco.FailureIsSuccess,
        }
        base = next((bare[c] for c in type(node).__mro__ if c in bare), deco.PassThrough)
        return base(name=node.name, child=child)
    return leaf(node)


class PyTreesTicked(RunObserver):
    """Swaps the runner's tree for its mirror under py_trees' composites with the same leaf objects, before
    the first tick: the same leaves' work (the same blackboard, the same inputs), py_trees' tick around it."""

    def on_start(self, run: TreeRunner) -> None:
        assert run.tree is not None
        run.tree = py_trees.trees.BehaviourTree(bare_mirror(run.tree.root, py_trees_ticked))


def _leaves(root: py_trees.behaviour.Behaviour) -> list[py_trees.behaviour.Behaviour]:
    return [n for n in root.iterate() if not n.children and not isinstance(n, py_trees.decorators.Decorator)]


def _time_leaves(leaves: list[py_trees.behaviour.Behaviour], spent: dict[str, float]) -> None:
    """Wrap each leaf's update() to add its wall time to `spent[class name]` (the breakdown pass only)."""
    for leaf in leaves:
        inner, key = leaf.update, type(leaf).__name__

        def timed(inner: Any = inner, key: str = key) -> Status:
            t0 = time.perf_counter()
            try:
                return inner()  # type: ignore[no-any-return]
            finally:
                spent[key] = spent.get(key, 0.0) + time.perf_counter() - t0

        leaf.update = timed  # type: ignore[method-assign]


class _LeafTimer(RunObserver):
    def __init__(self, spent: dict[str, float]) -> None:
        self.spent = spent

    def on_start(self, run: TreeRunner) -> None:
        assert run.tree is not None
        _time_leaves(_leaves(run.tree.root), self.spent)


def leaf_breakdown(rec: Recording) -> dict[str, float]:
    """Mean µs per tick spent in each leaf class's update() over the recording (one extra pass)."""
    spent: dict[str, float] = {}
    _replay_tree(rec, [_LeafTimer(spent)]).close()
    py_trees.blackboard.Blackboard.clear()
    n = max(1, len(rec.ticks))
    return {k: round(v / n * 1e6, 1) for k, v in sorted(spent.items(), key=lambda kv: -kv[1])}


def replay(rec: Recording, passes: int) -> dict[str, Any]:
    """Tick the real tree on the recorded inputs, then the bare tree on the real leaves' statuses."""
    real_us: list[float] = []
    bare_us: list[float] = []
    same_us: list[float] = []
    n_nodes = 0
    state_match = root_match = same_match = total = 0
    for _ in range(passes):
        # Pass 1: the real tree, recording every leaf's status after each tick.
        timer = TickTimer()
        runner = _replay_tree(rec, [timer])
        assert runner.tree is not None
        n_nodes = sum(1 for _ in runner.tree.root.iterate())
        real_us.extend(timer.us)
        state_match += sum(s == t.state for s, t in zip(timer.states, rec.ticks, strict=False))
        total += len(timer.states)
        bare = py_trees.trees.BehaviourTree(bare_mirror(runner.tree.root, scripted(timer.scripts, _Clock)))
        runner.close()
        # Pass 2: the bare tree on the same tick sequence.
        for i in range(len(timer.roots)):
            _Clock.i = i
            t0 = time.perf_counter()
            bare.tick()
            bare_us.append((time.perf_counter() - t0) * 1e6)
            root_match += bare.root.status == timer.roots[i]
        # Pass 3: the same leaves under py_trees' composites, on the same inputs.
        same = TickTimer()
        _replay_tree(rec, [PyTreesTicked(), same]).close()
        same_us.extend(same.us)
        same_match += sum(s == t.state for s, t in zip(same.states, rec.ticks, strict=False))
    py_trees.blackboard.Blackboard.clear()
    return {
        "real_us": real_us,
        "bare_us": bare_us,
        "same_leaves_us": same_us,
        "nodes": n_nodes,
        "state_matches_live": round(state_match / max(1, total), 3),
        "same_leaves_state_matches_live": round(same_match / max(1, total), 3),
        "bare_root_status_matches": round(root_match / max(1, total), 3),
    }


def run(quick: bool, out: Path) -> dict[str, Any]:
    seconds, passes = (12.0, 2) if quick else (60.0, 5)
    rec = record("mission_full", seconds)
    progress(f"tree: recorded {len(rec.ticks)} ticks of mission_full in {rec.wall_s:.1f} s; replaying ×{passes}")
    r = replay(rec, passes)
    breakdown = leaf_breakdown(rec)
    real_med, bare_med = float(np.median(r["real_us"])), float(np.median(r["bare_us"]))
    same_med = float(np.median(r["same_leaves_us"]))
    real_mean, bare_mean = float(np.mean(r["real_us"])), float(np.mean(r["bare_us"]))
    structure = round(real_mean - sum(breakdown.values()), 1)
    states = {}
    for t in rec.ticks:
        states[t.state] = states.get(t.state, 0) + 1
    figures = [
        # The target's comparison: the tree alone, the leaves' own work on both sides. The mirror is the
        # same leaf objects under py_trees' Sequence/Selector/decorators, ticked by py_trees' generators.
        Figure(
            "mission.xml tick on scripted inputs vs the same leaves in a py_trees tree: median µs per tick",
            round(real_med, 1),
            "µs",
            baseline="the same leaves in a py_trees tree of the same shape (py_trees' composites, tick)",
            baseline_value=round(same_med, 1),
            ratio=round(real_med / same_med, 2),
            target=f"ratio ≤ {TARGET}",
            meets_target=real_med / same_med <= TARGET,
        ),
        Figure(
            "mission.xml tick on scripted inputs: median µs per tick",
            round(real_med, 1),
            "µs",
            baseline="bare py_trees tree of the same shape (leaves only return the real ones' statuses)",
            baseline_value=round(bare_med, 1),
            ratio=round(real_med / bare_med, 2),
        ),
        Figure(
            "mission.xml: median µs per node per tick",
            round(real_med / r["nodes"], 2),
            "µs",
            baseline="bare tree µs per node",
            baseline_value=round(bare_med / r["nodes"], 2),
            ratio=round(real_med / bare_med, 2),
        ),
        Figure(
            "mission.xml tick p99",
            pct(r["real_us"], 99, 1),
            "µs",
            baseline="bare tree p99",
            baseline_value=pct(r["bare_us"], 99, 1),
        ),
        # Where the ratio comes from: the tick minus the time inside the leaves' update() (the breakdown
        # pass) is the rest — composites, decorators, the leaves' initialise()/terminate(), py_trees' own
        # bookkeeping — against the bare tree, which has only that rest.
        Figure(
            "mission.xml tick minus its leaves' update() time: mean µs per tick",
            structure,
            "µs",
            baseline="bare tree mean µs per tick (composites + leaves that only return a status)",
            baseline_value=round(bare_mean, 1),
            ratio=round(structure / bare_mean, 2),
        ),
    ]
    return {
        "title": (
            "Tree tick cost: the shipped mission.xml vs py_trees trees of the same shape "
            "(the same leaves; leaves that do no work)"
        ),
        "figures": [f.to_json() for f in figures],
        "details": {
            "scenario": rec.scenario,
            "sim_seconds": seconds,
            "ticks": len(rec.ticks),
            "passes": passes,
            "nodes": r["nodes"],
            "ticks_in_state": states,
            "leaf_update_us_per_tick": breakdown,
            "replay_state_matches_live_run": r["state_matches_live"],
            "same_leaves_state_matches_live_run": r["same_leaves_state_matches_live"],
            "same_leaves_us_p50_p90_p99": [pct(r["same_leaves_us"], q, 1) for q in (50, 90, 99)],
            "bare_root_status_matches_real": r["bare_root_status_matches"],
            "real_us_mean": round(real_mean, 1),
            "bare_us_mean": round(bare_mean, 1),
            "leaf_update_us_per_tick_total": round(sum(breakdown.values()), 1),
            "real_us_p50_p90_p99": [pct(r["real_us"], q, 1) for q in (50, 90, 99)],
            "bare_us_p50_p90_p99": [pct(r["bare_us"], q, 1) for q in (50, 90, 99)],
        },
        "plots": [],
    }
