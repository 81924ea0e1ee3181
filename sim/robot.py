"""A differential-drive base moved kinematically: what it is told is what it does, within its limits.

Wheel velocity control in pybullet under-turns badly (FIELD_NOTES: commanded 0.4 rad/s gives 0.13), so
the base integrates the commanded (v, ω) exactly — after clipping to its speed limits and slewing at
its acceleration limits, like a real base controller — and resolves collisions itself: a step that
would bring the disc footprint into any obstacle is shortened to the last free point and the base
stops translating (it may still turn in place: a disc never collides by turning). Each new contact is
counted once, from the moment the base is blocked until it moves freely again.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from mission.core.se3 import wrap_angle
from mission.sim.geometry import Footprint, clearance
from mission.sim.scenario import RobotSpec

CONTACT_EPS_M = 0.002  # a step ending closer than this to an obstacle counts as touching it


@dataclass
class BaseState:
    x: float
    y: float
    yaw: float
    v: float = 0.0
    w: float = 0.0


def _slew(current: float, wanted: float, limit: float) -> float:
    return current + max(-limit, min(limit, wanted - current))


def integrate(x: float, y: float, yaw: float, v: float, w: float, dt: float) -> tuple[float, float, float]:
    """Exact unicycle motion for constant (v, ω) over dt (an arc, or a line when ω ≈ 0)."""
    if abs(w) < 1e-9:
        return x + v * dt * math.cos(yaw), y + v * dt * math.sin(yaw), yaw
    r = v / w
    yaw2 = yaw + w * dt
    return x + r * (math.sin(yaw2) - math.sin(yaw)), y - r * (math.cos(yaw2) - math.cos(yaw)), wrap_angle(yaw2)


class DiffDriveBase:
    """The robot's base: pose, velocity, limits and collision handling in the map frame."""

    def __init__(self, spec: RobotSpec, x: float, y: float, yaw: float) -> None:
        self.spec = spec
        self.state = BaseState(x, y, wrap_angle(yaw))
        self.blocked = False
        self.contacts = 0  # contact events so far
        self.last_contact: Footprint | None = None
        self.contact_log: list[str] = []

    def step(self, v_cmd: float, w_cmd: float, dt: float, obstacles: list[Footprint]) -> None:
        """Advance dt seconds towards the commanded twist."""
        s, sp = self.state, self.spec
        v_cmd = max(-sp.max_v, min(sp.max_v, v_cmd))
        w_cmd = max(-sp.max_w, min(sp.max_w, w_cmd))
        s.v = _slew(s.v, v_cmd, sp.acc_v * dt)
        s.w = _slew(s.w, w_cmd, sp.acc_w * dt)
        x2, y2, yaw2 = integrate(s.x, s.y, s.yaw, s.v, s.w, dt)
        free, who = clearance(obstacles, x2, y2)
        if free >= sp.radius + CONTACT_EPS_M or abs(s.v) < 1e-9:
            s.x, s.y, s.yaw = x2, y2, yaw2
            self.blocked = False
            return
        # Would touch: move as far along the arc as stays free (bisection), then stop translating.
        lo, hi = 0.0, 1.0
        for _ in range(12):
            mid = (lo + hi) / 2
            xm, ym, _ = integrate(s.x, s.y, s.yaw, s.v, 0.0 if s.v == 0 else s.w, dt * mid)
            if clearance(obstacles, xm, ym)[0] >= sp.radius + CONTACT_EPS_M:
                lo = mid
            else:
                hi = mid
        xs, ys, _ = integrate(s.x, s.y, s.yaw, s.v, s.w, dt * lo)
        s.x, s.y = xs, ys
        s.yaw = yaw2
        s.v = 0.0
        if not self.blocked:
            self.contacts += 1
            self.last_contact = who
            self.contact_log.append(who.name if who is not None and who.name else "obstacle")
        self.blocked = True
