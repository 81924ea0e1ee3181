"""A live simulated mission, recorded tick by tick: the inputs the tree saw and what each step cost.

Shared by the `tree` benchmark (which replays the inputs into a fresh tree and a bare py_trees tree of
the same shape) and the `latency` benchmark (frame on the blackboard → command on the blackboard, and
the detector's own time on the same frames). Recorded once per process and reused.

The loop is the runner's own (``TreeRunner.run``, the code path of ``mission run``); nothing here
re-writes it. It is watched from the edges: the world is wrapped to note when ``sense()`` returned,
py_trees' pre/post tick handlers time ``tree.tick()`` alone, perception sources are wrapped to time each
``process`` call and keep its detections by frame stamp, and an observer keeps each tick's inputs.
"""

from __future__ import annotations

import copy
import time
from dataclasses import dataclass, field
from typing import Any

from mission.app.runner import TreeRunner
from mission.app.sim_run import DEFAULT_SIM_CONFIG, choose_tree, shipped_config
from mission.core import blackboard as bbk
from mission.core.observers import RunObserver, Tick
from mission.core.types import Detection, Frame
from mission.perception_plugins import registry
from mission.sim.scenario import load_scenario
from mission.sim.scenario_overrides import apply_overrides
from mission.sim.sim_adapter import SimAdapter

# What the tree reads: written by the world in sense() and, for the tracks, by the perception stage.
INPUT_KEYS = (bbk.CLOCK, bbk.ROBOT_STATE, bbk.CAMERA_EXTRINSICS, bbk.MAP, bbk.NAV_STATUS, bbk.SCAN, bbk.TRACKS)


class TimedSource:
    """A perception source wrapper: the real source's output, plus how long each call took."""

    def __init__(self, inner: Any) -> None:
        self.inner = inner
        self.name = getattr(inner, "name", type(inner).__name__)
        self.description = getattr(inner, "description", "")
        self.calls: dict[float, tuple[float, list[Detection]]] = {}  # stamp → (seconds, detections)

    def process(self, frame: Frame) -> list[Detection]:
        t0 = time.perf_counter()
        dets = self.inner.process(frame)
        self.calls[float(frame.stamp)] = (time.perf_counter() - t0, list(dets))
        return dets

    def close(self) -> None:
        self.inner.close()


class SensedWorld:
    """The sim adapter, noting the wall time at which each sense() returned (the frame is on the board)."""

    def __init__(self, inner: SimAdapter) -> None:
        self.inner = inner
        self.sensed_at = 0.0

    def sense(self, bb: Any) -> None:
        self.inner.sense(bb)
        self.sensed_at = time.perf_counter()

    def __getattr__(self, name: str) -> Any:  # setup, act, advance, now, ground_truth, close: the sim's own
        return getattr(self.inner, name)


@dataclass
class TickRecord:
    inputs: dict[str, Any]  # blackboard key path → value the tree saw (INPUT_KEYS)
    new_frame: bool
    frame_stamp: float | None
    tick_s: float  # tree.tick() wall time alone (perception runs before it, as a stage)
    e2e_s: float  # end of sense() → end of tree.tick(): perception + tick, the step's reaction time
    detector_s: float | None  # the sources' process() time on this tick's frame
    state: str
    command: str  # which command the tick left on the blackboard: goal / twist / none


@dataclass
class Recording:
    scenario: str
    seed: int
    tree: str
    config: str
    ticks: list[TickRecord] = field(default_factory=list)
    detections: dict[str, dict[float, list[Detection]]] = field(default_factory=dict)  # source → stamp → dets
    wall_s: float = 0.0


class _Recorder(RunObserver):
    """Keeps each tick's inputs (as the tree saw them) and the step's timings."""

    def __init__(self, rec: Recording, world: SensedWorld, sources: list[TimedSource]) -> None:
        self.rec, self.world, self.sources = rec, world, sources
        self._inputs: dict[str, Any] = {}
        self._tick_start = self._tick_end = 0.0

    def on_start(self, run: TreeRunner) -> None:
        assert run.tree is not None
        run.tree.add_pre_tick_handler(lambda _tree: self._before_tick(run))
        run.tree.add_post_tick_handler(lambda _tree: self._after_tick())

    def _before_tick(self, run: TreeRunner) -> None:
        # the tracks are copied: the stage updates them in place on the next frame
        self._inputs = {k.path: copy.deepcopy(run.get(k)) if k is bbk.TRACKS else run.get(k) for k in INPUT_KEYS}
        self._tick_start = time.perf_counter()

    def _after_tick(self) -> None:
        self._tick_end = time.perf_counter()

    def on_tick(self, run: TreeRunner, tick: Tick) -> None:
        frame = tick.perceived.frame if tick.perceived is not None and tick.perceived.processed else None
        stamp = None if frame is None else float(frame.stamp)
        det_s = None
        if stamp is not None:
            det_s = sum(s.calls[stamp][0] for s in self.sources if stamp in s.calls)
        twist, goal = run.get(bbk.TWIST), run.get(bbk.NAV_GOAL)
        command = "twist" if twist is not None else ("goal" if goal is not None else "none")
        self.rec.ticks.append(
            TickRecord(
                self._inputs,
                frame is not None,
                stamp,
                self._tick_end - self._tick_start,
                self._tick_end - self.world.sensed_at,
                det_s,
                str(run.get(bbk.STATE, "")),
                command,
            )
        )


_CACHE: dict[tuple[str, float, int], Recording] = {}


def record(scenario_name: str = "mission_full", seconds: float = 20.0, seed: int = 0) -> Recording:
    """Run `scenario_name` for `seconds` of sim time with the default sim config, timing every step."""
    key = (scenario_name, seconds, seed)
    if key in _CACHE:
        return _CACHE[key]
    from mission.core.config import load_config

    config_path = shipped_config(DEFAULT_SIM_CONFIG)
    config = load_config(config_path)
    scenario = apply_overrides(load_scenario(scenario_name), config.sim, file=str(config_path))
    world = SensedWorld(SimAdapter(scenario, seed=seed))
    sources = [TimedSource(s) for s in registry.create_all(config.perception.sources, file=str(config_path))]
    tree = choose_tree(None, config, scenario)
    rec = Recording(scenario_name, seed, tree, config_path.name)
    runner = TreeRunner(
        config, world, tree, config_file=config_path, sources=list(sources), observers=[_Recorder(rec, world, sources)]
    )
    wall0 = time.perf_counter()
    try:
        runner.setup()
        runner.run(until=seconds)
    finally:
        runner.close()
        for s in sources:
            s.close()
    rec.wall_s = time.perf_counter() - wall0
    rec.detections = {s.name: {st: d for st, (_, d) in s.calls.items()} for s in sources}
    _CACHE[key] = rec
    return rec
