"""The 2D lidar scan as things in the map: where each return lands, which are not the map's own walls, and
which neighbouring returns lie on one thing.

The line-of-sight check (is a return the target's own body or something wider that hides it?) and the
mover tracker (what is the lidar seeing move?) both split a scan into things the same way, so the rule
lives here once.
"""

from __future__ import annotations

import itertools
import math

import numpy as np

from mission.core.types import LaserScan, OccupancyGrid, Pose2D

OCCUPIED = 50  # nav_msgs/OccupancyGrid value from which a cell is an obstacle
SEGMENT_GAP_M = 0.1  # neighbouring scan returns further apart than this (+ beam spacing) are different things


def scan_points(
    scan: LaserScan, robot: Pose2D, grid: OccupancyGrid | None = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Map x, y of every return, and which are returns on something the map does not hold.

    A return in or next to a map cell ≥ OCCUPIED is the map's own obstacle (a wall); inf, NaN and
    out-of-range beams are no return."""
    ranges = np.asarray(scan.ranges, dtype=np.float64)
    valid = np.isfinite(ranges) & (ranges >= scan.range_min) & (ranges < scan.range_max)
    world = robot.yaw + scan.angles
    r = np.where(valid, ranges, 0.0)
    xs, ys = robot.x + r * np.cos(world), robot.y + r * np.sin(world)
    if grid is not None:
        rows, cols = grid.world_to_cells(xs, ys)
        h, w = grid.data.shape
        on_map = np.zeros(valid.shape, dtype=bool)
        for dr, dc in itertools.product((-1, 0, 1), repeat=2):
            rr, cc = rows + dr, cols + dc
            inside = (rr >= 0) & (rr < h) & (cc >= 0) & (cc < w)
            on_map[inside] |= grid.data[rr[inside], cc[inside]] >= OCCUPIED
        valid &= ~on_map
    return xs, ys, valid


def _continues(xs: np.ndarray, ys: np.ndarray, ranges: np.ndarray, angle_increment: float, j: int, k: int) -> bool:
    """Do returns j and k (neighbours) lie on one thing? Closer than SEGMENT_GAP_M plus three beam spacings at
    their range: a face seen at a grazing angle spreads its returns."""
    gap = SEGMENT_GAP_M + 3.0 * abs(angle_increment) * max(ranges[j], ranges[k])
    return math.hypot(xs[k] - xs[j], ys[k] - ys[j]) <= gap


def segment_width(
    xs: np.ndarray, ys: np.ndarray, valid: np.ndarray, ranges: np.ndarray, angle_increment: float, i: int
) -> float:
    """Width (m) of the thing return `i` lies on: the neighbouring returns that continue its surface (see
    _continues); the width is the greatest distance from either end of that run of returns to any of its
    points."""
    n = len(xs)

    def run(step: int) -> int:
        j = i
        for _ in range(n - 1):
            k = (j + step) % n
            if not valid[k] or not _continues(xs, ys, ranges, angle_increment, j, k):
                break
            j = k
        return j

    first, last = run(-1), run(+1)
    members = np.arange(first, first + (last - first) % n + 1) % n
    return extent_width(xs[members], ys[members])


def extent_width(px: np.ndarray, py: np.ndarray) -> float:
    """Width of a thing from its returns in beam order: the greatest distance from either end to any of them
    (robust to a return in the middle being the thing's nearest, not its edge)."""
    return float(max(np.hypot(px - px[0], py - py[0]).max(), np.hypot(px - px[-1], py - py[-1]).max()))


def scan_segments(
    xs: np.ndarray, ys: np.ndarray, valid: np.ndarray, ranges: np.ndarray, angle_increment: float
) -> list[np.ndarray]:
    """The scan's valid returns split into things: each an array of return indices, in beam order (a thing
    across the scan's seam, the last beam to the first, is one thing)."""
    n = len(xs)
    index = np.flatnonzero(valid)
    if not index.size:
        return []
    segments: list[list[int]] = [[int(index[0])]]
    for j, k in itertools.pairwise(index):
        if k == j + 1 and _continues(xs, ys, ranges, angle_increment, int(j), int(k)):
            segments[-1].append(int(k))
        else:
            segments.append([int(k)])
    full_circle = abs(angle_increment) * n >= 2 * math.pi - 1e-6
    if (
        len(segments) > 1
        and full_circle
        and segments[0][0] == 0
        and segments[-1][-1] == n - 1
        and _continues(xs, ys, ranges, angle_increment, n - 1, 0)
    ):
        segments[0] = segments.pop() + segments[0]
    return [np.asarray(s) for s in segments]
