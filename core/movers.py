"""Things the lidar sees moving that the map does not hold (a cart, a person): where they are and how fast.

Why: a search that picks a place to look from must not pick the place a cart is about to drive over. With
no notion of motion the robot chose a spot just ahead of a crossing cart, the navigator shifted the goal
out of the cart's way, and the robot drove along in front of the cart for seconds — the same way the cart
went — while the target walked on behind it (moving_occluder). Knowing the cart's velocity, the search
looks from behind it instead.

Each scan is split into things (returns off the map's walls, neighbours on one surface:
mission.core.scan.scan_segments); each thing is matched to the nearest track predicted to now (within
GATE_M of the middle of its returns' extent). A track's velocity comes from the edges of that extent, each
fitted by least squares over the last WINDOW_S, and per axis the slower of its two edges: as a box drives
past, the lidar sees one end face and then the other, so the mean of the returns lags (a cart at 0.35 m/s
measured 0.26 m/s), and an edge where a face comes into or out of view moves when the box does not (the
cart's far side seemed to drift 0.2 m/s toward the robot); the other edge moves with the box. A track
unseen for KEEP_S is dropped. Only tracks seen for MIN_AGE_S and moving at MIN_SPEED_MPS or faster are
reported: a standing box is the costmap's business, not a mover.

The tracker runs once per scan in the loop (mission.app.runner), before the tree ticks, in every world.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field

import cv2
import numpy as np

from mission.core.scan import OCCUPIED, extent_width, scan_points, scan_segments
from mission.core.types import LaserScan, OccupancyGrid, Pose2D
from mission.core.velocity import least_squares_velocity

GATE_M = 0.4  # a thing further than this from a track's predicted centroid is another thing
WINDOW_S = 1.0  # velocity: least squares over this much of a track's centroids
KEEP_S = 0.5  # a track unseen this long is gone
MIN_AGE_S = 0.4  # a track younger than this has no velocity worth reporting
MIN_SPEED_MPS = 0.1  # slower is standing still (centroid jitter)
MIN_RETURNS = 3  # a thing of fewer returns is noise or too far to tell
WALL_MARGIN_M = 0.15  # returns this close to the map's walls are the walls (localisation error, grazing beams)


@dataclass(frozen=True)
class Mover:
    """A thing the lidar sees moving, in the map frame."""

    id: int
    points: np.ndarray  # (n, 2) map x, y of its newest returns
    velocity: tuple[float, float]  # m/s
    width_m: float  # the widest it has been seen (a cart seen end-on is narrower than from its side)
    stamp: float  # when it was last seen

    @property
    def speed(self) -> float:
        return math.hypot(*self.velocity)

    def swept(self, horizon_s: float, step_s: float = 0.25) -> np.ndarray:
        """(m, 2) its returns moved along its velocity at every step_s up to horizon_s from its stamp: where
        it will have been by then, if it keeps going."""
        steps = np.arange(0.0, horizon_s + 1e-9, step_s)
        v = np.asarray(self.velocity)
        return (self.points[None, :, :] + steps[:, None, None] * v[None, None, :]).reshape(-1, 2)


@dataclass
class _Track:
    id: int
    history: deque[tuple[float, float, float, float, float]] = field(default_factory=deque)  # t and the extent
    points: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    width_m: float = 0.0
    first_seen: float = 0.0
    velocity: tuple[float, float] = (0.0, 0.0)

    def predicted(self, now: float) -> tuple[float, float]:
        t, x0, x1, y0, y1 = self.history[-1]
        return (x0 + x1) / 2 + self.velocity[0] * (now - t), (y0 + y1) / 2 + self.velocity[1] * (now - t)

    def add(self, now: float, points: np.ndarray, width: float) -> None:
        (x0, y0), (x1, y1) = points.min(axis=0), points.max(axis=0)
        self.history.append((now, float(x0), float(x1), float(y0), float(y1)))
        while self.history and self.history[0][0] < now - WINDOW_S:
            self.history.popleft()
        self.points, self.width_m = points, max(self.width_m, width)
        h = np.asarray(self.history)
        if len(h) >= 3 and h[-1, 0] - h[0, 0] >= 0.2:
            low = least_squares_velocity(h[:, [0, 1, 3]])  # the extent's low edges (x0, y0)
            high = least_squares_velocity(h[:, [0, 2, 4]])  # its high edges (x1, y1)
            self.velocity = (_slower(low[0], high[0]), _slower(low[1], high[1]))


def _slower(a: float, b: float) -> float:
    """Of two edges' speeds along one axis, the slower: an edge that moves because a face came into or out of
    view moves faster than the thing, the other edge moves with it."""
    return a if abs(a) <= abs(b) else b


class MoverTracker:
    """Tracks what the lidar sees move; `update` once per new scan."""

    def __init__(self) -> None:
        self._tracks: list[_Track] = []
        self._next_id = 1
        self._stamp: float | None = None
        self._walls: tuple[OccupancyGrid, np.ndarray] | None = None

    def update(self, scan: LaserScan, robot: Pose2D, grid: OccupancyGrid | None, now: float) -> tuple[Mover, ...]:
        """The movers after this scan (the same as last time when `scan` is the one already taken)."""
        if self._stamp is not None and scan.stamp == self._stamp:
            return self.movers()
        self._stamp = scan.stamp
        ranges = np.asarray(scan.ranges, dtype=np.float64)
        xs, ys, valid = scan_points(scan, robot, grid)
        if grid is not None:
            valid &= ~self._near_walls(grid, xs, ys)
        things = []
        for seg in scan_segments(xs, ys, valid, ranges, scan.angle_increment):
            if len(seg) < MIN_RETURNS:
                continue
            pts = np.column_stack([xs[seg], ys[seg]])
            span = extent_width(xs[seg], ys[seg])
            things.append(((pts.min(axis=0) + pts.max(axis=0)) / 2, pts, span))  # the extent's middle
        pairs = sorted(
            (math.hypot(c[0] - px, c[1] - py), i, j)
            for i, (c, _, _) in enumerate(things)
            for j, (px, py) in enumerate(tr.predicted(now) for tr in self._tracks)
        )
        used_things: set[int] = set()
        used_tracks: set[int] = set()
        for d, i, j in pairs:
            if d > GATE_M:
                break
            if i in used_things or j in used_tracks:
                continue
            used_things.add(i)
            used_tracks.add(j)
            _, pts, span = things[i]
            self._tracks[j].add(now, pts, span)
        for i, (_, pts, span) in enumerate(things):
            if i not in used_things:
                track = _Track(self._next_id, first_seen=now)
                self._next_id += 1
                track.add(now, pts, span)
                self._tracks.append(track)
        self._tracks = [tr for tr in self._tracks if now - tr.history[-1][0] <= KEEP_S]
        return self.movers()

    def _near_walls(self, grid: OccupancyGrid, xs: np.ndarray, ys: np.ndarray) -> np.ndarray:
        """Which points lie within WALL_MARGIN_M of the map's obstacles (the grown walls kept per map)."""
        if self._walls is None or self._walls[0] is not grid:
            k = 2 * math.ceil(WALL_MARGIN_M / grid.resolution) + 1
            walls = (np.asarray(grid.data) >= OCCUPIED).astype(np.uint8)
            self._walls = (grid, cv2.dilate(walls, np.ones((k, k), np.uint8)).astype(bool))
        grown = self._walls[1]
        rows, cols = grid.world_to_cells(xs, ys)
        h, w = grown.shape
        inside = (rows >= 0) & (rows < h) & (cols >= 0) & (cols < w)
        near = ~inside  # off the map: nothing to track there
        near[inside] = grown[rows[inside], cols[inside]]
        return near

    def movers(self) -> tuple[Mover, ...]:
        out = []
        for tr in self._tracks:
            t_last = tr.history[-1][0]
            if t_last - tr.first_seen >= MIN_AGE_S and math.hypot(*tr.velocity) >= MIN_SPEED_MPS:
                out.append(Mover(tr.id, tr.points, tr.velocity, tr.width_m, t_last))
        return tuple(out)
