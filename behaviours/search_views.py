"""Searching by moving: drive to the place that sees the most per second of driving, look round there, repeat.

Both rungs rank the same way and differ in what they look for:

* :class:`SearchBelief` (SEARCH b) looks where the target can be — the loss's belief (behaviours/belief.py:
  its last position grown at ``target_speed_mps``, minus what the camera has seen, weighted toward the way
  it was going);
* :class:`CoverUnseen` (SEARCH c) looks at the part of the map the camera has not seen since the loss, of
  what the target could have walked to — when the belief has led nowhere, cover the rest.

Ranking: candidate places are the cells the robot fits in, every ``spacing_m``, within ``max_travel_m``
of path (and the robot's own place). For each, the weight seen in every direction within the view range
(rays stopped by the map's obstacles, what the lidar sees, and where a crossing cart is going:
SearchLeaf.mover_paths) gives the best window of the camera's field
of view plus ``sweep_deg``; its score is that weight over the time to get there and sweep it (path length
over ``speed_mps``, the sweep at ``angular_speed``, a second of overhead). The robot drives to the best
(the navigator's goal, facing the window's heavier edge: the heaviest directions are looked at first),
sweeps the window, and ranks again; while it
drives it re-ranks every ``replan_s`` and changes its mind only for a place scoring 30 % better (and at
once when the camera has seen on the way what it was going to look at). A place it cannot reach is not
chosen again in this loss, and the next sweep is made at least ``RESWEEP_M`` from the last one while any place
there sees something (the front grows back beside a sweep at once, and a look at that from where the robot
stands is cheap, so a greedy ranking would sweep the same place again and again). The camera's view clears
the belief on every tick, driving or sweeping.

Each fails with a reason after ``timeout_s``, or when nothing is left to look at (SearchBelief: the belief
fell below ``min_mass`` of what it was, or no place sees any of it; CoverUnseen: ``done_fraction`` of the
reachable space has been seen, or no place sees any unseen cell), and the next rung takes over.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np
import py_trees

from mission.behaviours.belief import TargetBelief
from mission.behaviours.ports import port
from mission.behaviours.search_grid import best_window, dilate, ray_masses, travel_distances
from mission.behaviours.search_leaf import SearchLeaf, turn_rate
from mission.core import se3
from mission.core.blackboard import MissionState
from mission.core.types import NavGoal, NavStatus, Pose2D, TargetTrack

RAYS = 72  # directions round a candidate (5° each)
SWITCH_GAIN = 1.3  # a new place must score this much better to change the goal while driving
ARRIVED_M = 0.25
FACING_RAD = 0.3
OVERHEAD_S = 1.0  # per visit: stopping, settling, the navigator's final turn
BAD_RADIUS_M = 0.3  # goals the navigator failed on: no candidate this close in this loss
RESWEEP_M = 0.6  # no sweep this close to where the last one was made, while any place farther sees something
MIN_SEEN = 0.5  # a window seeing less than half a cell's weight is not worth a visit


@dataclass
class Visit:
    """Where a search is going and what it will look at there."""

    pose: Pose2D  # facing the window's heavier edge
    sweep_rad: float  # then turn this much (CCW +, CW −) to its other edge
    mass: float  # the weight its window sees (when chosen)
    score: float  # mass per second


@dataclass
class Hunt:
    """One loss's viewpoint search."""

    episode: float
    started: float
    phase: str = "plan"  # plan | drive (to the place) | face (at it: turn to the window) | sweep
    visit: Visit | None = None
    goal: NavGoal | None = None
    planned_at: float = -math.inf
    sweep_turned: float = 0.0
    yaw_prev: float | None = None
    visits: int = 0
    bad: list[tuple[float, float]] = field(default_factory=list)
    swept_at: tuple[float, float] | None = None  # where the last sweep was made
    done: str = ""


class ViewpointSearch(SearchLeaf):
    """Base of the viewpoint searches: subclasses say what to look for and when nothing is left."""

    RUNG: ClassVar[str] = "?"
    WHAT: ClassVar[str] = "weight"  # what the feedback calls the weight ("where it can be", "unseen space")

    def __init__(self, name: str | None = None, **ports: Any) -> None:
        super().__init__(name, **ports)
        self.hunt: Hunt | None = None

    # -- what subclasses decide -------------------------------------------------------------------
    def keep(self, track: TargetTrack) -> TargetBelief | None:
        """The loss's belief, brought up to now (subclasses pass their ports)."""
        return self.belief(track)

    def weights(self, belief: TargetBelief) -> np.ndarray:
        raise NotImplementedError

    def exhausted(self, belief: TargetBelief) -> str | None:
        """Why nothing is left to look at ('' / None: there is)."""
        return None

    def summary(self, hunt: Hunt, now: float) -> str:
        raise NotImplementedError

    # -- the lifecycle ----------------------------------------------------------------------------
    def initialise(self) -> None:
        track = self.track(self.params.target)
        episode = None if track is None else track.last_seen
        if self.hunt is not None and self.hunt.episode == episode:
            self.hunt.phase = "plan" if self.hunt.phase in ("drive", "face") else self.hunt.phase
            self.hunt.goal = None
            self.hunt.yaw_prev = None
            return
        self.hunt = None if episode is None else Hunt(episode, self.now())

    def update(self) -> py_trees.common.Status:
        p = self.params
        rung = f"SEARCH {self.RUNG}"
        track = self.track(p.target)
        if track is None or track.last_seen is None or track.pose_map is None or self.hunt is None:
            return self.fail(f"{rung}: {p.target} was never placed in the map, nowhere to start looking")
        state = self.robot()
        if state is None:
            self.halt()
            self.feedback_message = self.waiting_for_pose(f"{rung}: ")
            return py_trees.common.Status.RUNNING
        hunt = self.hunt
        if hunt.done:
            return self.fail(hunt.done)
        self.set_state(MissionState.SEARCH)
        belief = self.keep(track)
        if belief is None:
            return self._finish(hunt, None, f"{rung}: no map to search on")
        now = self.now()
        if now - hunt.started > p.timeout_s:
            return self._finish(
                hunt, belief, f"{rung}: {p.target} not found in {p.timeout_s:g} s ({self.summary(hunt, now)})"
            )
        why = self.exhausted(belief)
        if why:
            return self._finish(hunt, belief, f"{rung}: {why} ({self.summary(hunt, now)})")
        robot = state.pose
        if hunt.phase == "drive" and hunt.visit is not None:
            self._drive(hunt, belief, robot, now)
        if hunt.phase == "face" and hunt.visit is not None and self._face(hunt, robot):
            return py_trees.common.Status.RUNNING
        if hunt.phase == "sweep" and hunt.visit is not None:
            if self._sweep(hunt, belief, robot):
                return py_trees.common.Status.RUNNING
            hunt.phase = "plan"
            hunt.swept_at = (robot.x, robot.y)
        if hunt.phase == "plan":
            visit = self._best(belief, robot)
            if visit is None:
                return self._finish(
                    hunt,
                    belief,
                    f"{rung}: no place within {p.max_travel_m:g} m sees any of {self.WHAT} ({self.summary(hunt, now)})",
                )
            self._go(hunt, visit, now)
        assert hunt.visit is not None
        v = hunt.visit.pose
        self.feedback_message = (
            f"{rung}: to ({v.x:.2f}, {v.y:.2f}) to look at {self.WHAT} ({hunt.visit.mass:.0f} cells' worth, "
            f"{hunt.visit.score:.1f}/s); visit {hunt.visits}, {now - hunt.started:.1f} s of {p.timeout_s:g} s"
        )
        return py_trees.common.Status.RUNNING

    # -- phases -----------------------------------------------------------------------------------
    def _go(self, hunt: Hunt, visit: Visit, now: float) -> None:
        hunt.visit = visit
        hunt.planned_at = now
        hunt.visits += 1
        state = self.robot()
        here = state is not None and math.hypot(visit.pose.x - state.pose.x, visit.pose.y - state.pose.y) <= ARRIVED_M
        if here:  # the best place is where it stands: turn to the window on the spot, no trip to the navigator
            hunt.phase, hunt.goal = "face", None
            return
        hunt.phase = "drive"
        hunt.goal = self.navigate(visit.pose)

    def _face(self, hunt: Hunt, robot: Pose2D) -> bool:
        """Turn on the spot to the window's first edge; False when facing it (the sweep starts)."""
        visit = hunt.visit
        assert visit is not None
        error = se3.wrap_angle(visit.pose.yaw - robot.yaw)
        if abs(error) <= FACING_RAD:
            hunt.phase, hunt.sweep_turned, hunt.yaw_prev = "sweep", 0.0, robot.yaw
            return False
        self.drive(0.0, turn_rate(error, self.params.angular_speed, 0.3))
        self.feedback_message = (
            f"SEARCH {self.RUNG}: turning to look at {self.WHAT} from here, {math.degrees(abs(error)):.0f}° to go"
        )
        return True

    def _drive(self, hunt: Hunt, belief: TargetBelief, robot: Pose2D, now: float) -> None:
        visit = hunt.visit
        assert visit is not None
        v = visit.pose
        outcome = None if hunt.goal is None else self.nav_outcome(hunt.goal)
        close = math.hypot(v.x - robot.x, v.y - robot.y) <= ARRIVED_M
        if outcome == NavStatus.FAILED:
            hunt.bad.append((v.x, v.y))
            hunt.phase = "plan"
            return
        if outcome == NavStatus.SUCCEEDED or close:
            self._aim_on_arrival(hunt, belief, robot)
            return
        if now - hunt.planned_at >= self.params.replan_s:
            hunt.planned_at = now
            still = self._score_of(belief, robot, visit)
            best = self._best(belief, robot)
            if best is not None and (still is None or best.score > SWITCH_GAIN * still.score):
                self._go(hunt, best, now)
                hunt.visits -= 1  # a change of mind, not a new visit
                return
        if hunt.goal is None:
            hunt.goal = self.navigate(v)
        else:
            self.resend_goal(hunt.goal)

    def _sweep(self, hunt: Hunt, belief: TargetBelief, robot: Pose2D) -> bool:
        """Turn through the visit's window; False when it is done."""
        visit = hunt.visit
        assert visit is not None
        if hunt.yaw_prev is not None:
            hunt.sweep_turned += se3.wrap_angle(robot.yaw - hunt.yaw_prev)
        hunt.yaw_prev = robot.yaw
        left = visit.sweep_rad - hunt.sweep_turned
        if left * math.copysign(1.0, visit.sweep_rad) <= 0.05:  # what is left to turn, its way
            return False
        self.drive(0.0, turn_rate(left, self.params.angular_speed, 0.3))
        self.feedback_message = f"SEARCH {self.RUNG}: sweeping {self.WHAT}, {math.degrees(left):.0f}° to go"
        return True

    def _finish(self, hunt: Hunt, belief: TargetBelief | None, why: str) -> py_trees.common.Status:
        hunt.done = why
        if belief is not None:
            belief.log.append(self.summary(hunt, self.now()))
        return self.fail(why)

    # -- ranking ----------------------------------------------------------------------------------
    def _windows(self) -> tuple[int, float]:
        """(window width in rays, sweep angle) for the camera's field of view plus sweep_deg."""
        hfov = self.hfov()
        sweep = math.radians(self.params.sweep_deg)
        return max(1, round((hfov + sweep) / (2 * math.pi / RAYS))), sweep

    def _best(self, belief: TargetBelief, robot: Pose2D) -> Visit | None:
        p = self.params
        sg = belief.grid
        blocked = self.sight_blocked(sg, robot)
        scan_near = dilate(blocked & ~sg.occupied, 2)  # what the lidar sees, with room for the robot
        drivable = sg.robot_free(p.clearance_m) & ~scan_near & ~self.ahead_of_movers(sg, robot, p.clearance_m)
        here = sg.cell(robot.x, robot.y)
        leave = self.with_room_to_leave(sg, robot, drivable, blocked, p.clearance_m)
        dist = travel_distances(leave, here, sg.resolution)
        step = max(1, round(p.spacing_m / sg.resolution))
        rows, cols = np.mgrid[0 : sg.shape[0], 0 : sg.shape[1]]
        lattice = (rows % step == 0) & (cols % step == 0)
        cand = drivable & lattice & (dist <= p.max_travel_m)
        xs, ys = sg.centres()
        for bx, by in self.hunt.bad if self.hunt is not None else []:
            cand &= np.hypot(xs - bx, ys - by) > BAD_RADIUS_M
        idx = np.argwhere(cand)
        cx = np.concatenate([[robot.x], xs[idx[:, 0], idx[:, 1]]])
        cy = np.concatenate([[robot.y], ys[idx[:, 0], idx[:, 1]]])
        travel = np.concatenate([[0.0], dist[idx[:, 0], idx[:, 1]]])
        weights = self.weights(belief)
        masses = ray_masses(sg, blocked | self.mover_paths(sg), weights, cx, cy, RAYS, belief.view_range_m)
        width, sweep = self._windows()
        seen, start = best_window(masses, width)
        swept = self.hunt.swept_at if self.hunt is not None else None
        if swept is not None:  # what grew back beside the last sweep is cheap to look at and seldom where it is
            near = np.hypot(cx - swept[0], cy - swept[1]) < RESWEEP_M
            if (seen[~near] >= MIN_SEEN).any():
                seen = np.where(near, 0.0, seen)
        time = travel / p.speed_mps + sweep / p.angular_speed + OVERHEAD_S
        # Where it stands the robot first turns on the spot to the window (elsewhere the drive there turns it).
        turn = abs(se3.wrap_angle((start[0] + 0.5) * (2 * math.pi / RAYS) + self.hfov() / 2 - robot.yaw))
        time[0] += turn / p.angular_speed
        score = seen / time
        i = int(np.argmax(score))
        if seen[i] < MIN_SEEN:
            return None
        first, sweep_rad = self._orient(masses[i], int(start[i]), width)
        x, y = float(cx[i]), float(cy[i])
        return Visit(Pose2D(x, y, first), sweep_rad, float(seen[i]), float(score[i]))

    def _orient(self, masses: np.ndarray, start: int, width: int) -> tuple[float, float]:
        """(the yaw to face first, the signed sweep from there) for the window of `width` rays from `start`:
        from its heavier end, so the most likely directions are looked at first."""
        step = 2 * math.pi / RAYS
        sweep_rad = max(0.0, (width - 1) * step - self.hfov())
        window = masses[(start + np.arange(width)) % RAYS]
        half = width // 2
        if window[width - half :].sum() > window[:half].sum():  # heavier at its CCW end: start there, sweep CW
            return se3.wrap_angle((start + width - 0.5) * step - self.hfov() / 2), -sweep_rad
        return se3.wrap_angle((start + 0.5) * step + self.hfov() / 2), sweep_rad

    def _aim_on_arrival(self, hunt: Hunt, belief: TargetBelief, robot: Pose2D) -> None:
        """Arrived: choose the window again from here, for what is left now (the drive has looked at some of
        what it was going to), then turn to its heavier edge and sweep."""
        visit = hunt.visit
        assert visit is not None
        masses, seen, start = self._window_at(belief, robot, robot.x, robot.y)
        if seen >= MIN_SEEN:
            yaw, sweep_rad = self._orient(masses, start, self._windows()[0])
            hunt.visit = Visit(Pose2D(robot.x, robot.y, yaw), sweep_rad, seen, visit.score)
        hunt.phase, hunt.goal = "face", None

    def _window_at(self, belief: TargetBelief, robot: Pose2D, x: float, y: float) -> tuple[np.ndarray, float, int]:
        """From the place (x, y): the weight each direction sees, the most its best window sees, and that window's
        first direction (what _best ranks every candidate by, for one place)."""
        sg = belief.grid
        blocked = self.sight_blocked(sg, robot) | self.mover_paths(sg)
        masses = ray_masses(sg, blocked, self.weights(belief), np.array([x]), np.array([y]), RAYS, belief.view_range_m)
        seen, start = best_window(masses, self._windows()[0])
        return masses[0], float(seen[0]), int(start[0])

    def _score_of(self, belief: TargetBelief, robot: Pose2D, visit: Visit) -> Visit | None:
        """The chosen visit's score now (its window seen from its place, with the path left to it)."""
        p = self.params
        _, seen, _ = self._window_at(belief, robot, visit.pose.x, visit.pose.y)
        if seen < MIN_SEEN:
            return None
        left = math.hypot(visit.pose.x - robot.x, visit.pose.y - robot.y)  # a lower bound of the path left
        score = seen / (left / p.speed_mps + self._windows()[1] / p.angular_speed + OVERHEAD_S)
        return Visit(visit.pose, visit.sweep_rad, seen, score)


class SearchBelief(ViewpointSearch):
    """SEARCH b: drive to the place that sees most of where the target can be per second of travel, sweep it
    there; repeat; FAILURE after timeout_s or when nothing is left."""

    RUNG = "b"
    WHAT = "where it can be"

    @dataclass(frozen=True, kw_only=True)
    class Params:
        target: str = port("target", "name of the target (a key of perception.targets)")
        timeout_s: float = port(25.0, "give up after searching this long")
        target_speed_mps: float = port(1.0, "the belief grows as fast as the target can walk (m/s)")
        view_range_m: float = port(4.0, "the camera sees the target's marker this far")
        min_mass: float = port(0.03, "give up when the belief falls below this fraction of what it was")
        speed_mps: float = port(0.35, "the robot's average speed on a path: travel time = path / speed")
        angular_speed: float = port(0.8, "rotation rate of the sweep at a viewpoint (rad/s)")
        sweep_deg: float = port(90.0, "at a viewpoint, turn this much beyond the camera's field of view")
        spacing_m: float = port(0.4, "candidate viewpoints every this many metres")
        max_travel_m: float = port(8.0, "candidate viewpoints within this path length")
        clearance_m: float = port(0.35, "viewpoints keep this far from the map's obstacles (robot radius + margin)")
        replan_s: float = port(1.0, "re-rank the viewpoints this often while driving")

        def __post_init__(self) -> None:
            _check_positive(
                self,
                "timeout_s",
                "target_speed_mps",
                "view_range_m",
                "speed_mps",
                "angular_speed",
                "spacing_m",
                "max_travel_m",
                "replan_s",
            )

    NODE_TYPE = "Action"
    params: Params

    def keep(self, track: TargetTrack) -> TargetBelief | None:
        return self.belief(track, self.params.target_speed_mps, self.params.view_range_m)

    def weights(self, belief: TargetBelief) -> np.ndarray:
        return belief.weights()

    def exhausted(self, belief: TargetBelief) -> str | None:
        if belief.initial_mass > 0 and belief.mass() < self.params.min_mass * belief.initial_mass:
            return f"nothing left where {self.params.target} could be"
        return None

    def summary(self, hunt: Hunt, now: float) -> str:
        return f"searched where it could be for {now - hunt.started:.0f} s, {hunt.visits} viewpoint(s)"


class CoverUnseen(ViewpointSearch):
    """SEARCH c: cover what the camera has not seen since the loss, of where the target could have walked;
    FAILURE when covered or after timeout_s."""

    RUNG = "c"
    WHAT = "unseen space"

    @dataclass(frozen=True, kw_only=True)
    class Params:
        target: str = port("target", "name of the target (a key of perception.targets)")
        timeout_s: float = port(40.0, "give up after searching this long")
        done_fraction: float = port(0.95, "give up when this fraction of where the target could walk has been seen")
        speed_mps: float = port(0.35, "the robot's average speed on a path: travel time = path / speed")
        angular_speed: float = port(0.8, "rotation rate of the sweep at a viewpoint (rad/s)")
        sweep_deg: float = port(90.0, "at a viewpoint, turn this much beyond the camera's field of view")
        spacing_m: float = port(0.4, "candidate viewpoints every this many metres")
        max_travel_m: float = port(12.0, "candidate viewpoints within this path length")
        clearance_m: float = port(0.35, "viewpoints keep this far from the map's obstacles (robot radius + margin)")
        replan_s: float = port(1.0, "re-rank the viewpoints this often while driving")

        def __post_init__(self) -> None:
            _check_positive(self, "timeout_s", "speed_mps", "angular_speed", "spacing_m", "max_travel_m", "replan_s")
            if not 0 < self.done_fraction <= 1:
                raise ValueError(f"done_fraction: expected 0 < value ≤ 1, got {self.done_fraction}")

    NODE_TYPE = "Action"
    params: Params

    def weights(self, belief: TargetBelief) -> np.ndarray:
        return belief.unseen().astype(np.float32)

    def exhausted(self, belief: TargetBelief) -> str | None:
        if belief.seen_fraction() >= self.params.done_fraction:
            return f"seen {100 * belief.seen_fraction():.0f} % of where {self.params.target} could have walked"
        return None

    def summary(self, hunt: Hunt, now: float) -> str:
        return f"covered the unseen space for {now - hunt.started:.0f} s, {hunt.visits} viewpoint(s)"


def _check_positive(params: Any, *names: str) -> None:
    bad = [n for n in names if not getattr(params, n) > 0]
    if bad:
        raise ValueError(f"expected {', '.join(bad)} > 0")
