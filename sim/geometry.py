"""Floor-plane footprints of everything solid, one signed-distance function for each.

The robot is a disc, so "does the robot fit here" is "is every footprint's signed distance ≥ the
radius". The same functions rasterise the static map, keep the robot out of obstacles and keep the
target out of the robot, so the map, the collisions and the scenario checks cannot disagree.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Footprint:
    """A box (centre, yaw, half extents) or a circle (centre, radius) on the floor."""

    kind: str  # "box" | "circle"
    x: float
    y: float
    yaw: float = 0.0
    hx: float = 0.0
    hy: float = 0.0
    r: float = 0.0
    name: str = ""

    def distance(self, x: float, y: float) -> float:
        """Signed distance (m) from (x, y) to the footprint's boundary, negative inside."""
        if self.kind == "circle":
            return math.hypot(x - self.x, y - self.y) - self.r
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        dx, dy = x - self.x, y - self.y
        qx = abs(c * dx + s * dy) - self.hx
        qy = abs(-s * dx + c * dy) - self.hy
        return math.hypot(max(qx, 0.0), max(qy, 0.0)) + min(max(qx, qy), 0.0)

    def distance_grid(self, xs: np.ndarray, ys: np.ndarray) -> np.ndarray:
        """Vectorised :meth:`distance` over arrays of points."""
        if self.kind == "circle":
            return np.hypot(xs - self.x, ys - self.y) - self.r
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        dx, dy = xs - self.x, ys - self.y
        qx = np.abs(c * dx + s * dy) - self.hx
        qy = np.abs(-s * dx + c * dy) - self.hy
        return np.hypot(np.maximum(qx, 0.0), np.maximum(qy, 0.0)) + np.minimum(np.maximum(qx, qy), 0.0)


def clearance(footprints: list[Footprint], x: float, y: float) -> tuple[float, Footprint | None]:
    """The smallest signed distance from (x, y) to any footprint, and which one it is."""
    best, who = math.inf, None
    for f in footprints:
        d = f.distance(x, y)
        if d < best:
            best, who = d, f
    return best, who
