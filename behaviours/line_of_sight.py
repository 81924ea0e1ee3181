"""IsLineOfSightBlocked: did the target vanish behind something, or just leave the field of view?

The difference decides LOST (hold the goal, let navigation go around the obstacle) versus SEARCH
(turn to look). Two independent witnesses, either one is enough:

* the static map: an exact grid traversal (Amanatides–Woo, the DDA that visits every cell the segment
  crosses — Bresenham can step diagonally past a corner) from the camera to the target; a cell with
  occupancy ≥ 50 blocks;
* the live lidar: a scan return along the target's bearing that is closer than the target — an obstacle
  the map does not know about (a person, a box). A return on the target's own footprint (within
  ``target_radius_m`` of the line from its last to its predicted position) is not an occluder: when the
  prediction runs past a corner, the lidar still sees the target's body where it really is, in the open.

Where the target may be: its last seen position, its position predicted with constant velocity from
the track history (≤ 1 s extrapolation — it kept walking after it disappeared), and every free place
within ``reach_m`` of the last position that it could walk to in a straight line (a ring of
hypotheses). A point test alone is fooled by a corner: the target last seen just round the end of a
wall, in plain view, then walks on behind the wall — its last and predicted positions are both in
clear sight, yet it is hidden. The line of sight counts as blocked when the camera cannot see the
last/predicted position (map or scan) or any place the target could have reached (map).

The verdict is taken once per loss — when the misses reach ``min_misses`` — and held until the target
is seen again (hysteresis): the robot moving while LOST or turning while SEARCHing does not flip the
coordinator between the two.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import py_trees

from mission.behaviours.leaf import MissionLeaf
from mission.behaviours.ports import port
from mission.core import blackboard as bbk
from mission.core import se3
from mission.core.scan import OCCUPIED, scan_points, segment_width
from mission.core.types import LaserScan, OccupancyGrid, Pose2D, TargetTrack
from mission.core.velocity import least_squares_velocity, velocity_standard_error

END_MARGIN_M = 0.15  # stop the ray short of the target: the target itself may sit in a wall-adjacent cell
SCAN_MARGIN_M = 0.30  # a scan return must be this much closer than the target (the target's own body)
TARGET_HALF_WIDTH_M = 0.15  # angular window of scan rays that "look at" the target
WIDE_MARGIN_M = 0.03  # a thing wider than the target hides it when it is this much nearer (range noise)
PREDICT_HORIZON_S = 1.0
TARGET_RADIUS_M = 0.3  # a scan return this close to the target's last or predicted place may be its own body
MAX_SPEED = 2.0  # m/s: a faster fitted velocity is noise, clamp it
RING_DIRECTIONS = 16  # hypotheses per ring round the last seen position
RING_FRACTIONS = (0.5, 1.0)  # rings at these fractions of reach_m
FREE = 0  # only known-free cells can hold the target
# How far from its last position the target may have walked by the time turning toward where it went would show
# it: the loss is decided a few frames after the last sighting, and a turn to face it takes a second more. A target
# lost off the image's side as it rounds a wall's end is behind the wall by then; with every place within 1 m in
# clear sight SEARCH turned in place beside the wall while it walked down the far side (search_corner seeds 5303,
# 5308 and 5316 under typical: re-acquired after 15.8-20.1 s; LOST's look round the end finds it in 5.7-7.8 s).
REACH_M = 1.5


def first_occupied_cell(
    grid: OccupancyGrid, start: tuple[float, float], end: tuple[float, float], threshold: int = OCCUPIED
) -> tuple[int, int] | None:
    """(row, col) of the first cell ≥ threshold on the segment start→end (map metres), or None if clear.

    Visits every cell the segment passes through (Amanatides & Woo 1987). Cells outside the grid and
    unknown cells (-1) do not block.
    """
    r0, c0 = grid.world_to_grid(*start)
    r1, c1 = grid.world_to_grid(*end)
    row, col = math.floor(r0), math.floor(c0)
    end_row, end_col = math.floor(r1), math.floor(c1)
    dr, dc = r1 - r0, c1 - c0
    step_r = 1 if dr > 0 else -1
    step_c = 1 if dc > 0 else -1
    t_delta_r = abs(1.0 / dr) if dr != 0 else math.inf
    t_delta_c = abs(1.0 / dc) if dc != 0 else math.inf
    t_max_r = ((row + 1 - r0) / dr if dr > 0 else (r0 - row) / -dr) if dr != 0 else math.inf
    t_max_c = ((col + 1 - c0) / dc if dc > 0 else (c0 - col) / -dc) if dc != 0 else math.inf
    for _ in range(abs(end_row - row) + abs(end_col - col) + 1):
        if grid.in_bounds(row, col) and int(grid.data[row, col]) >= threshold:
            return row, col
        if (row, col) == (end_row, end_col):
            break
        if t_max_r < t_max_c:
            t_max_r += t_delta_r
            row += step_r
        else:
            t_max_c += t_delta_c
            col += step_c
    return None


def scan_hit_before(
    scan: LaserScan,
    robot: Pose2D,
    target: tuple[float, float],
    own_path: tuple[tuple[float, float], ...] = (),
    own_radius_m: float = 0.0,
    grid: OccupancyGrid | None = None,
) -> float | None:
    """Range of the closest scan return along the target's bearing that is clearly nearer than the target.

    A return that lands within `own_radius_m` of `own_path` (the target's last seen position and where it
    is predicted to be: the polyline it walked along) on a thing no wider than the target (2 × own_radius_m)
    is the target's own body, not an occluder — when the prediction runs past a corner, the lidar still sees
    the target where it really is, nearer than the prediction. A wider thing there is something else: it
    hides the target even when it stands just in front of it (WIDE_MARGIN_M, not SCAN_MARGIN_M: a cart
    passing right in front of the target). Returns on the map's own obstacles (`grid`) are not part of any
    thing's width: a target standing against a wall is still target-sized. The scan is taken in the base
    frame at the base origin (LaserScan's convention here).
    """
    dx, dy = target[0] - robot.x, target[1] - robot.y
    distance = math.hypot(dx, dy)
    if distance <= SCAN_MARGIN_M:
        return None
    bearing = se3.wrap_angle(math.atan2(dy, dx) - robot.yaw)
    ranges = np.asarray(scan.ranges, dtype=np.float64)
    angles = scan.angles
    diff = np.abs(np.arctan2(np.sin(angles - bearing), np.cos(angles - bearing)))
    half = max(abs(scan.angle_increment), math.atan2(TARGET_HALF_WIDTH_M, distance))
    filtered = bool(own_path) and own_radius_m > 0
    margin = WIDE_MARGIN_M if filtered else SCAN_MARGIN_M
    limit = min(distance - margin, scan.range_max)
    near = (diff <= half) & np.isfinite(ranges) & (ranges >= scan.range_min) & (ranges < limit)
    index = np.flatnonzero(near)
    if index.size and filtered:
        xs, ys, valid = scan_points(scan, robot, grid)
        wide = np.array(
            [segment_width(xs, ys, valid, ranges, scan.angle_increment, int(i)) > 2 * own_radius_m for i in index]
        )
        clear = ranges[index] < distance - SCAN_MARGIN_M
        on_path = _distance_to_polyline(xs[index], ys[index], own_path) <= own_radius_m
        index = index[wide | (clear & ~on_path)]
    return float(ranges[index].min()) if index.size else None


def _distance_to_polyline(px: np.ndarray, py: np.ndarray, path: tuple[tuple[float, float], ...]) -> np.ndarray:
    """Distance of each point to the polyline through `path` (one point: to that point)."""
    best = np.full(px.shape, np.inf)
    pts = list(path) if len(path) > 1 else [path[0], path[0]]
    for (ax, ay), (bx, by) in itertools.pairwise(pts):
        vx, vy = bx - ax, by - ay
        seg = vx * vx + vy * vy
        t = np.zeros(px.shape) if seg < 1e-12 else np.clip(((px - ax) * vx + (py - ay) * vy) / seg, 0.0, 1.0)
        np.minimum(best, np.hypot(px - (ax + t * vx), py - (ay + t * vy)), out=best)
    return best


TURNING_RAD = math.radians(60.0)  # the two halves of the window disagree this much: it was turning, no heading
# A heading the search acts on needs sightings this long: a target walking 0.5 m/s moves 0.2 m in it, four
# times what a robot's localisation and a calibrated camera put on its position (AMCL's ~3 cm and 0.02 rad
# at 1–2 m, a bias that moves with the marker across the image). Over the 0.2 s after a re-acquisition that
# noise alone reads as 0.3–0.6 m/s: a target standing at a corner fitted 0.6 m/s into the wall beside it.
STEADY_SPAN_S = 0.4
# … and a speed of this many standard errors of the fit: a target standing at a corner while it turned, its
# marker swinging round its body, is placed ±15 cm about where it stands (hide_and_wait seed 1002, typical),
# and a line through that is the scatter's, not a walk.
STEADY_SIGNIFICANCE = 2.0


def fitted_velocity(track: TargetTrack, window_s: float = 1.0, *, steady: bool = False) -> tuple[float, float] | None:
    """The target's map velocity (m/s) when last seen: least squares over the last `window_s` of its centre's
    placings (TargetTrack.centres; its `history` when none were kept), clamped to MAX_SPEED; None when too few
    sightings span too short a time to tell.

    With `steady`, also None when the sightings span less than STEADY_SPAN_S or the speed is under
    STEADY_SIGNIFICANCE standard errors of the fit (neither tells a walk from the positions' noise), or when
    the target was turning: the halves of the window point more than
    TURNING_RAD apart. A target tracked by a marker on its face that turns at a corner moves the marker
    round its centre, and a fit over that says it walked off the wrong way (the search then looks there)."""
    points = track.centres or track.history  # the centre's walk, not the marker's swing round it
    if track.last_seen is None or len(points) < 3:
        return None
    recent = np.array([h for h in points if h[0] >= track.last_seen - window_s])
    if len(recent) < 3 or recent[-1, 0] - recent[0, 0] < (STEADY_SPAN_S if steady else 0.2) - 1e-6:
        return None
    vx, vy = least_squares_velocity(recent)
    if steady and math.hypot(vx, vy) < STEADY_SIGNIFICANCE * velocity_standard_error(recent):
        return None
    if steady and len(recent) >= 6:
        half = len(recent) // 2
        (ax, ay), (bx, by) = least_squares_velocity(recent[:half]), least_squares_velocity(recent[half:])
        if math.hypot(ax, ay) > 0.05 and math.hypot(bx, by) > 0.05:
            turn = abs(math.atan2(ax * by - ay * bx, ax * bx + ay * by))
            if turn > TURNING_RAD:
                return None
    speed = math.hypot(vx, vy)
    if speed > MAX_SPEED:
        vx, vy = vx * MAX_SPEED / speed, vy * MAX_SPEED / speed
    return vx, vy


def predicted_position(
    track: TargetTrack, now: float, horizon_s: float = PREDICT_HORIZON_S
) -> tuple[float, float] | None:
    """Constant-velocity extrapolation (least squares over the last second of history) to `now`, ≤ horizon."""
    v = fitted_velocity(track)
    if v is None:
        return None
    x, y = track.history[-1][1], track.history[-1][2]
    dt = min(max(now - track.last_seen, 0.0), horizon_s)  # type: ignore[operator]  # last_seen set: v exists
    return float(x + v[0] * dt), float(y + v[1] * dt)


@dataclass(frozen=True)
class Blockage:
    what: str  # "map cell (r, c)" or "scan return"
    at_m: float  # distance from the camera / base to the blocking thing


def map_blockage(grid: OccupancyGrid, cam: tuple[float, float], goal: tuple[float, float]) -> Blockage | None:
    """The first occupied map cell between the camera and `goal`, stopping END_MARGIN_M short of it (the target
    may stand in a cell next to a wall); None when the map leaves the line clear."""
    dx, dy = goal[0] - cam[0], goal[1] - cam[1]
    dist = math.hypot(dx, dy)
    if dist <= END_MARGIN_M:
        return None
    k = (dist - END_MARGIN_M) / dist
    cell = first_occupied_cell(grid, cam, (cam[0] + k * dx, cam[1] + k * dy))
    if cell is None:
        return None
    cx, cy = grid.cell_to_world(*cell)
    return Blockage(f"map cell {cell}", math.hypot(cx - cam[0], cy - cam[1]))


def sight_blockage(
    grid: OccupancyGrid | None,
    scan: LaserScan | None,
    cam: tuple[float, float],
    robot: Pose2D,
    goal: tuple[float, float],
    own_path: tuple[tuple[float, float], ...] = (),
    own_radius_m: float = 0.0,
) -> Blockage | None:
    """What hides `goal` from the camera: the map's first occupied cell on the way (map_blockage), else a scan
    return clearly nearer than it that is not the target's own body (scan_hit_before); None when neither."""
    if grid is not None:
        b = map_blockage(grid, cam, goal)
        if b is not None:
            return b
    if scan is not None:
        hit = scan_hit_before(scan, robot, goal, own_path, own_radius_m, grid)
        if hit is not None:
            return Blockage("scan return", hit)
    return None


def reachable_hypotheses(grid: OccupancyGrid, last: tuple[float, float], reach_m: float) -> list[tuple[float, float]]:
    """Free places within `reach_m` of `last` that the target can walk to in a straight line (map metres).

    Rings of RING_DIRECTIONS points at RING_FRACTIONS of reach_m; a point counts when its cell is known
    free and the segment from `last` to it crosses no occupied cell (the target does not walk through
    walls — a place on the far side of a thin wall is not "just round the corner").
    """
    out: list[tuple[float, float]] = []
    if reach_m <= 0:
        return out
    for frac in RING_FRACTIONS:
        r = frac * reach_m
        for k in range(RING_DIRECTIONS):
            a = 2 * math.pi * k / RING_DIRECTIONS
            p = (last[0] + r * math.cos(a), last[1] + r * math.sin(a))
            row, col = (math.floor(v) for v in grid.world_to_grid(*p))
            if not grid.in_bounds(row, col) or int(grid.data[row, col]) != FREE:
                continue
            if first_occupied_cell(grid, last, p) is None:
                out.append(p)
    return out


@dataclass(frozen=True)
class Verdict:
    """One loss's classification, held until the target is seen again."""

    last_seen: float
    blocked: bool
    why: str


class IsLineOfSightBlocked(MissionLeaf):
    """SUCCESS when the target has been missed ≥ min_misses frames AND the map or the scan blocks the view.

    Decided once per loss (at the min_misses-th miss) and held until the next sighting.
    """

    @dataclass(frozen=True, kw_only=True)
    class Params:
        target: str = port("target", "name of the target (a key of perception.targets)")
        min_misses: int = port(5, "consecutive missed frames before an occlusion is considered")
        target_radius_m: float = port(
            TARGET_RADIUS_M,
            "a scan return this close to the target's last or predicted position, on a thing no wider than twice "
            "this, is its own body, not an occluder",
        )

    NODE_TYPE = "Condition"
    READS = (bbk.TRACKS, bbk.MAP, bbk.SCAN)
    params: Params

    def __init__(self, name: str | None = None, **ports: Any) -> None:
        super().__init__(name, **ports)
        self.reach_m = REACH_M
        self.verdict: Verdict | None = None

    def _classify(self, tr: TargetTrack, robot: Pose2D) -> tuple[bool, str]:
        """(blocked, why) for the current loss: last/predicted position (map + scan), then reachable places (map)."""
        assert tr.pose_map is not None
        cam = self.camera_xy(robot)
        last = (float(tr.pose_map[0, 3]), float(tr.pose_map[1, 3]))
        candidates = [("last", last)]
        pred = predicted_position(tr, self.now())
        if pred is not None:
            candidates.insert(0, ("predicted", pred))
        own_path = tuple(p for _, p in reversed(candidates))  # last → predicted: where the target's body can be
        for label, where in candidates:
            b = sight_blockage(
                self.read(bbk.MAP), self.read(bbk.SCAN), cam, robot, where, own_path, self.params.target_radius_m
            )
            if b is not None:
                return True, (
                    f"line of sight to {label} {self.params.target} position ({where[0]:.2f}, {where[1]:.2f}) "
                    f"blocked by {b.what} {b.at_m:.2f} m away"
                )
        grid: OccupancyGrid | None = self.read(bbk.MAP)
        places = reachable_hypotheses(grid, last, self.reach_m) if grid is not None else []
        for where in places:
            b = map_blockage(grid, cam, where)  # type: ignore[arg-type]
            if b is not None:
                return True, (
                    f"{self.params.target} may be hidden at ({where[0]:.2f}, {where[1]:.2f}), "
                    f"{self.reach_m:g} m or less from its last position ({last[0]:.2f}, {last[1]:.2f}): "
                    f"line of sight blocked by {b.what} {b.at_m:.2f} m away"
                )
        said = " and ".join(f"{label} ({p[0]:.2f}, {p[1]:.2f})" for label, p in candidates)
        return False, (
            f"line of sight clear to {said} and to {len(places)} place(s) within {self.reach_m:g} m: "
            f"{self.params.target} left the view"
        )

    def update(self) -> py_trees.common.Status:
        fail = py_trees.common.Status.FAILURE
        tr = self.track(self.params.target)
        if tr is None or tr.last_seen is None or tr.pose_map is None:
            self.verdict = None
            self.feedback_message = f"{self.params.target} never placed in the map: nothing to raytrace to"
            return fail
        if tr.misses < self.params.min_misses:
            self.verdict = None
            self.feedback_message = (
                f"{self.params.target}: {tr.misses} miss(es) < {self.params.min_misses}, not an occlusion yet"
            )
            return fail
        if self.verdict is None or self.verdict.last_seen != tr.last_seen:
            state = self.robot()
            if state is None:
                self.feedback_message = "no robot pose: cannot raytrace"
                return fail
            if self.read(bbk.MAP) is None and self.read(bbk.SCAN) is None:
                self.feedback_message = "no map and no scan: cannot raytrace, treating line of sight as clear"
                return fail
            blocked, why = self._classify(tr, state.pose)
            self.verdict = Verdict(tr.last_seen, blocked, why)
        self.feedback_message = f"{self.verdict.why}; {tr.misses} misses"
        return py_trees.common.Status.SUCCESS if self.verdict.blocked else fail
