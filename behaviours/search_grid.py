"""The map as LOST and SEARCH reason about it: where the robot can stand, where the target can be, what
hides what from the camera, and how far things are by the paths the robot can drive.

Why a second, coarse grid: the questions asked here ("which of these hundred viewpoints sees most of where
the target can be, per second of driving?") are answered many times per replan, and 10 cm cells are as
fine as a camera's view or a person-sized target needs. The coarse grid is derived from the map (a coarse
cell is occupied when any map cell in it is), with the clearance of every cell to the nearest obstacle
measured on the fine map; it is cached per map, so a static map costs its conversion once.

Three questions, three functions:

* :func:`travel_distances` — metres along 8-connected paths through cells the robot fits in, from one
  cell to every other (Dijkstra, scipy.sparse.csgraph): travel time is what a search spends;
* :func:`view_cells` — the cells a camera at a pose sees (rays through its field of view, stopped by the
  first blocking cell: the map's obstacles and what the lidar sees now);
* :func:`ray_masses` — for many places at once, how much of a weight grid each direction round them sees
  (each ray sample weighted by the area it stands for), from which the best heading window follows.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import cv2
import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import dijkstra

from mission.core.scan import OCCUPIED
from mission.core.types import LaserScan, OccupancyGrid, Pose2D

COARSE_M = 0.10  # cell size of the search grid
TARGET_RADIUS_M = 0.20  # the target's centre keeps this far from obstacles (a person-sized box)
SQRT2 = math.sqrt(2.0)


@dataclass
class SearchGrid:
    """The coarse grid of one map: geometry (an OccupancyGrid of the coarse cells) and its layers."""

    geometry: OccupancyGrid  # data: 100 occupied, 0 free, -1 unknown, per coarse cell
    occupied: np.ndarray  # bool H×W: blocks sight and travel (the map's obstacles)
    known_free: np.ndarray  # bool H×W: every map cell inside is known free
    clearance: np.ndarray  # float32 H×W: metres from the cell centre to the nearest obstacle or unknown cell
    source: OccupancyGrid = field(repr=False)

    @property
    def shape(self) -> tuple[int, int]:
        return self.occupied.shape  # type: ignore[return-value]

    @property
    def resolution(self) -> float:
        return self.geometry.resolution

    def cell(self, x: float, y: float) -> tuple[int, int]:
        return self.geometry.world_to_cell(x, y)

    def centre(self, row: int, col: int) -> tuple[float, float]:
        return self.geometry.cell_to_world(row, col)

    def inside(self, row: int, col: int) -> bool:
        return self.geometry.in_bounds(row, col)

    def target_free(self, radius_m: float = TARGET_RADIUS_M) -> np.ndarray:
        """Cells the target's centre can occupy: known free and `radius_m` from every obstacle."""
        return self.known_free & (self.clearance >= radius_m)

    def robot_free(self, clearance_m: float) -> np.ndarray:
        """Cells the robot's centre can be driven to with `clearance_m` from everything on the map."""
        return self.known_free & (self.clearance >= clearance_m)

    def centres(self) -> tuple[np.ndarray, np.ndarray]:
        """Map x, y of every cell centre (H×W each)."""
        h, w = self.shape
        g = self.geometry
        cols, rows = np.meshgrid(np.arange(w) + 0.5, np.arange(h) + 0.5)
        c, s = math.cos(g.origin.yaw), math.sin(g.origin.yaw)
        lx, ly = cols * g.resolution, rows * g.resolution
        return g.origin.x + c * lx - s * ly, g.origin.y + s * lx + c * ly

    def scan_cells(self, scan: LaserScan | None, robot: Pose2D) -> np.ndarray:
        """Cells where the lidar sees something now (obstacles the map does not know: a crate, a cart)."""
        hits = np.zeros(self.shape, dtype=bool)
        if scan is None:
            return hits
        r = np.asarray(scan.ranges, dtype=np.float64)
        ok = np.isfinite(r) & (r >= scan.range_min) & (r < scan.range_max)
        ang = robot.yaw + scan.angles[ok]
        rows, cols = self._cells(robot.x + r[ok] * np.cos(ang), robot.y + r[ok] * np.sin(ang))
        hits[rows, cols] = True
        return hits

    def point_cells(self, points: np.ndarray) -> np.ndarray:
        """Cells holding any of the (n, 2) map points."""
        hits = np.zeros(self.shape, dtype=bool)
        if len(points):
            rows, cols = self._cells(points[:, 0], points[:, 1])
            hits[rows, cols] = True
        return hits

    def _cells(self, xs: np.ndarray, ys: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(rows, cols) of the points inside the grid."""
        rows, cols = self.geometry.world_to_cells(xs, ys)
        h, w = self.shape
        ok = (rows >= 0) & (rows < h) & (cols >= 0) & (cols < w)
        return rows[ok], cols[ok]


_CACHE: dict[int, tuple[OccupancyGrid, SearchGrid]] = {}


def search_grid(grid: OccupancyGrid) -> SearchGrid:
    """The coarse search grid of `grid` (cached while the same map object is on the blackboard)."""
    hit = _CACHE.get(id(grid))
    if hit is not None and hit[0] is grid:
        return hit[1]
    made = _coarsen(grid)
    _CACHE.clear()  # one map at a time: a new map (ROS /map) replaces the old
    _CACHE[id(grid)] = (grid, made)
    return made


def _coarsen(grid: OccupancyGrid) -> SearchGrid:
    k = max(1, round(COARSE_M / grid.resolution))
    data = np.asarray(grid.data)
    fh, fw = data.shape
    h, w = -(-fh // k), -(-fw // k)
    padded = np.full((h * k, w * k), -1, dtype=np.int16)
    padded[:fh, :fw] = data
    blocks = padded.reshape(h, k, w, k).transpose(0, 2, 1, 3).reshape(h, w, k * k)
    occupied = (blocks >= OCCUPIED).any(axis=2)
    known_free = ((blocks >= 0) & (blocks < OCCUPIED)).all(axis=2)
    # clearance on the fine map: distance from free cells to the nearest occupied or unknown cell
    free_fine = ((data >= 0) & (data < OCCUPIED)).astype(np.uint8)
    dist = cv2.distanceTransform(free_fine, cv2.DIST_L2, 5).astype(np.float32) * grid.resolution
    centre = np.clip(np.arange(h) * k + k // 2, 0, fh - 1)[:, None], np.clip(np.arange(w) * k + k // 2, 0, fw - 1)
    clearance = dist[centre[0], centre[1]]
    coarse = np.where(occupied, 100, np.where(known_free, 0, -1)).astype(np.int8)
    geometry = OccupancyGrid(data=coarse, resolution=grid.resolution * k, origin=grid.origin, frame_id=grid.frame_id)
    return SearchGrid(geometry, occupied, known_free, clearance, grid)


# ------------------------------------------------------------------------------------------- travel
def travel_distances(free: np.ndarray, start: tuple[int, int], resolution: float) -> np.ndarray:
    """Metres from `start` to every cell along 8-connected paths through `free` cells (inf: unreachable).

    The start cell counts as free (a robot parked close to a wall can still leave); a diagonal step
    needs both cells beside it free, so paths never squeeze between two obstacles touching at a corner.
    """
    h, w = free.shape
    ok = free.copy()
    r0, c0 = start
    if not (0 <= r0 < h and 0 <= c0 < w):
        return np.full((h, w), np.inf)
    ok[r0, c0] = True
    idx = np.arange(h * w).reshape(h, w)
    rows, cols, costs = [], [], []
    for dr, dc, step in ((0, 1, 1.0), (1, 0, 1.0), (1, 1, SQRT2), (1, -1, SQRT2)):
        ra = slice(0, h - dr) if dr >= 0 else slice(-dr, h)
        rb = slice(dr, h) if dr >= 0 else slice(0, h + dr)
        ca = slice(0, w - dc) if dc >= 0 else slice(-dc, w)
        cb = slice(dc, w) if dc >= 0 else slice(0, w + dc)
        a = ok[ra, ca] & ok[rb, cb]
        if dr and dc:  # no corner cutting
            a &= ok[ra, cb] & ok[rb, ca]
        rows.append(idx[ra, ca][a])
        cols.append(idx[rb, cb][a])
        costs.append(np.full(int(a.sum()), step * resolution))
    r = np.concatenate(rows)
    c = np.concatenate(cols)
    graph = coo_matrix((np.concatenate(costs), (r, c)), shape=(h * w, h * w)).tocsr()
    dist = dijkstra(graph, directed=False, indices=r0 * w + c0)
    return np.asarray(dist).reshape(h, w)


# ------------------------------------------------------------------------------------------- sight
def _ray_samples(
    sg: SearchGrid,
    xs: np.ndarray,
    ys: np.ndarray,
    angles: np.ndarray,
    range_m: float,
    min_range_m: float,
    step: float,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Flat cell indices (N, R, S), whether each sample is inside the grid, and the samples' ranges (S,).

    Samples every `step` metres along each ray from `min_range_m` to `range_m`."""
    ranges = np.arange(max(min_range_m, step / 2), range_m, step)
    px = xs[:, None, None] + ranges[None, None, :] * np.cos(angles)[None, :, None]
    py = ys[:, None, None] + ranges[None, None, :] * np.sin(angles)[None, :, None]
    rows, cols = sg.geometry.world_to_cells(px, py)
    h, w = sg.shape
    inside = (rows >= 0) & (rows < h) & (cols >= 0) & (cols < w)
    flat = np.where(inside, rows * w + cols, 0)
    return flat, inside, ranges


def _visible(blocked_flat: np.ndarray, flat: np.ndarray, inside: np.ndarray) -> np.ndarray:
    """Per sample: nothing blocking between the ray's origin and it (the blocking cell itself is not seen)."""
    hit = blocked_flat[flat] | ~inside
    return np.cumsum(hit, axis=-1) == 0


def view_cells(
    sg: SearchGrid,
    blocked: np.ndarray,
    camera: tuple[float, float],
    yaw: float,
    hfov: float,
    range_m: float,
    min_range_m: float = 0.2,
) -> np.ndarray:
    """Bool H×W: the cells a camera at `camera` facing `yaw` sees within its horizontal FOV and range."""
    n_rays = max(8, int(math.degrees(hfov)))  # a ray per degree: 7 cm apart at 4 m
    angles = yaw + np.linspace(-hfov / 2, hfov / 2, n_rays)
    xs, ys = np.array([camera[0]]), np.array([camera[1]])
    flat, inside, _ = _ray_samples(sg, xs, ys, angles, range_m, min_range_m, sg.resolution / 2)
    vis = _visible(blocked.ravel(), flat, inside)
    seen = np.zeros(blocked.size, dtype=bool)
    seen[flat[vis & inside]] = True
    return seen.reshape(blocked.shape)


def ray_masses(
    sg: SearchGrid,
    blocked: np.ndarray,
    weights: np.ndarray,
    xs: np.ndarray,
    ys: np.ndarray,
    n_rays: int,
    range_m: float,
    min_range_m: float = 0.2,
) -> np.ndarray:
    """(N, n_rays): the weight each of `n_rays` directions round each place (xs[i], ys[i]) sees.

    A ray sample at range r stands for the area r·Δθ·Δs of the fan, so a weight grid of "probability per
    cell" integrates to what the view covers whatever the ray spacing (a near cell crossed by many rays is
    not counted many times over). Direction j is the angle 2πj/n_rays in the map frame.
    """
    angles = np.arange(n_rays) * (2 * math.pi / n_rays)
    step = sg.resolution  # a sample per cell along the ray: ranking needs the sum, not every cell's verdict
    flat, inside, ranges = _ray_samples(sg, xs, ys, angles, range_m, min_range_m, step)
    vis = _visible(blocked.ravel(), flat, inside) & inside
    area = ranges * (2 * math.pi / n_rays) * step / sg.resolution**2  # fraction of a cell per sample
    w = weights.ravel()[flat] * vis
    return np.asarray((w * area[None, None, :]).sum(axis=2))


def best_window(masses: np.ndarray, width: int) -> tuple[np.ndarray, np.ndarray]:
    """For each row of (N, R) ray masses: the most mass any `width` consecutive directions (circularly) see,
    and the first direction of that window."""
    n, r = masses.shape
    width = max(1, min(width, r))
    ext = np.concatenate([masses, masses[:, : width - 1]], axis=1)
    csum = np.concatenate([np.zeros((n, 1)), np.cumsum(ext, axis=1)], axis=1)
    sums = csum[:, width : width + r] - csum[:, :r]
    start = np.argmax(sums, axis=1)
    return sums[np.arange(n), start], start


def line_clear(blocked: np.ndarray, sg: SearchGrid, a: tuple[float, float], b: tuple[float, float]) -> bool:
    """Nothing blocking on the straight line a → b (both ends' own cells aside)."""
    d = math.hypot(b[0] - a[0], b[1] - a[1])
    if d < 1e-6:
        return True
    n = max(2, int(d / (sg.resolution / 2)))
    t = np.linspace(0, 1, n)[1:-1]
    rows, cols = sg._cells(a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1]))
    ra, ca = sg.cell(*a)
    rb, cb = sg.cell(*b)
    own = ((rows == ra) & (cols == ca)) | ((rows == rb) & (cols == cb))
    return not bool(blocked[rows[~own], cols[~own]].any())


_SQUARE = np.ones((3, 3), np.uint8)
_CROSS = cv2.getStructuringElement(cv2.MORPH_CROSS, (3, 3))


def dilate(mask: np.ndarray, cells: int) -> np.ndarray:
    """`mask` grown by `cells` cells (a disc-ish octagon: square and cross kernels alternating)."""
    out = mask.astype(bool)
    for i in range(cells):
        out = dilate_once(out, i)
    return out


def dilate_once(mask: np.ndarray, i: int) -> np.ndarray:
    """`mask` grown by one cell: the `i`-th step of :func:`dilate` (the cross on even steps, the square on odd)."""
    return cv2.dilate(mask.astype(np.uint8), _SQUARE if i % 2 else _CROSS).astype(bool)


def walk(free: np.ndarray, sg: SearchGrid, start: tuple[float, float], end: tuple[float, float]) -> tuple[float, float]:
    """How far along start → end one gets through `free` cells: the last point before the first cell that is
    not free (`start` itself when its own cell is not). A target walking on does not go through walls."""
    d = math.hypot(end[0] - start[0], end[1] - start[1])
    n = max(1, int(d / (sg.resolution / 2)))
    last = start
    h, w = free.shape
    for i in range(1, n + 1):
        t = i / n
        p = (start[0] + t * (end[0] - start[0]), start[1] + t * (end[1] - start[1]))
        r, c = sg.cell(*p)
        if not (0 <= r < h and 0 <= c < w) or not free[r, c]:
            break
        last = p
    return last
