"""The followed target's motion: wait, turn towards the next waypoint, drive, pause — as a timeline.

The whole path is laid out once (with the seed's timing jitter) as segments over the target's own
progress clock, so its pose is a pure function of that clock: reproducible, cheap to query, and easy
to pause (the adapter stops the clock while the robot stands in the way, like a person waiting).
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np

from mission.core.se3 import wrap_angle
from mission.sim.scenario import MovingObstacle, TargetSpec


@dataclass(frozen=True)
class Segment:
    t0: float
    t1: float
    kind: str  # "wait" | "turn" | "move"
    x0: float
    y0: float
    yaw0: float
    x1: float
    y1: float
    yaw1: float

    def at(self, t: float) -> tuple[float, float, float]:
        f = 1.0 if self.t1 <= self.t0 else min(1.0, max(0.0, (t - self.t0) / (self.t1 - self.t0)))
        return (
            self.x0 + f * (self.x1 - self.x0),
            self.y0 + f * (self.y1 - self.y0),
            wrap_angle(self.yaw0 + f * wrap_angle(self.yaw1 - self.yaw0)),
        )


class TargetPath:
    """Pose of the target (or of a moving obstacle) as a function of its progress clock τ (seconds since the run
    started)."""

    def __init__(
        self, spec: TargetSpec | MovingObstacle, rng: np.random.Generator, timing_frac: float, horizon_s: float
    ) -> None:
        def jitter() -> float:
            return 1.0 + (rng.uniform(-timing_frac, timing_frac) if timing_frac > 0 else 0.0)

        x, y, yaw = spec.x, spec.y, math.radians(spec.yaw_deg)
        t = 0.0
        segs: list[Segment] = []
        if spec.start_delay_s > 0:
            d = spec.start_delay_s * jitter()
            segs.append(Segment(t, t + d, "wait", x, y, yaw, x, y, yaw))
            t += d
        turn_rate = math.radians(spec.turn_rate_dps)
        points = [(w.x, w.y, w.pause_s, w.speed_mps or spec.speed_mps) for w in spec.waypoints]
        if spec.loop and points:
            lap = [*points, (spec.x, spec.y, 0.0, spec.speed_mps)]
            ring = [(spec.x, spec.y), *[(p[0], p[1]) for p in lap]]
            lap_s = sum(math.hypot(b[0] - a[0], b[1] - a[1]) for a, b in itertools.pairwise(ring)) / max(
                p[3] for p in lap
            )
            lap_s += sum(p[2] for p in lap) + 1e-3
            laps = min(1000, math.ceil((horizon_s + 60.0) / lap_s))  # enough laps to outlast any run
            points = lap * laps
        for wx, wy, pause, speed in points:
            dist = math.hypot(wx - x, wy - y)
            if dist > 1e-6:
                heading = math.atan2(wy - y, wx - x)
                dyaw = abs(wrap_angle(heading - yaw))
                if dyaw > 1e-6:
                    d = dyaw / turn_rate
                    segs.append(Segment(t, t + d, "turn", x, y, yaw, x, y, heading))
                    t += d
                yaw = heading
                d = dist / (speed * jitter())
                segs.append(Segment(t, t + d, "move", x, y, yaw, wx, wy, yaw))
                t += d
                x, y = wx, wy
            if pause > 0:
                d = pause * jitter()
                segs.append(Segment(t, t + d, "wait", x, y, yaw, x, y, yaw))
                t += d
        self.segments = segs
        self.end_pose = (x, y, yaw)
        self.end_time = t

    def pose(self, tau: float) -> tuple[float, float, float]:
        """(x, y, yaw) at progress time τ; after the last segment the target stays where it stopped."""
        for s in self.segments:
            if tau < s.t1:
                return s.at(tau)
        return self.end_pose

    def moving(self, tau: float) -> bool:
        """True while the target drives or turns (not while it waits or after it stopped)."""
        for s in self.segments:
            if tau < s.t1:
                return s.kind != "wait" and tau >= s.t0
        return False
