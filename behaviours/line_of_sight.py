"""IsLineOfSightBlocked: did the target vanish behind something, or just leave the field of view?

The difference decides LOST (hold the goal, let navigation go around the obstacle) versus SEARCH
(turn to look). Two independent witnesses, either one is enough:

* the static map: an exact grid traversal (Amanatides–Woo, the DDA that visits every cell the segment
  crosses — Bresenham can step diagonally past a corner) from the camera to the target; a cell with
  occupancy ≥ 50 blocks;
* the live lidar: a scan return along the target's bearing that is closer than the target — an obstacle
  the map does not know about (a person, a box).

Where the target is: its position predicted with constant velocity from the track history (≤ 1 s
extrapolation — it kept walking after it disappeared) and its last seen position; the line of sight
counts as blocked if it is blocked to either.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np
import py_trees

from behaviours.leaf import MissionLeaf
from behaviours.ports import Port
from behaviours.registry import register
from mission.core import blackboard as bbk
from mission.core import se3
from mission.core.types import LaserScan, OccupancyGrid, Pose2D, TargetTrack

OCCUPIED = 50  # nav_msgs/OccupancyGrid value from which a cell is an obstacle
END_MARGIN_M = 0.15  # stop the ray short of the target: the target itself may sit in a wall-adjacent cell
SCAN_MARGIN_M = 0.30  # a scan return must be this much closer than the target (the target's own body)
TARGET_HALF_WIDTH_M = 0.15  # angular window of scan rays that "look at" the target
PREDICT_HORIZON_S = 1.0
MAX_SPEED = 2.0  # m/s: a faster fitted velocity is noise, clamp it


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


def scan_hit_before(scan: LaserScan, robot: Pose2D, target: tuple[float, float]) -> float | None:
    """Range of the closest scan return along the target's bearing that is clearly nearer than the target.

    The scan is taken in the base frame at the base origin (LaserScan's convention here).
    """
    dx, dy = target[0] - robot.x, target[1] - robot.y
    distance = math.hypot(dx, dy)
    if distance <= SCAN_MARGIN_M:
        return None
    bearing = se3.wrap_angle(math.atan2(dy, dx) - robot.yaw)
    ranges = np.asarray(scan.ranges, dtype=np.float64)
    diff = np.abs(np.arctan2(np.sin(scan.angles - bearing), np.cos(scan.angles - bearing)))
    half = max(abs(scan.angle_increment), math.atan2(TARGET_HALF_WIDTH_M, distance))
    limit = min(distance - SCAN_MARGIN_M, scan.range_max)
    hits = ranges[(diff <= half) & np.isfinite(ranges) & (ranges >= scan.range_min) & (ranges < limit)]
    return float(hits.min()) if hits.size else None


def predicted_position(
    track: TargetTrack, now: float, horizon_s: float = PREDICT_HORIZON_S
) -> tuple[float, float] | None:
    """Constant-velocity extrapolation (least squares over the last second of history) to `now`, ≤ horizon."""
    if track.last_seen is None or len(track.history) < 3:
        return None
    recent = np.array([h for h in track.history if h[0] >= track.last_seen - 1.0])
    if len(recent) < 3 or recent[-1, 0] - recent[0, 0] < 0.2:
        return None
    t = recent[:, 0] - recent[:, 0].mean()
    vx = float(t @ (recent[:, 1] - recent[:, 1].mean()) / (t @ t))
    vy = float(t @ (recent[:, 2] - recent[:, 2].mean()) / (t @ t))
    speed = math.hypot(vx, vy)
    if speed > MAX_SPEED:
        vx, vy = vx * MAX_SPEED / speed, vy * MAX_SPEED / speed
    dt = min(max(now - track.last_seen, 0.0), horizon_s)
    return float(recent[-1, 1] + vx * dt), float(recent[-1, 2] + vy * dt)


@dataclass(frozen=True)
class Blockage:
    what: str  # "map cell (r, c)" or "scan return"
    at_m: float  # distance from the camera / base to the blocking thing


@register
class IsLineOfSightBlocked(MissionLeaf):
    """SUCCESS when the target has been missed ≥ min_misses frames AND the map or the scan blocks the view."""

    NODE_TYPE = "Condition"
    PORTS: ClassVar[dict[str, Port]] = {
        "target": Port(str, "target", "name of the target (a key of perception.targets)"),
        "min_misses": Port(int, 5, "consecutive missed frames before an occlusion is considered"),
    }
    READS = (bbk.TRACKS, bbk.MAP, bbk.SCAN)

    def __init__(self, name: str = "IsLineOfSightBlocked", *, target: str = "target", min_misses: int = 5) -> None:
        super().__init__(name)
        self.target = target
        self.min_misses = int(min_misses)

    def _blockage(self, cam: tuple[float, float], robot: Pose2D, goal: tuple[float, float]) -> Blockage | None:
        grid: OccupancyGrid | None = self.read(bbk.MAP)
        scan: LaserScan | None = self.read(bbk.SCAN)
        if grid is not None:
            dx, dy = goal[0] - cam[0], goal[1] - cam[1]
            dist = math.hypot(dx, dy)
            if dist > END_MARGIN_M:
                k = (dist - END_MARGIN_M) / dist
                cell = first_occupied_cell(grid, cam, (cam[0] + k * dx, cam[1] + k * dy))
                if cell is not None:
                    cx, cy = grid.cell_to_world(*cell)
                    return Blockage(f"map cell {cell}", math.hypot(cx - cam[0], cy - cam[1]))
        if scan is not None:
            hit = scan_hit_before(scan, robot, goal)
            if hit is not None:
                return Blockage("scan return", hit)
        return None

    def update(self) -> py_trees.common.Status:
        fail = py_trees.common.Status.FAILURE
        tr = self.track(self.target)
        if tr is None or tr.last_seen is None or tr.pose_map is None:
            self.feedback_message = f"{self.target} never placed in the map: nothing to raytrace to"
            return fail
        if tr.misses < self.min_misses:
            self.feedback_message = f"{self.target}: {tr.misses} miss(es) < {self.min_misses}, not an occlusion yet"
            return fail
        state = self.robot()
        if state is None:
            self.feedback_message = "no robot pose: cannot raytrace"
            return fail
        if self.read(bbk.MAP) is None and self.read(bbk.SCAN) is None:
            self.feedback_message = "no map and no scan: cannot raytrace, treating line of sight as clear"
            return fail
        T_map_cam = se3.planar(state.pose.x, state.pose.y, state.pose.yaw) @ self.extrinsics()
        cam = (float(T_map_cam[0, 3]), float(T_map_cam[1, 3]))
        last = (float(tr.pose_map[0, 3]), float(tr.pose_map[1, 3]))
        candidates = [("last", last)]
        pred = predicted_position(tr, self.now())
        if pred is not None:
            candidates.insert(0, ("predicted", pred))
        for label, where in candidates:
            b = self._blockage(cam, state.pose, where)
            if b is not None:
                self.feedback_message = (
                    f"line of sight to {label} {self.target} position ({where[0]:.2f}, {where[1]:.2f}) blocked by "
                    f"{b.what} {b.at_m:.2f} m away; {tr.misses} misses"
                )
                return py_trees.common.Status.SUCCESS
        said = " and ".join(f"{label} ({p[0]:.2f}, {p[1]:.2f})" for label, p in candidates)
        self.feedback_message = f"line of sight clear to {said}; {tr.misses} misses: {self.target} left the view"
        return fail
