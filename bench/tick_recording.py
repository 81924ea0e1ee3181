"""A live simulated mission, recorded tick by tick: the inputs the tree saw and what each tick cost.

Shared by the `tree` benchmark (which replays the inputs into a fresh tree and a bare py_trees tree of
the same shape) and the `latency` benchmark (frame on the blackboard → command on the blackboard, and
the detector's own time on the same frames). Recorded once per process and reused.

The loop is TreeRunner's (``sense → tree.tick → act → advance``, the code path of ``mission run``),
opened up so the parts can be timed separately. Perception sources are wrapped to time each
``process`` call and to keep its detections, keyed by the frame's stamp.
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from mission.app.runner import TreeRunner
from mission.app.sim_run import DEFAULT_SIM_CONFIG, choose_tree, shipped_config
from mission.core import blackboard as bbk
from mission.core.types import Detection, Frame
from mission.perception_plugins import registry
from mission.sim.adapter import SimAdapter
from mission.sim.config import apply_overrides
from mission.sim.scenario import load_scenario

# What a world adapter writes in sense(): the tree's inputs.
INPUT_KEYS = (bbk.CLOCK, bbk.ROBOT_STATE, bbk.CAMERA_EXTRINSICS, bbk.MAP, bbk.NAV_STATUS, bbk.FRAME, bbk.FRAME_SEQ,
              bbk.SCAN)  # fmt: skip
TINY = np.zeros((8, 8, 3), np.uint8)


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


@dataclass
class TickRecord:
    inputs: dict[str, Any]  # blackboard key path → value after sense() (frames shrunk to 8×8)
    new_frame: bool
    frame_stamp: float | None
    tick_s: float  # tree.tick() wall time (perception included: it runs inside the tree)
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


_CACHE: dict[tuple[str, float, int], Recording] = {}


def record(scenario_name: str = "mission_full", seconds: float = 20.0, seed: int = 0) -> Recording:
    """Run `scenario_name` for `seconds` of sim time with the default sim config, timing every tick."""
    key = (scenario_name, seconds, seed)
    if key in _CACHE:
        return _CACHE[key]
    from mission.core.config import load_config

    config_path = shipped_config(DEFAULT_SIM_CONFIG)
    config = load_config(config_path)
    scenario = apply_overrides(load_scenario(scenario_name), config.sim, file=str(config_path))
    adapter = SimAdapter(scenario, seed=seed)
    sources = [TimedSource(s) for s in registry.create_all(config.perception.sources, file=str(config_path))]
    tree = choose_tree(None, config, scenario)
    runner = TreeRunner(config, adapter, tree, config_file=config_path, sources=sources)
    rec = Recording(scenario_name, seed, tree, config_path.name)
    dt = 1.0 / config.run.tick_hz
    wall0 = time.perf_counter()
    runner.setup()
    try:
        assert runner.tree is not None
        last_seq = None
        while adapter.t < seconds:
            adapter.sense(runner.bb)
            seq = bbk.get(runner.bb, bbk.FRAME_SEQ)
            frame = bbk.get(runner.bb, bbk.FRAME)
            new = seq != last_seq and frame is not None
            last_seq = seq
            t0 = time.perf_counter()
            runner.tree.tick()
            tick_s = time.perf_counter() - t0
            det_s = None
            if new:
                det_s = sum(s.calls[float(frame.stamp)][0] for s in sources if float(frame.stamp) in s.calls)
            inputs = {}
            for k in INPUT_KEYS:
                v = bbk.get(runner.bb, k)
                if k is bbk.FRAME and isinstance(v, Frame):
                    v = dataclasses.replace(v, image=TINY, depth=None)
                inputs[k.path] = v
            twist, goal = bbk.get(runner.bb, bbk.TWIST), bbk.get(runner.bb, bbk.NAV_GOAL)
            command = "twist" if twist is not None else ("goal" if goal is not None else "none")
            rec.ticks.append(TickRecord(inputs, new, float(frame.stamp) if new else None, tick_s, det_s,
                                        str(bbk.get(runner.bb, bbk.STATE, "")), command))  # fmt: skip
            adapter.act(runner.bb)
            adapter.advance(dt)
    finally:
        runner.close()
        for s in sources:
            s.close()
    rec.wall_s = time.perf_counter() - wall0
    rec.detections = {s.name: {st: d for st, (_, d) in s.calls.items()} for s in sources}
    _CACHE[key] = rec
    return rec
