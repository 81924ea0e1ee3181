"""PursueLastSeen: the LOST state that looks — go where the target can be seen again, camera on it.

When the target vanishes behind something, where it went is its last position carried on along its last
velocity for ``horizon_s`` (the walk stops where it could not go on: a wall). The leaf drives to the
nearest place, by the path the robot can drive, from which the camera sees that walk — its end and its
middle, with a cell of margin, so the robot peeks round the edge of the occluder rather than stopping on
the shadow's border — and arrives facing the predicted position. Where a place already sees it (the
occluder has moved away, or the robot stands at the corner) that place is where the robot stands, turned
toward it. The walk is a guess — a target that went through a doorway and turned along the wall is not on
it — so of the places that see it, one that also sees more of where the target could have walked unseen (the
peek's hidden set, below) per second of driving is taken instead, and swept across from the walk's side.

When there is no heading to go by — the target stood still, or it was turning (a marker on the face of a
target that turns at a corner swings round its centre, and a velocity fitted over that points the wrong
way) — the leaf peeks round the edge instead: of the places the target could have walked to in
``horizon_s`` that the camera cannot see from where the robot stands, it drives to the place that sees the
most of them per second of driving, and sweeps the camera across them there. A sweep starts from whichever
of its edges the camera faces more nearly on arriving: a drive that ends facing the far edge does not turn
back to the near one first (hide_and_wait seed 5002, typical: 130° away from the target, and back).

The loss timer is the detour's: its path length on the map over ``speed_mps``, plus the turn and
``look_s`` of looking, within [``min_timeout_s``, ``max_timeout_s``] — a long way round a pillar is given
the time it takes, a glance round a corner is not given more. It is set once per loss (when LOST is first
entered) and counted from then, and it bounds the way there: once the robot has arrived, the look it came
for (the sweep round the edge, then ``look_s``) is given in full, the timer or not. The navigator drives
slower than ``speed_mps`` through turns and near obstacles, and a look cut short 100° before it faced the
place it was turning to is the drive wasted (hide_and_wait seed 5002, typical: LOST arrived 2 s before its
timer, turning west to where the target stood in plain sight; SEARCH then turned the other way first and
found it 17 s after the loss). After the look, or the timer on the way, the leaf fails and SEARCH takes
over; re-entering LOST before the target is seen again fails at once (one pursuit per loss).

When the target left through the image's side, the leaf first glances that way, on the spot: it turns to where
the target's last velocity carries it and GLANCE_PAST_RAD on, since a velocity fitted over the last second lags
a target that is turning.

Every tick it keeps the loss's belief (behaviours/belief.py), so SEARCH knows what LOST has looked at.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import py_trees

from mission.behaviours.approach import approach_goal, bearing_to
from mission.behaviours.ports import port
from mission.behaviours.search_grid import SearchGrid, dilate, ray_masses, travel_distances, view_cells
from mission.behaviours.search_leaf import MOVER_HORIZON_S, SearchLeaf, predicted_walk, turn_rate
from mission.core import se3
from mission.core.blackboard import MissionState
from mission.core.types import NavGoal, NavStatus, Pose2D, TargetTrack

ARRIVED_M = 0.25  # within this of the viewpoint, facing the target's way, counts as arrived
# … and within this, facing anywhere, when a sweep follows: where a navigator stops driving and turns to the
# goal's heading (the sim's goal tolerance; at 0.25 m the robot stopped short of a doorway it was to look
# through, two_rooms seed 5005 under typical)
SWEEP_ARRIVED_M = 0.15
FACING_RAD = 0.35
MIN_STANDOFF_M = 0.7  # a viewpoint no closer than this to where the target went
TURN_RATE = 1.0  # rad/s assumed for the loss timer's turn
# The glance turns this far past where the target's last velocity carries it, as SEARCH a's turn does: a velocity
# fitted over the last second lags a target that is turning. Without it, a target lost off the image's side as it
# turned south past a partition's end was glanced at 46° off, east, where the fit pointed, and found 5.9 s later
# from a drive to see that walk; SEARCH a's turn had found it in 0.7 s (target_gone seed 5, ideal, with REACH_M
# 1.5 m in behaviours/line_of_sight.py).
GLANCE_PAST_RAD = math.radians(30.0)
# Peeking round an edge (no heading to go by): what the target could have walked to unseen, and where from.
PEEK_SPEED_MPS = 1.0
STAY_M = 0.5  # a heading's viewpoint nearer than this (by path) is where the robot stands: peek instead
PEEK_MIN_CELLS = 4  # fewer hidden cells than this: nothing to peek round
PEEK_SPACING_M = 0.2
PEEK_MAX_TRAVEL_M = 4.0
PEEK_SEEN_FROM_HERE_M = 2.0  # beyond max_standoff_m: how far the robot's own view counts as seeing
PEEK_REACH_M = 1.0  # beyond max_standoff_m: how far a viewpoint's view counts
PEEK_MIN_SEEN = 0.5  # a place must see at least half of what the best place sees
PEEK_AIM_M = 1.5  # the point faced: this far along the middle of the view
PEEK_ARC_FRACTION = 0.05  # directions seeing this fraction of the best one's hidden cells are swept across
PEEK_EDGE_RAD = math.radians(10.0)  # a sweep ends this far inside the view past the arc's edge: a marker must
# be whole in the image to be read, so the image's outer strip does not count as seeing
RAYS = 72
WAIT_STEP_S = 0.5  # a view a mover hides is tried again every this much of its predicted passing


@dataclass
class Pursuit:
    """One loss's plan: where the target went, where to see it from, and the time allowed."""

    episode: float  # the track's last_seen
    last: tuple[float, float]
    aim: tuple[float, float]  # where the target is predicted to be
    view: Pose2D  # where to look from, facing `aim`
    path_m: float  # the detour's length on the map
    deadline: float
    started: float
    arrived_at: float | None = None
    sweep_to: float | None = None  # peeking: after facing `aim`, turn to this heading across what it hides
    sweep_from: float | None = None  # … or, arrived facing elsewhere: first to this edge (the nearer), then across
    swept: bool = False
    done: str = ""  # why this loss's pursuit is over ('' while it goes on)
    fallback: bool = False  # no place sees `aim`: heading for the last position instead
    glance_to: float | None = None  # it left through the view's side: first turn to this heading, where it was
    opens_at: float | None = None  # a mover hides `aim` from `view` until about then: look on until then + look_s


class PursueLastSeen(SearchLeaf):
    """LOST: drive to the nearest place that sees where the target went (facing it); the loss timer is the detour's."""

    @dataclass(frozen=True, kw_only=True)
    class Params:
        target: str = port("target", "name of the target (a key of perception.targets)")
        horizon_s: float = port(2.0, "carry the target on along its last velocity this long (stopping at walls)")
        speed_mps: float = port(0.35, "the robot's average speed on a detour: the loss timer is path / speed + …")
        look_s: float = port(1.0, "look from the viewpoint this long before SEARCH takes over")
        min_timeout_s: float = port(2.0, "the loss timer is at least this")
        max_timeout_s: float = port(12.0, "and at most this")
        max_standoff_m: float = port(3.0, "the viewpoint is at most this far from where the target went")
        clearance_m: float = port(0.35, "viewpoints keep this far from the map's obstacles (robot radius + margin)")

        def __post_init__(self) -> None:
            if min(self.horizon_s, self.look_s, self.min_timeout_s) < 0 or self.speed_mps <= 0:
                raise ValueError("expected horizon_s, look_s, min_timeout_s ≥ 0 and speed_mps > 0")
            if self.max_timeout_s < self.min_timeout_s:
                raise ValueError(f"max_timeout_s {self.max_timeout_s:g} < min_timeout_s {self.min_timeout_s:g}")

    NODE_TYPE = "Action"
    params: Params

    def __init__(self, name: str | None = None, **ports: Any) -> None:
        super().__init__(name, **ports)
        self.pursuit: Pursuit | None = None
        self._goal: NavGoal | None = None

    def initialise(self) -> None:
        self._goal = None
        self.feedback_message = f"LOST: {self.params.target}"

    # -- planning ---------------------------------------------------------------------------------
    def _plan(self, track: TargetTrack, robot: Pose2D, now: float) -> Pursuit:
        p = self.params
        assert track.pose_map is not None and track.last_seen is not None
        last = (float(track.pose_map[0, 3]), float(track.pose_map[1, 3]))
        sg = self.grid()
        if sg is None:  # no map: hold the last position (the old LOST), for the shortest timer
            goal = approach_goal((robot.x, robot.y), last, 0.5)
            return Pursuit(track.last_seen, last, last, goal, 0.0, now + p.min_timeout_s, now, fallback=True)
        _, aim = predicted_walk(sg, sg.target_free(), track, p.horizon_s)
        view, path_m, sweep_to, open_s = None, 0.0, None, 0.0
        if aim != last:
            view, path_m, sweep_to, open_s = self._viewpoint(sg, robot, last, aim)
            if sweep_to is not None or (view is not None and abs(bearing_to(view, aim)) > FACING_RAD):
                aim = _faced(view)  # type: ignore[arg-type]
        # No heading, or one whose walk is seen from where the robot stands already (it ended at the corner):
        # look round the edge it vanished behind. (Not when a passing mover is what hides it: wait it out.)
        waits = open_s - path_m / p.speed_mps > WAIT_STEP_S / 2
        if view is None or (path_m < STAY_M and not waits):
            peek = self._peek(sg, robot, last)
            if peek is not None:
                view, path_m, sweep_to = peek
                open_s = 0.0
                aim = _faced(view)
            elif view is None:  # nothing hidden to peek round: where the last position is seen from
                view, path_m, sweep_to, open_s = self._viewpoint(sg, robot, last, aim)
        fallback = view is None
        if view is None:  # nothing sees it: go to where it was last seen, as close as FollowTarget would
            view = approach_goal((robot.x, robot.y), aim, 0.5)
            path_m = math.hypot(view.x - robot.x, view.y - robot.y)
        turn = abs(se3.wrap_angle(view.yaw - robot.yaw)) / TURN_RATE
        glance = self.glance_heading(track, robot)
        if glance is not None:  # on past it, the way it turns
            glance = se3.wrap_angle(glance + math.copysign(GLANCE_PAST_RAD, se3.wrap_angle(glance - robot.yaw)))
            turn += 2 * abs(se3.wrap_angle(glance - robot.yaw)) / TURN_RATE  # there and back
        if sweep_to is not None:
            turn += abs(se3.wrap_angle(sweep_to - view.yaw)) / TURN_RATE
        wait = max(0.0, open_s - path_m / p.speed_mps) if not fallback else 0.0
        opens_at = now + open_s if wait > WAIT_STEP_S / 2 else None
        timeout = min(p.max_timeout_s, max(p.min_timeout_s, path_m / p.speed_mps + wait + turn + p.look_s))
        return Pursuit(
            track.last_seen,
            last,
            aim,
            view,
            path_m,
            now + timeout,
            now,
            fallback=fallback,
            sweep_to=sweep_to,
            glance_to=glance,
            opens_at=opens_at,
        )

    def _viewpoint(
        self, sg: SearchGrid, robot: Pose2D, last: tuple[float, float], aim: tuple[float, float]
    ) -> tuple[Pose2D | None, float, float | None, float]:
        """The place that first sees `aim` and the middle of the walk to it, the path length there, None,
        and the seconds from now until it sees them; or a place a little farther that also sees round the
        edge, facing the edge nearer the walk, and the heading to sweep on to (see _sees_more_round_the_edge).

        Without movers the first to see is the nearest by path (seconds = path / ``speed_mps``). A crossing
        cart hides a moving window, not its whole path: a place is taken to see at the first half second,
        from when the robot can be there, at which the cart's predicted face (over a ``look_s`` look) is out
        of the way (waiting there if need be); so a place 1 m away that sees once the cart has moved on
        (2.8 s) beats one 2 m round behind the cart, reached with the camera turned away (6.1 s;
        moving_occluder seed 2015, typical). Past MOVER_HORIZON_S the cart's whole path still counts as in
        the way."""
        p = self.params
        blocked = self.sight_blocked(sg, robot)
        mid = ((last[0] + aim[0]) / 2, (last[1] + aim[1]) / 2)
        xs, ys = sg.centres()
        near = np.hypot(xs - aim[0], ys - aim[1])
        drivable = sg.robot_free(p.clearance_m) & ~blocked & ~self.ahead_of_movers(sg, robot, p.clearance_m)
        stand = drivable & (near >= MIN_STANDOFF_M) & ~self.in_movers_way(sg, p.clearance_m)
        leave = self.with_room_to_leave(sg, robot, drivable, blocked, p.clearance_m)
        dist = travel_distances(leave, sg.cell(robot.x, robot.y), sg.resolution)
        arrive_s = dist / p.speed_mps

        def sees_through(through: np.ndarray) -> np.ndarray:
            sees = np.ones(sg.shape, dtype=bool)
            for point in (aim, mid):  # the places a point is seen from are the places it sees (same rays)
                sees &= view_cells(sg, through, point, 0.0, 2 * math.pi, p.max_standoff_m, min_range_m=0.05)
            return sees & ~dilate(~sees, 1)  # a cell of margin: the camera sees round the corner, not along its edge

        # Places that see whatever the movers do (their whole paths as walls) see on arrival.
        regardless = stand & sees_through(blocked | self.mover_paths(sg))
        open_s = np.where(regardless, arrive_s, np.inf)
        faces_now = self.movers_then(sg, 0.0, 0.0)
        if faces_now.any():
            still = blocked & ~dilate(faces_now, 1)  # all but the movers' faces stays where it is
            for t in np.arange(0.0, MOVER_HORIZON_S, WAIT_STEP_S):
                first = stand & np.isinf(open_s) & (arrive_s <= t + WAIT_STEP_S)
                if first.any():
                    first &= sees_through(still | self.movers_then(sg, t, p.look_s))
                    open_s[first] = np.maximum(arrive_s[first], t)
        candidates = np.isfinite(open_s)
        if not candidates.any():
            return None, 0.0, None, 0.0
        cost = np.where(candidates, open_s + 0.1 * near / p.speed_mps, np.inf)  # first to see; of equals, nearer
        r, c = np.unravel_index(int(np.argmin(cost)), cost.shape)
        # Round the edge is scored with the movers' whole paths as walls: it cannot weigh a mover's passing, so
        # a place that sees only once a mover has passed is taken as it is.
        better = None
        if regardless[r, c]:
            better = self._sees_more_round_the_edge(sg, robot, blocked, last, aim, candidates, dist, (int(r), int(c)))
        if better is not None:
            (r, c), first_yaw, sweep_to = better
            view = Pose2D(float(xs[r, c]), float(ys[r, c]), first_yaw)
            return view, float(dist[r, c]), sweep_to, float(open_s[r, c])
        x, y = float(xs[r, c]), float(ys[r, c])
        here = math.hypot(x - robot.x, y - robot.y) <= sg.resolution * 1.5
        if here:
            x, y = robot.x, robot.y
        return Pose2D(x, y, math.atan2(aim[1] - y, aim[0] - x)), float(dist[r, c]), None, float(open_s[r, c])

    def _hidden(self, sg: SearchGrid, robot: Pose2D, blocked: np.ndarray, last: tuple[float, float]) -> np.ndarray:
        """Bool H×W: the places the target could have walked to from `last` in ``horizon_s`` (at
        PEEK_SPEED_MPS, by the paths it can walk) that the camera cannot see from where the robot stands —
        within PEEK_SEEN_FROM_HERE_M beyond the standoff (what is merely far is not taken for hidden)."""
        p = self.params
        free = sg.target_free()
        walk_m = travel_distances(free, sg.cell(*last), sg.resolution)
        cam = self.camera_pose(robot)
        visible = view_cells(
            sg, blocked, (cam[0], cam[1]), 0.0, 2 * math.pi, p.max_standoff_m + PEEK_SEEN_FROM_HERE_M, min_range_m=0.05
        )
        return (walk_m <= PEEK_SPEED_MPS * p.horizon_s) & free & ~visible

    def _sees_more_round_the_edge(
        self,
        sg: SearchGrid,
        robot: Pose2D,
        blocked: np.ndarray,
        last: tuple[float, float],
        aim: tuple[float, float],
        candidates: np.ndarray,
        dist: np.ndarray,
        nearest: tuple[int, int],
    ) -> tuple[tuple[int, int], float, float | None] | None:
        """Of the places that see the predicted walk, the one that also sees, turning across it, most of what
        the target could have walked to unseen per second of driving — its cell, the heading to face first
        (the edge nearer the walk) and the one to sweep on to; None when that is the nearest.

        The walk is a guess: a target that turned at the corner it vanished behind (through a doorway and
        along the wall) is not on it. The nearest place that sees the walk often sees it through the gap
        only; one a little farther, in the gap, sees round both edges as well."""
        p = self.params
        hidden = self._hidden(sg, robot, blocked, last)
        if int(hidden.sum()) < PEEK_MIN_CELLS:
            return None
        rows, cols = np.mgrid[0 : sg.shape[0], 0 : sg.shape[1]]
        step = max(1, round(PEEK_SPACING_M / sg.resolution))
        lattice = candidates & (rows % step == 0) & (cols % step == 0) & (dist <= PEEK_MAX_TRAVEL_M)
        lattice[nearest] = True
        idx = np.argwhere(lattice)
        xs, ys = sg.centres()
        cx, cy = xs[idx[:, 0], idx[:, 1]], ys[idx[:, 0], idx[:, 1]]
        through = blocked | self.mover_paths(sg)  # a crossing cart will be in the way of the view by then
        masses = ray_masses(sg, through, hidden.astype(np.float32), cx, cy, RAYS, p.max_standoff_m + PEEK_REACH_M)
        score = masses.sum(axis=1) / (dist[idx[:, 0], idx[:, 1]] / p.speed_mps + 1.0)
        here = int(np.flatnonzero((idx[:, 0] == nearest[0]) & (idx[:, 1] == nearest[1]))[0])
        i = int(np.argmax(score))
        if not score[i] > score[here]:
            return None
        first, second = self._across(masses[i], math.atan2(aim[1] - cy[i], aim[0] - cx[i]))  # from the walk's side
        return (int(idx[i, 0]), int(idx[i, 1])), first, second

    def _peek(
        self, sg: SearchGrid, robot: Pose2D, last: tuple[float, float]
    ) -> tuple[Pose2D, float, float | None] | None:
        """Where to look round the edge the target vanished behind, when there is no heading to go by.

        The places it could have walked to in ``horizon_s`` (at PEEK_SPEED_MPS, by the paths it can walk)
        that the robot cannot see from where it stands are where it went; the place to drive to is the one
        that sees most of them, turning, per second of driving (ties: the nearer). (Sizing that walk by the
        time the robot takes to get there was tried: behind a long wall it makes the hidden set the whole far
        side, and the peek a slow half-turn sweep instead of a glance.) Returns that place facing one edge of
        what it hides, the path length, and the heading of the other edge when they are wider apart than the
        camera's field of view (to sweep across them), else None. None when the robot sees all of them already
        (it vanished in plain view: nothing to peek round)."""
        p = self.params
        blocked = self.sight_blocked(sg, robot)
        drivable = sg.robot_free(p.clearance_m) & ~blocked & ~self.ahead_of_movers(sg, robot, p.clearance_m)
        leave = self.with_room_to_leave(sg, robot, drivable, blocked, p.clearance_m)
        dist = travel_distances(leave, sg.cell(robot.x, robot.y), sg.resolution)
        rows, cols = np.mgrid[0 : sg.shape[0], 0 : sg.shape[1]]
        step = max(1, round(PEEK_SPACING_M / sg.resolution))
        cand = drivable & (rows % step == 0) & (cols % step == 0) & (dist <= PEEK_MAX_TRAVEL_M)
        cand &= ~self.in_movers_way(sg, p.clearance_m)
        idx = np.argwhere(cand)
        if not len(idx):
            return None
        xs, ys = sg.centres()
        cx, cy = xs[idx[:, 0], idx[:, 1]], ys[idx[:, 0], idx[:, 1]]
        travel = dist[idx[:, 0], idx[:, 1]]
        hidden = self._hidden(sg, robot, blocked, last)
        if int(hidden.sum()) < PEEK_MIN_CELLS:
            return None
        through = blocked | self.mover_paths(sg)  # a crossing cart will be in the way of the view by then
        masses = ray_masses(sg, through, hidden.astype(np.float32), cx, cy, RAYS, p.max_standoff_m + PEEK_REACH_M)
        seen = masses.sum(axis=1)  # all it hides that the place sees, turning across it
        score = seen / (travel / p.speed_mps + 1.0)
        score[seen < PEEK_MIN_SEEN * max(float(seen.max()), 1e-9)] = 0.0
        i = int(np.argmax(score))
        if not score[i] > 0:
            return None
        x, y = float(cx[i]), float(cy[i])
        first, second = self._across(masses[i], math.atan2(y - robot.y, x - robot.x))  # from the way it arrives
        return Pose2D(x, y, first), float(travel[i]), second

    def _across(self, masses: np.ndarray, start_near: float) -> tuple[float, float | None]:
        """(the heading to face first, the heading to sweep on to or None) to look across what `masses` (one
        place's directions) holds: its middle when one look covers it, else from the edge nearer
        `start_near` to the other."""
        ray = 2 * math.pi / RAYS
        lo, hi = _arc(masses > PEEK_ARC_FRACTION * float(masses.max()))
        half = self.hfov() / 2 - PEEK_EDGE_RAD
        if (hi - lo) * ray <= 2 * half:  # one look covers it: face its middle
            return se3.wrap_angle((lo + hi + 1) / 2 * ray), None
        edges = (se3.wrap_angle(lo * ray + half), se3.wrap_angle((hi + 1) * ray - half))
        first, second = sorted(edges, key=lambda a: abs(se3.wrap_angle(a - start_near)))
        return first, second

    # -- ticking ----------------------------------------------------------------------------------
    def _look(self, plan: Pursuit, robot: Pose2D, now: float) -> bool:
        """Peeking: turn across what the edge hides; True while turning (the look timer starts after)."""
        if plan.sweep_to is None or plan.swept:
            return False
        if plan.sweep_from is not None:
            error = se3.wrap_angle(plan.sweep_from - robot.yaw)
            if abs(error) > 0.1:
                self.drive(0.0, turn_rate(error, 0.8))
                self.feedback_message = (
                    f"LOST: turning to the edge of what it went behind, {math.degrees(abs(error)):.0f}° to go"
                )
                return True
            plan.sweep_from = None
        error = se3.wrap_angle(plan.sweep_to - robot.yaw)
        if abs(error) <= 0.1:
            plan.swept, plan.arrived_at = True, now
            return False
        self.drive(0.0, turn_rate(error, 0.8))
        self.feedback_message = f"LOST: looking round the edge it went behind, {math.degrees(abs(error)):.0f}° to go"
        return True

    def update(self) -> py_trees.common.Status:
        p = self.params
        track = self.track(p.target)
        if track is None or track.last_seen is None or track.pose_map is None:
            return self.fail(f"LOST: {p.target} was never placed in the map, nowhere to look")
        state = self.robot()
        if state is None:
            return self.fail(self.waiting_for_pose("LOST: "))
        now = self.now()
        plan = self.pursuit
        if plan is None or plan.episode != track.last_seen:
            plan = self.pursuit = self._plan(track, state.pose, now)
            self._goal = None
        if plan.done:
            return self.fail(plan.done)
        self.set_state(MissionState.LOST)
        belief = self.belief(track)
        where = f"({plan.aim[0]:.2f}, {plan.aim[1]:.2f})"
        if now > plan.deadline and plan.arrived_at is None:  # once there, the look is given in full
            return self._finish(
                plan,
                belief,
                f"LOST: {p.target} not seen again within the loss timer "
                f"{plan.deadline - plan.started:.1f} s ({plan.path_m:.1f} m detour to see {where})",
            )
        v = plan.view
        robot = state.pose
        if plan.glance_to is not None:  # first the glance toward where it left the view
            error = se3.wrap_angle(plan.glance_to - robot.yaw)
            if abs(error) > 0.1:
                self.drive(0.0, turn_rate(error, TURN_RATE))
                self.feedback_message = (
                    f"LOST: turning to where {p.target} left the view, {math.degrees(abs(error)):.0f}° to go"
                )
                return py_trees.common.Status.RUNNING
            plan.glance_to = None
        off = math.hypot(v.x - robot.x, v.y - robot.y)
        close = off <= ARRIVED_M
        facing = abs(bearing_to(robot, plan.aim)) <= FACING_RAD
        sweeping = plan.sweep_to is not None and off <= SWEEP_ARRIVED_M
        if plan.arrived_at is None and close and (facing or sweeping):
            plan.arrived_at = now
            if plan.sweep_to is not None:  # sweep from whichever edge the robot faces more nearly
                edges = sorted((plan.view.yaw, plan.sweep_to), key=lambda a: abs(se3.wrap_angle(a - robot.yaw)))
                plan.sweep_from, plan.sweep_to = edges
        if plan.arrived_at is not None:
            if self._look(plan, robot, now):
                return py_trees.common.Status.RUNNING
            if now - plan.arrived_at >= p.look_s and (plan.opens_at is None or now >= plan.opens_at + p.look_s):
                seen_from = f"({v.x:.2f}, {v.y:.2f})"
                return self._finish(
                    plan, belief, f"LOST: looked from {seen_from} toward {where}, where {p.target} went: not there"
                )
            self.drive(0.0, turn_rate(bearing_to(robot, plan.aim), 0.8) if not facing and not plan.swept else 0.0)
            self.feedback_message = f"LOST: looking toward {where}, {now - plan.arrived_at:.1f} s of {p.look_s:g} s"
            return py_trees.common.Status.RUNNING
        if self._goal is None:
            self._goal = self.navigate(v)
        else:
            outcome = self.nav_outcome(self._goal)
            if outcome == NavStatus.FAILED:
                return self._finish(
                    plan,
                    belief,
                    f"LOST: cannot reach ({v.x:.2f}, {v.y:.2f}) to see {where}: "
                    f"{self.nav_reason() or 'navigation failed'}",
                )
            if outcome == NavStatus.SUCCEEDED and not facing:  # arrived not quite facing: turn on the spot
                self.drive(0.0, turn_rate(bearing_to(robot, plan.aim), 0.8))
            else:
                self.resend_goal(self._goal)
        what = "the last position (nothing sees where it went)" if plan.fallback else f"see where it went, {where}"
        self.feedback_message = (
            f"LOST: to ({v.x:.2f}, {v.y:.2f}) to {what}; {plan.path_m:.1f} m detour, "
            f"{now - plan.started:.1f} s of {plan.deadline - plan.started:.1f} s"
        )
        return py_trees.common.Status.RUNNING

    def _finish(self, plan: Pursuit, belief: Any, why: str) -> py_trees.common.Status:
        plan.done = why
        if belief is not None:
            belief.log.append(f"LOST went {plan.path_m:.1f} m to look ({self.now() - plan.started:.0f} s)")
        return self.fail(why)


def _faced(view: Pose2D) -> tuple[float, float]:
    """The point a look from `view` is aimed at: PEEK_AIM_M along its heading (arrival waits to face it)."""
    return view.x + PEEK_AIM_M * math.cos(view.yaw), view.y + PEEK_AIM_M * math.sin(view.yaw)


def _arc(mask: np.ndarray) -> tuple[int, int]:
    """(first, last) index of the shortest circular run of directions holding every True of `mask` (last may
    exceed len(mask): it wraps)."""
    on = np.flatnonzero(mask)
    n = len(mask)
    if len(on) == 0:
        return 0, 0
    gaps = np.diff(np.concatenate([on, [on[0] + n]]))  # gap after each on-direction to the next
    k = int(np.argmax(gaps))  # the widest gap is outside the arc
    first = int(on[(k + 1) % len(on)])
    last = int(on[k]) if on[k] >= first else int(on[k]) + n
    return first, last
