"""Fault injection for simulated runs: what a robot in the field gets wrong, on purpose and repeatably.

A scenario's ``faults:`` section (validated in sim/scenario.py, settable through a mission config's
``sim:`` overrides like any scenario key) switches them on::

    faults:
      camera_blackout: [{at_s: 20, frames: 30}]      # no frames at all for 30 camera periods
      frame_drop_prob: 0.2                            # each frame lost with this probability
      frame_duplicate_prob: 0.1                       # … or delivered twice (same image, same stamp)
      late_frame_prob: 0.1                            # … or held back and delivered late_by_s later,
      late_by_s: 0.5                                  #     with its original (older) stamp: out of order
      lidar_dropout: [{at_s: 10, duration_s: 3}]      # no scans (the navigator keeps the last one)
      target_teleport: [{at_s: 45, skip_s: 8}]        # the target jumps 8 s ahead along its path
      robot_kick: [{at_s: 15, dx: 0.3, dy: -0.2, dyaw_deg: 40}]   # the robot is bumped off its path
      plugin_raise_every: 5                           # every source raises on every 5th frame
      plugin_raise_source: null                       #   (or only the one with this name)
      vlm: {mode: timeout, every: 1}                  # the VLM client times out / returns garbage

The sim side (camera, lidar, target, robot) is :class:`FaultInjector`, driven by ``SimAdapter``; the
perception side wraps the sources the runner created (:func:`wrap_sources`): :class:`FaultySource` raises
on every k-th frame, and a VLM source's model client is replaced by :class:`FaultyVlmClient`. Everything
injected is counted in ``FaultInjector.injected`` so a report can set it beside what the system counted.
Random choices come from their own seeded stream: a run with the same seed injects the same faults.
"""

from __future__ import annotations

import math
import time
from collections import Counter
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from mission.core.types import Detection, Frame


@dataclass
class _Pending:
    due: float
    frame: Frame
    first: bool  # late frames and duplicates take the next slot (the fresh frame waits a tick)


@dataclass
class FaultInjector:
    """The sim-side faults of one run. ``spec`` is a validated ``mission.sim.scenario.Faults``."""

    spec: Any
    seed: int = 0
    injected: Counter[str] = field(default_factory=Counter)

    def __post_init__(self) -> None:
        self._rng = np.random.default_rng(np.random.SeedSequence([self.seed, 0xFA017]))
        self._queue: list[_Pending] = []
        self._blackout_left: dict[int, int] = {}
        self._fired: set[tuple[str, int]] = set()
        self.max_scan_gap_s = 0.0
        self.max_frame_gap_s = 0.0  # longest time without a delivered frame
        self._last_delivery: float | None = None
        self._last_scan_t: float | None = None

    @property
    def active(self) -> bool:
        return self.spec is not None and self.spec != type(self.spec)()  # anything not at its default

    # -- camera --------------------------------------------------------------------------------------
    def _in_blackout(self, t: float) -> bool:
        for i, b in enumerate(self.spec.camera_blackout):
            if t + 1e-9 >= b.at_s:
                left = self._blackout_left.setdefault(i, b.frames)
                if left > 0:
                    self._blackout_left[i] = left - 1
                    return True
        return False

    def camera(self, frame: Frame | None, t: float) -> Frame | None:
        """The frame delivered at time t (the one captured now, if any, has gone through the faults).

        At most one frame per tick, as from a camera topic with queue depth 1: a late frame due now
        takes the slot (the fresh one waits a tick); of several fresh frames waiting only the newest
        survives (the others count as ``frames_superseded``).
        """
        s = self.spec
        if frame is not None:
            if self._in_blackout(t):
                self.injected["camera_blackout_frames"] += 1
            elif s.frame_drop_prob > 0 and self._rng.random() < s.frame_drop_prob:
                self.injected["frames_dropped"] += 1
            elif s.late_frame_prob > 0 and self._rng.random() < s.late_frame_prob:
                self.injected["frames_late"] += 1
                self._queue.append(_Pending(t + s.late_by_s, frame, True))
            else:
                self._queue.append(_Pending(t, frame, False))
                if s.frame_duplicate_prob > 0 and self._rng.random() < s.frame_duplicate_prob:
                    self.injected["frames_duplicated"] += 1
                    self._queue.append(_Pending(t + 1e-6, frame, True))  # again in the next tick's slot
        due = [p for p in self._queue if p.due <= t + 1e-9]
        if not due:
            return None
        if self._last_delivery is not None:
            self.max_frame_gap_s = max(self.max_frame_gap_s, t - self._last_delivery)
        self._last_delivery = t
        first = [p for p in due if p.first]
        if first:
            pick = min(first, key=lambda p: p.due)
        else:  # fresh frames only: deliver the newest, as a depth-1 queue would
            pick = due[-1]
            for p in due[:-1]:
                self._queue.remove(p)
                self.injected["frames_superseded"] += 1
        self._queue.remove(pick)
        return pick.frame

    # -- lidar ---------------------------------------------------------------------------------------
    def lidar_out(self, t: float) -> bool:
        """True while a lidar dropout window is open (the scan is not taken)."""
        out = any(d.at_s <= t < d.at_s + d.duration_s for d in self.spec.lidar_dropout)
        if out:
            self.injected["scans_dropped"] += 1
        else:
            if self._last_scan_t is not None:
                self.max_scan_gap_s = max(self.max_scan_gap_s, t - self._last_scan_t)
            self._last_scan_t = t
        return out

    # -- one-shot events -----------------------------------------------------------------------------
    def _due(self, kind: str, events: list[Any], t: float) -> list[Any]:
        out = []
        for i, ev in enumerate(events):
            if t + 1e-9 >= ev.at_s and (kind, i) not in self._fired:
                self._fired.add((kind, i))
                out.append(ev)
        return out

    def target_skip(self, t: float) -> float:
        """Seconds of path the target jumps ahead now (0 when no teleport is due)."""
        skip = 0.0
        for ev in self._due("teleport", self.spec.target_teleport, t):
            self.injected["target_teleports"] += 1
            skip += ev.skip_s
        return skip

    def robot_kicks(self, t: float) -> list[tuple[float, float, float]]:
        """(dx, dy, dyaw rad) in the map frame for every kick due now."""
        out = []
        for ev in self._due("kick", self.spec.robot_kick, t):
            self.injected["robot_kicks"] += 1
            out.append((ev.dx, ev.dy, math.radians(ev.dyaw_deg)))
        return out

    def report(self) -> dict[str, Any]:
        """What was injected (counts), for report.json."""
        out: dict[str, Any] = dict(sorted(self.injected.items()))
        out["max_frame_gap_s"] = round(self.max_frame_gap_s, 3)
        if self.spec is not None and self.spec.lidar_dropout:
            out["max_scan_gap_s"] = round(self.max_scan_gap_s, 3)
        return out


# --------------------------------------------------------------------------------------------------
# perception-side faults
# --------------------------------------------------------------------------------------------------


class InjectedFault(RuntimeError):
    """What a faulty source raises (a plugin bug stand-in)."""


class FaultySource:
    """A perception source that raises on every k-th frame and otherwise is the source it wraps."""

    def __init__(self, inner: Any, every: int, injected: Counter[str]) -> None:
        self.inner = inner
        self.every = int(every)
        self.name = str(getattr(inner, "name", None) or type(inner).__name__)
        self.description = getattr(inner, "description", "")
        self._calls = 0
        self._injected = injected

    def process(self, frame: Frame) -> list[Detection]:
        self._calls += 1
        if self._calls % self.every == 0:
            self._injected[f"plugin_raises:{self.name}"] += 1
            raise InjectedFault(f"injected fault on frame call {self._calls} (every {self.every}th)")
        return self.inner.process(frame)  # type: ignore[no-any-return]

    def close(self) -> None:
        self.inner.close()

    def __getattr__(self, item: str) -> Any:  # status(), reset_latch(), counters … of the wrapped source
        return getattr(self.inner, item)


@dataclass(frozen=True)
class GarbagePoint:
    """Shaped like a VLM answer point, with values no model should return."""

    y: float
    x: float
    confidence: float

    def to_pixel(self, width: int, height: int) -> tuple[float, float]:
        return self.x / 1000.0 * width, self.y / 1000.0 * height


class FaultyVlmClient:
    """A VLM client (perception_plugins/vlm/client.py's VlmClient shape) that, on every k-th call, times
    out (raises TimeoutError after ``delay_s``, as a real HTTP client with a request timeout does) or
    answers garbage (NaN / out-of-image points, a non-list); other calls go to the wrapped client."""

    def __init__(self, inner: Any, mode: str, every: int, injected: Counter[str], delay_s: float = 0.0) -> None:
        self.inner = inner
        self.mode = mode
        self.every = int(every)
        self.delay_s = float(delay_s)
        self._calls = 0
        self._injected = injected

    def locate(self, image: np.ndarray, label: str) -> Any:
        self._calls += 1
        if self._calls % self.every != 0:
            return self.inner.locate(image, label)
        if self.mode == "timeout":
            self._injected["vlm_timeouts"] += 1
            if self.delay_s > 0:
                time.sleep(self.delay_s)  # on the source's worker thread, never the tick
            raise TimeoutError(f"VLM request timed out (injected, call {self._calls})")
        self._injected["vlm_garbage"] += 1
        kind = self._calls // self.every % 3
        if kind == 0:
            return "I'm sorry, I cannot help with that"  # not a list of points
        if kind == 1:
            return [GarbagePoint(float("nan"), float("nan"), 0.9)]
        return [GarbagePoint(-4000.0, 99999.0, 7.5)]  # far outside the image, confidence > 1

    def close(self) -> None:
        self.inner.close()

    def __getattr__(self, item: str) -> Any:  # usage (the cost accounting), last_note … of the wrapped client
        if item == "inner":
            raise AttributeError(item)
        return getattr(self.inner, item)


def wrap_sources(sources: list[Any], spec: Any, injected: Counter[str]) -> None:
    """Put the perception-side faults of ``spec`` around the runner's sources, in place (the tree holds
    the same list). A VLM source is recognised by its model client attribute ``_client``."""
    if spec is None:
        return
    for i, src in enumerate(sources):
        if spec.vlm is not None and hasattr(src, "_client"):
            src._client = FaultyVlmClient(src._client, spec.vlm.mode, spec.vlm.every, injected, spec.vlm.delay_s)
        name = str(getattr(src, "name", None) or type(src).__name__)
        if spec.plugin_raise_every and spec.plugin_raise_source in (None, name):
            sources[i] = FaultySource(src, spec.plugin_raise_every, injected)


COUNTED_STATS = ("frames_processed", "frames_stale", "frames_duplicate", "frames_dropped", "detections_invalid")


def fault_summary(injector: FaultInjector, perception_stats: dict[str, int], sources: list[Any]) -> dict[str, Any]:
    """report.json's ``faults``: what was injected beside what the system counted (empty without faults)."""
    if not injector.active:
        return {}
    counted: dict[str, Any] = {
        k: v for k, v in sorted(perception_stats.items()) if k in COUNTED_STATS or k.startswith("source_errors:")
    }
    for src in sources:
        inner = getattr(src, "inner", src)
        if hasattr(inner, "_client") and isinstance(getattr(inner, "counters", None), Counter):
            name = str(getattr(inner, "name", "vlm"))
            counted.update({f"{name}:{k}": v for k, v in sorted(inner.counters.items())})
    return {"injected": injector.report(), "counted": counted}
