"""A small, honest stand-in for Nav2 in the sim: costmap, A*, pure pursuit, replanning, status.

* Costmap: the static map plus what the lidar sees (marked at hits, cleared along free rays), turned
  into distances to the nearest obstacle. Cells closer than the robot radius are lethal; closer than
  radius + inflation are allowed but expensive (so a robot that starts near a wall can leave), and a
  soft cost keeps paths off walls.
* Planner: 8-connected A* on the map grid, then string-pulled to a few corners. A goal in an occupied
  or inflated cell is moved to the nearest comfortable free cell (the follow target stands in space
  the robot should not enter).
* Controller: pure pursuit towards the next path corner with a turn-in-place threshold, slowing near
  the goal, a look-ahead safety stop against lethal cells and the newest scan's returns, then a turn to
  the goal yaw.
* Replans on a new goal, when the path crosses a newly seen obstacle, and periodically; fails when no
  path exists or no progress is made for `stuck_timeout_s`. Cancel returns to idle.

Not a Nav2 clone: no recovery behaviours, no velocity-space search, no costmap layers beyond these two.
"""

from __future__ import annotations

import heapq
import itertools
import math

import cv2
import numpy as np

from mission.core.se3 import wrap_angle
from mission.core.types import LaserScan, NavStatus, OccupancyGrid, Pose2D, Twist
from mission.sim.scenario import NavSpec

SQRT2 = math.sqrt(2.0)
SOFT_BAND_M = 0.35  # beyond the inflation, cost fades to nothing over this band
INFLATED_COST = 25.0
SOFT_COST = 4.0
LETHAL_MARGIN_M = 0.02
# Inside the lethal margin a move may lose a few millimetres (the grid is coarser than the world), but never past
# this much of it: re-checked each period, that allowance let a robot creep along a wall's end into contact.
FLOOR_MARGIN_M = 0.01
TURN_IN_PLACE_RAD = 0.9
SAFETY_HORIZON_S = 0.6


class Costmap:
    """Static obstacles from the map, dynamic ones from the lidar, and the distance field over both."""

    def __init__(self, grid: OccupancyGrid, robot_radius: float, inflation_m: float) -> None:
        self.grid = grid
        self.res = grid.resolution
        self.static = grid.data != 0  # occupied or unknown
        self.seen = np.zeros_like(self.static)
        self.robot_radius = robot_radius
        self.inflation_m = inflation_m
        self.version = 0
        self._recompute()

    def _recompute(self) -> None:
        free = (~(self.static | self.seen)).astype(np.uint8)
        self.dist = cv2.distanceTransform(free, cv2.DIST_L2, 5).astype(np.float32) * self.res
        r_lethal = self.robot_radius + LETHAL_MARGIN_M
        r_infl = self.robot_radius + self.inflation_m
        self.lethal = self.dist < r_lethal
        self.inflated = self.dist < r_infl
        cost = np.ones_like(self.dist)
        soft = np.clip(1.0 - (self.dist - r_infl) / SOFT_BAND_M, 0.0, 1.0)
        cost += SOFT_COST * soft
        cost[self.inflated] += INFLATED_COST
        cost[self.lethal] = np.inf
        self.cost = cost
        self.version += 1

    def cell(self, x: float, y: float) -> tuple[int, int]:
        return self.grid.world_to_cell(x, y)

    def in_bounds(self, rc: tuple[int, int]) -> bool:
        return self.grid.in_bounds(*rc)

    def clearance_at(self, x: float, y: float) -> float:
        """Distance (m) from (x, y) to the nearest obstacle cell, interpolated between cell centres (so it
        changes smoothly as the robot moves, not in 5 cm steps); 0 outside the map."""
        r, c = self.grid.world_to_grid(x, y)
        r0, c0 = math.floor(r - 0.5), math.floor(c - 0.5)
        h, w = self.dist.shape
        if r0 < 0 or c0 < 0 or r0 + 1 >= h or c0 + 1 >= w:
            return 0.0
        fr, fc = r - 0.5 - r0, c - 0.5 - c0
        d = self.dist
        top = d[r0, c0] * (1 - fc) + d[r0, c0 + 1] * fc
        bottom = d[r0 + 1, c0] * (1 - fc) + d[r0 + 1, c0 + 1] * fc
        return float(top * (1 - fr) + bottom * fr)

    @property
    def lethal_radius(self) -> float:
        return self.robot_radius + LETHAL_MARGIN_M

    def update_scan(self, pose: Pose2D, scan: LaserScan) -> np.ndarray:
        """Mark lidar hits, clear cells the beams passed through, and refresh the distance field. Returns the
        hits (N×2, map metres, placed from `pose`)."""
        ang = pose.yaw + scan.angles
        rng = np.asarray(scan.ranges, dtype=np.float64)
        hit = np.isfinite(rng) & (rng < scan.range_max) & (rng >= scan.range_min)
        reach = np.where(hit, rng, scan.range_max)
        # Clear along each beam up to half a cell short of its end.
        step = self.res * 0.7
        n = int(scan.range_max / step) + 1
        ts = np.arange(n) * step
        along = ts[None, :] < (reach[:, None] - self.res)
        xs = pose.x + ts[None, :] * np.cos(ang)[:, None]
        ys = pose.y + ts[None, :] * np.sin(ang)[:, None]
        rows, cols = self._cells(xs[along], ys[along])
        self.seen[rows, cols] = False
        hits = np.column_stack([pose.x + rng[hit] * np.cos(ang[hit]), pose.y + rng[hit] * np.sin(ang[hit])])
        rows, cols = self._cells(hits[:, 0], hits[:, 1])
        self.seen[rows, cols] = True
        self.seen &= ~self.static
        self._recompute()
        return hits

    def _cells(self, xs: np.ndarray, ys: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        rows, cols = self.grid.world_to_cells(xs, ys)
        ok = (rows >= 0) & (rows < self.static.shape[0]) & (cols >= 0) & (cols < self.static.shape[1])
        return rows[ok], cols[ok]

    def nearest_comfortable(self, rc: tuple[int, int], toward: tuple[int, int]) -> tuple[int, int] | None:
        """The closest cell to rc outside the inflation (rc itself when it already is).

        Among cells (almost) equally close to rc, the one nearest `toward` (the robot) wins, so a goal
        on an obstacle ends on the robot's side of it rather than behind it.
        """
        if self.in_bounds(rc) and not self.inflated[rc]:
            return rc
        free = np.argwhere(~self.inflated)
        if len(free) == 0:
            return None
        d = np.hypot(free[:, 0] - rc[0], free[:, 1] - rc[1])
        near = free[d <= d.min() + 1.5]
        d_robot = (near[:, 0] - toward[0]) ** 2 + (near[:, 1] - toward[1]) ** 2
        r, c = near[int(np.argmin(d_robot))]
        return int(r), int(c)

    def segment_clear(self, a: tuple[float, float], b: tuple[float, float], *, comfortable: bool = True) -> bool:
        """True when the straight segment a → b stays out of lethal (and, if asked, inflated) cells."""
        length = math.hypot(b[0] - a[0], b[1] - a[1])
        n = max(2, int(length / (self.res * 0.5)) + 1)
        xs = np.linspace(a[0], b[0], n)
        ys = np.linspace(a[1], b[1], n)
        rows, cols = self._cells(xs, ys)
        if len(rows) < n:
            return False
        mask = self.inflated if comfortable else self.lethal
        return not bool(mask[rows, cols].any())


def astar(cost: np.ndarray, start: tuple[int, int], goal: tuple[int, int]) -> list[tuple[int, int]] | None:
    """8-connected A* over a cost grid (inf = impassable) with the octile heuristic."""
    h, w = cost.shape
    flat = cost.ravel().tolist()
    s, g = start[0] * w + start[1], goal[0] * w + goal[1]
    if math.isinf(flat[g]):
        return None
    gr, gc = goal
    moves = [(-1, 0, 1.0), (1, 0, 1.0), (0, -1, 1.0), (0, 1, 1.0),
             (-1, -1, SQRT2), (-1, 1, SQRT2), (1, -1, SQRT2), (1, 1, SQRT2)]  # fmt: skip
    best = {s: 0.0}
    parent = {s: -1}
    heap = [(0.0, 0.0, s)]
    closed = set()
    while heap:
        _, gcost, cur = heapq.heappop(heap)
        if cur in closed:
            continue
        if cur == g:
            path = []
            while cur != -1:
                path.append(divmod(cur, w))
                cur = parent[cur]
            return path[::-1]
        closed.add(cur)
        r, c = divmod(cur, w)
        here = flat[cur] if cur != s else 1.0
        for dr, dc, step in moves:
            nr, nc = r + dr, c + dc
            if nr < 0 or nr >= h or nc < 0 or nc >= w:
                continue
            nxt = nr * w + nc
            cn = flat[nxt]
            if cn == math.inf or nxt in closed:
                continue
            ng = gcost + step * 0.5 * (here + cn)
            if ng < best.get(nxt, math.inf):
                best[nxt] = ng
                parent[nxt] = cur
                ddr, ddc = abs(nr - gr), abs(nc - gc)
                hh = (ddr + ddc) + (SQRT2 - 2) * min(ddr, ddc)
                heapq.heappush(heap, (ng + hh, ng, nxt))
    return None


class Navigator:
    """Goal in, twist out, status on the side (what Nav2's NavigateToPose gives a behaviour tree)."""

    def __init__(self, grid: OccupancyGrid, robot_radius: float, spec: NavSpec, max_v: float, max_w: float) -> None:
        self.spec = spec
        self.costmap = Costmap(grid, robot_radius, spec.inflation_m)
        self.max_v = min(spec.max_v, max_v)
        self.max_w = min(spec.max_w, max_w)
        self.status = NavStatus.IDLE
        self.goal: Pose2D | None = None
        self.target_xy: tuple[float, float] | None = None  # goal position after moving it out of obstacles
        self.path: list[tuple[float, float]] = []
        self.reason = ""
        self._planned_at = -math.inf
        self._planned_version = -1
        self._at_goal = False
        self._best_dist = math.inf
        self._progress_at = 0.0
        self.plans = 0
        # The newest scan's returns, placed from the pose the robot believed it had then: the safety stop's
        # second opinion, as Nav2's collision monitor is. The map's cells are placed by the pose estimate,
        # off by the localization's few centimetres (and cut to 5 cm cells), while the scan measures from the
        # robot itself: following under AMCL's noise (typical), a robot clipped a rack's corner it believed
        # 2 cm further off (aisle seed 5003, six contacts).
        self._hits = np.empty((0, 2))

    # -- commands ------------------------------------------------------------------------------------
    def set_goal(self, goal: Pose2D, now: float) -> None:
        self.goal = goal
        self.status = NavStatus.RUNNING
        self.reason = ""
        self.path = []
        self._at_goal = False
        self._best_dist = math.inf
        self._progress_at = now
        self._planned_at = -math.inf

    def cancel(self) -> None:
        self.goal = None
        self.path = []
        self.target_xy = None
        if self.status == NavStatus.RUNNING:
            self.status = NavStatus.IDLE

    def update_scan(self, pose: Pose2D, scan: LaserScan) -> None:
        self._hits = self.costmap.update_scan(pose, scan)

    def clearance(self, points: np.ndarray) -> np.ndarray:
        """The clearance (m) at each of `points` (N×2, map metres): the costmap's, or the distance to the
        newest scan's nearest return where that is smaller."""
        cm = self.costmap
        out = np.array([cm.clearance_at(float(x), float(y)) for x, y in points])
        if len(self._hits):
            d = np.hypot(points[:, None, 0] - self._hits[None, :, 0], points[:, None, 1] - self._hits[None, :, 1])
            out = np.minimum(out, d.min(axis=1))
        return out

    def _clearance_at(self, x: float, y: float) -> float:
        return float(self.clearance(np.array([[x, y]]))[0])

    # -- planning ------------------------------------------------------------------------------------
    def _plan(self, pose: Pose2D, now: float) -> bool:
        assert self.goal is not None
        cm = self.costmap
        self._planned_at = now
        self._planned_version = cm.version
        self.plans += 1
        goal_rc = cm.nearest_comfortable(cm.cell(self.goal.x, self.goal.y), cm.cell(pose.x, pose.y))
        if goal_rc is None:
            return self._fail("no free space near the goal")
        gx, gy = cm.grid.cell_to_world(*goal_rc)
        if goal_rc == cm.cell(self.goal.x, self.goal.y):
            gx, gy = self.goal.x, self.goal.y
        self.target_xy = (gx, gy)
        start = (pose.x, pose.y)
        if cm.segment_clear(start, (gx, gy)):
            self.path = [start, (gx, gy)]
            return True
        start_rc = cm.cell(*start)
        if not cm.in_bounds(start_rc):
            return self._fail("robot is outside the map")
        cells = astar(cm.cost, start_rc, goal_rc)
        if cells is None and cm.lethal[start_rc]:
            # The robot (or its pose estimate: an AMCL jump under `typical`) stands in an obstacle's lethal
            # margin, where every neighbour is impassable too: drive out to the nearest comfortable cell first.
            # Failing instead froze the robot for good, and AMCL, which corrects only after motion, never
            # moved the estimate back out (hide_and_wait seed 5029, typical).
            out_rc = cm.nearest_comfortable(start_rc, goal_rc)
            if out_rc is not None:
                cells = astar(cm.cost, out_rc, goal_rc)
                if cells is not None:
                    cells = [start_rc, *cells]
        if cells is None:
            return self._fail("no path to the goal")
        pts = [start, *[cm.grid.cell_to_world(r, c) for r, c in cells[1:-1]], (gx, gy)]
        self.path = self._string_pull(pts)
        return True

    def _string_pull(self, pts: list[tuple[float, float]]) -> list[tuple[float, float]]:
        out = [pts[0]]
        i = 0
        while i < len(pts) - 1:
            j = len(pts) - 1
            while j > i + 1 and not self.costmap.segment_clear(pts[i], pts[j]):
                j -= 1
            out.append(pts[j])
            i = j
        return out

    def _fail(self, why: str) -> bool:
        self.status = NavStatus.FAILED
        self.reason = why
        self.path = []
        return False

    def _path_blocked(self) -> bool:
        return any(not self.costmap.segment_clear(a, b, comfortable=False) for a, b in itertools.pairwise(self.path))

    # -- control -------------------------------------------------------------------------------------
    def command(self, pose: Pose2D, now: float) -> Twist:
        """The twist for this control period (zero unless a goal is running)."""
        if self.status != NavStatus.RUNNING or self.goal is None:
            return Twist(0.0, 0.0)
        sp = self.spec
        if not self._at_goal:
            need = not self.path or now - self._planned_at >= sp.replan_period_s
            if not need and self._planned_version != self.costmap.version and self._path_blocked():
                need = True
            if need and not self._plan(pose, now):
                return Twist(0.0, 0.0)
            assert self.target_xy is not None
            dist = math.hypot(self.target_xy[0] - pose.x, self.target_xy[1] - pose.y)
            if dist < self._best_dist - 0.05:
                self._best_dist = dist
                self._progress_at = now
            elif now - self._progress_at > sp.stuck_timeout_s:
                self._fail(f"no progress for {sp.stuck_timeout_s:g} s")
                return Twist(0.0, 0.0)
            if dist <= sp.goal_tolerance_m:
                self._at_goal = True
            else:
                return self._pursue(pose, dist)
        err = wrap_angle(self.goal.yaw - pose.yaw)
        if abs(err) <= sp.yaw_tolerance_rad:
            self.status = NavStatus.SUCCEEDED
            self.path = []
            return Twist(0.0, 0.0)
        return Twist(0.0, math.copysign(min(self.max_w, max(0.3, 2.0 * abs(err))), err))

    def _lookahead_point(self, pose: Pose2D) -> tuple[float, float]:
        """The next path corner, dropped once the robot is within half the look-ahead of it.

        Aiming at corners rather than at a point further along the path keeps the robot on the
        string-pulled segments, which keep the inflation distance from obstacles; cutting corners
        round an obstacle's edge is what brings a pure-pursuit robot into it.
        """
        while len(self.path) > 2 and math.hypot(self.path[1][0] - pose.x, self.path[1][1] - pose.y) < (
            0.5 * self.spec.lookahead_m
        ):
            self.path.pop(0)
        return self.path[1] if len(self.path) > 1 else self.path[-1]

    def _pursue(self, pose: Pose2D, dist: float) -> Twist:
        lx, ly = self._lookahead_point(pose)
        dx, dy = lx - pose.x, ly - pose.y
        alpha = wrap_angle(math.atan2(dy, dx) - pose.yaw)
        if abs(alpha) > TURN_IN_PLACE_RAD:
            return Twist(0.0, math.copysign(min(self.max_w, max(0.4, 1.5 * abs(alpha))), alpha))
        v = self.max_v * (1.0 - 0.6 * abs(alpha) / TURN_IN_PLACE_RAD)
        v = min(v, max(0.08, 0.9 * dist))  # slow down for the goal
        ld = max(math.hypot(dx, dy), 1e-3)
        w = max(-self.max_w, min(self.max_w, 2.0 * v * math.sin(alpha) / ld))
        if self._unsafe(pose, v, w):
            self._planned_at = -math.inf  # replan next period; meanwhile edge away, or turn towards the aim point
            escape = self._escape(pose, (lx, ly))
            if escape is not None:
                return escape
            return Twist(0.0, math.copysign(min(self.max_w, max(0.3, 1.5 * abs(alpha))), alpha))
        return Twist(v, w)

    def _escape(self, pose: Pose2D, aim: tuple[float, float]) -> Twist | None:
        """A safe twist that gets the robot on when pure pursuit's is not: the best of a few sampled arcs by
        progress toward `aim` plus clearance gained, or backing straight off; None when none is safe and useful.

        Pure pursuit aims along the path, and a path that starts beside something (a cart that stopped next to
        the robot) grazes it: the safety stop then holds the robot turning on the spot for ever, while a
        slightly different arc, or a step back, would free it (what Nav2's DWB controller finds by sampling)."""
        clear0 = self._clearance_at(pose.x, pose.y)
        if clear0 >= self.costmap.robot_radius + self.spec.inflation_m:
            return None  # not hemmed in: turning to the aim point is the right thing
        best, best_score = None, 0.0
        before = math.hypot(aim[0] - pose.x, aim[1] - pose.y)
        for v, w in [
            *(
                (v, w)
                for v in (0.5 * self.max_v, 0.25 * self.max_v)
                for w in np.linspace(-0.8 * self.max_w, 0.8 * self.max_w, 9)
            ),
            (-0.1, 0.0),
        ]:
            if self._unsafe(pose, v, w, clear0):
                continue
            x, y = _rollout(pose, v, w)[-1]
            gained = self._clearance_at(x, y) - clear0
            score = (before - math.hypot(aim[0] - x, aim[1] - y)) + 0.5 * gained if v > 0 else gained
            if score > best_score + 1e-6:
                best, best_score = Twist(float(v), float(w)), score
        return best

    def _unsafe(self, pose: Pose2D, v: float, w: float, clear_now: float | None = None) -> bool:
        """Would driving (v, ω) for the safety horizon bring the robot closer to an obstacle than allowed?

        Moves that do not reduce the clearance are always allowed, so a robot that ended up close to
        something (the grid is coarser than the world) can still drive away from it. Inside the lethal margin a
        move may lose up to 5 mm, but not below the floor (radius + FLOOR_MARGIN_M): the allowance is granted
        afresh every period, and an escape arc that lost its 5 mm each time crept along a partition's end into
        contact (search_corner seed 5235, typical). `clear_now` is the clearance where the robot stands, when the
        caller has it (the escape tries ~20 arcs from the same pose).
        """
        ahead = self.clearance(np.array(_rollout(pose, v, w)))
        now = self._clearance_at(pose.x, pose.y) if clear_now is None else clear_now
        floor = self.costmap.robot_radius + FLOOR_MARGIN_M
        losing = (ahead < self.costmap.lethal_radius) & (ahead < now - 0.005)
        below_floor = (ahead < floor) & (ahead < now)
        return bool(np.any(losing | below_floor))


def _rollout(pose: Pose2D, v: float, w: float, steps: int = 6) -> list[tuple[float, float]]:
    """Where driving (v, ω) from `pose` puts the robot over the safety horizon, in `steps` steps."""
    x, y, yaw = pose.x, pose.y, pose.yaw
    dt = SAFETY_HORIZON_S / steps
    out = []
    for _ in range(steps):
        yaw += w * dt
        x += v * dt * math.cos(yaw)
        y += v * dt * math.sin(yaw)
        out.append((x, y))
    return out
