"""PursueLastSeen: the LOST state that looks — go where the target can be seen again, camera on it.

When the target vanishes behind something, where it went is its last position carried on along its last
velocity for ``horizon_s`` (the walk stops where it could not go on: a wall). The leaf drives to the
nearest place, by the path the robot can drive, from which the camera sees that walk — its end and its
middle, with a cell of margin, so the robot peeks round the edge of the occluder rather than stopping on
the shadow's border — and arrives facing the predicted position. Where a place already sees it (the
occluder has moved away, or the robot stands at the corner) that place is where the robot stands, turned
toward it.

The loss timer is the detour's: its path length on the map over ``speed_mps``, plus the turn and
``look_s`` of looking, within [``min_timeout_s``, ``max_timeout_s``] — a long way round a pillar is given
the time it takes, a glance round a corner is not given more. It is set once per loss (when LOST is first
entered) and counted from then; after it, or ``look_s`` after arriving, the leaf fails and SEARCH takes
over; re-entering LOST before the target is seen again fails at once (one pursuit per loss).

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
from mission.behaviours.search_grid import SearchGrid, dilate, travel_distances, view_cells
from mission.behaviours.search_leaf import SearchLeaf, predicted_walk, turn_rate
from mission.core import se3
from mission.core.blackboard import MissionState
from mission.core.types import NavGoal, NavStatus, Pose2D, TargetTrack

ARRIVED_M = 0.25  # within this of the viewpoint, facing the target's way, counts as arrived
FACING_RAD = 0.35
MIN_STANDOFF_M = 0.7  # a viewpoint no closer than this to where the target went
TURN_RATE = 1.0  # rad/s assumed for the loss timer's turn


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
    done: str = ""  # why this loss's pursuit is over ('' while it goes on)
    fallback: bool = False  # no place sees `aim`: heading for the last position instead


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
        view, path_m = self._viewpoint(sg, robot, last, aim)
        fallback = view is None
        if view is None:  # nothing sees it: go to where it was last seen, as close as FollowTarget would
            view = approach_goal((robot.x, robot.y), aim, 0.5)
            path_m = math.hypot(view.x - robot.x, view.y - robot.y)
        turn = abs(se3.wrap_angle(view.yaw - robot.yaw)) / TURN_RATE
        timeout = min(p.max_timeout_s, max(p.min_timeout_s, path_m / p.speed_mps + turn + p.look_s))
        return Pursuit(track.last_seen, last, aim, view, path_m, now + timeout, now, fallback=fallback)

    def _viewpoint(
        self, sg: SearchGrid, robot: Pose2D, last: tuple[float, float], aim: tuple[float, float]
    ) -> tuple[Pose2D | None, float]:
        """The nearest place (path length) that sees `aim` and the middle of the walk to it, and the path length."""
        p = self.params
        blocked = self.sight_blocked(sg, robot)
        mid = ((last[0] + aim[0]) / 2, (last[1] + aim[1]) / 2)
        sees = np.ones(sg.shape, dtype=bool)
        for point in (aim, mid):  # the places a point is seen from are the places it sees (same rays)
            sees &= view_cells(sg, blocked, point, 0.0, 2 * math.pi, p.max_standoff_m, min_range_m=0.05)
        sees &= ~dilate(~sees, 1)  # a cell of margin: the camera sees round the corner, not along its edge
        xs, ys = sg.centres()
        near = np.hypot(xs - aim[0], ys - aim[1])
        drivable = sg.robot_free(p.clearance_m) & ~blocked
        candidates = drivable & sees & (near >= MIN_STANDOFF_M)
        if not candidates.any():
            return None, 0.0
        dist = travel_distances(drivable, sg.cell(robot.x, robot.y), sg.resolution)
        cost = np.where(candidates, dist + 0.1 * near, np.inf)  # nearest by path; of equals, nearer the aim
        r, c = np.unravel_index(int(np.argmin(cost)), cost.shape)
        if not np.isfinite(cost[r, c]):
            return None, 0.0
        x, y = float(xs[r, c]), float(ys[r, c])
        here = math.hypot(x - robot.x, y - robot.y) <= sg.resolution * 1.5
        if here:
            x, y = robot.x, robot.y
        return Pose2D(x, y, math.atan2(aim[1] - y, aim[0] - x)), float(dist[r, c])

    # -- ticking ----------------------------------------------------------------------------------
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
        if now > plan.deadline:
            return self._finish(plan, belief, f"LOST: {p.target} not seen again within the loss timer "
                                f"{plan.deadline - plan.started:.1f} s ({plan.path_m:.1f} m detour to see {where})")
        v = plan.view
        robot = state.pose
        close = math.hypot(v.x - robot.x, v.y - robot.y) <= ARRIVED_M
        facing = abs(bearing_to(robot, plan.aim)) <= FACING_RAD
        if plan.arrived_at is None and close and facing:
            plan.arrived_at = now
        if plan.arrived_at is not None:
            if now - plan.arrived_at >= p.look_s:
                seen_from = f"({v.x:.2f}, {v.y:.2f})"
                return self._finish(plan, belief, f"LOST: looked from {seen_from} toward {where}, where "
                                    f"{p.target} went: not there")
            self.drive(0.0, turn_rate(bearing_to(robot, plan.aim), 0.8) if not facing else 0.0)
            self.feedback_message = f"LOST: looking toward {where}, {now - plan.arrived_at:.1f} s of {p.look_s:g} s"
            return py_trees.common.Status.RUNNING
        if self._goal is None:
            self._goal = self.navigate(v)
        else:
            outcome = self.nav_outcome(self._goal)
            if outcome == NavStatus.FAILED:
                return self._finish(plan, belief, f"LOST: cannot reach ({v.x:.2f}, {v.y:.2f}) to see {where}: "
                                    f"{self.nav_reason() or 'navigation failed'}")
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
