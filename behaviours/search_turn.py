"""Searching by turning in place: the ladder's first rung, and Nav2's following server's rotation (a baseline).

* :class:`TurnToBearing` (SEARCH a) turns toward where the target went, the nearer way first, past it by
  ``overshoot_deg``, then back the other way until ``back_deg`` beyond the bearing on the other side.
  Where the target went is its last position carried on along its last velocity (``horizon_s``, stopped at
  walls); when that bearing is within a few degrees of straight ahead, its sign says little, and the way
  the target was crossing the view decides (it was last seen walking off to that side). When the loss's
  belief holds SIDE_MAJORITY times as much of where the target can be in the quarter-turn on the other
  side, the first turn goes that way instead: LOST has usually looked along the bearing already. A turn stops early
  when the directions still to turn would show little of what a whole turn here could of where the target
  can be (the loss's belief), and where turning in place cannot show the target at all (a whole turn would
  show little of it), the rung hands over to the viewpoint search at once.
* :class:`RotateSearch` is opennav_following's ``rotateToObject`` (Nav2, Kilted), the baseline the ladder
  is measured against: from the heading it starts at, turn to +``angle_deg`` then to −``angle_deg`` (within
  ``angular_tolerance``), up to ``rounds`` times (its ``max_retries``), each within ``timeout_s``
  (``rotate_to_object_timeout``); then fail. Every round turns about the heading the search started at,
  so it never looks more than ``angle_deg`` away from it (it "only rotates ±π/2", as issue 15 puts it).

Both integrate the rotation from odometry (the robot's yaw), so a slow base still turns its full angle.
One loss, one search: re-entered before the target is seen again, they go on where they were.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import py_trees

from mission.behaviours.approach import bearing_to
from mission.behaviours.belief import TargetBelief
from mission.behaviours.leaf import MissionLeaf
from mission.behaviours.line_of_sight import fitted_velocity
from mission.behaviours.ports import port
from mission.behaviours.search_grid import ray_masses
from mission.behaviours.search_leaf import HEADING_WINDOW_S, SearchLeaf, predicted_walk, turn_rate
from mission.core import blackboard as bbk
from mission.core import se3
from mission.core.blackboard import MissionState

AHEAD_RAD = math.radians(8.0)  # a predicted bearing this close to 0 says nothing about which way to turn
RAYS = 72  # directions of the belief's mass round the robot (5° each)
# Turning here is cut short when a whole turn would show less than WORTH_FRACTION of everywhere the target can
# be (most of it is where turning here cannot look, behind the obstacle, and moving is what finds it), and a
# leg is when the directions it still has to turn through (more than LEG_MIN_DEG of them) show less than
# LEG_FRACTION of what a whole turn here would (what is left of the belief lies the other way).
WORTH_FRACTION = 0.35
LEG_FRACTION = 0.1
LEG_MIN_DEG = 45.0  # a leg with less than this left is finished, not cut: under a second of turning
# The first leg goes on past the predicted bearing's overshoot while the directions just beyond the view's edge
# hold at least EDGE_FRACTION of the heaviest direction's share of the belief (the target turned a corner and
# walked on past where the bearing said), by EDGE_STEP_DEG at a time and up to EDGE_MAX_DEG more.
EDGE_FRACTION = 0.25
EDGE_SPAN = 3  # rays beyond the edge looked at (15°)
EDGE_STEP_DEG = 15.0
EDGE_MAX_DEG = 90.0
# The first turn goes the way the belief holds this many times as much of where the target can be, within a
# quarter-turn of the heading, as the other way, whatever the predicted bearing says (a near-tie keeps it).
SIDE_MAJORITY = 1.5


@dataclass
class Turn:
    """One loss's turn in place: the two legs as cumulative angles (CCW +) from the start heading."""

    episode: float | None
    start_yaw: float
    legs: list[float]  # cumulative angle to reach, leg by leg
    directions: list[float]  # +1 (CCW) or -1 each leg turns
    extended: float = 0.0  # how far the first leg went on past its planned end (rad)
    leg: int = 0
    turned: float = 0.0  # cumulative signed rotation so far
    yaw_prev: float | None = None
    started: float = 0.0
    skipped: int = 0  # legs cut short because nothing could be seen there
    handed_over: bool = False  # stopped because turning here could show little of where the target can be
    glance: float | None = None  # cumulative angle of the first leg that centres where it left the view
    why: str = ""


class TurnToBearing(SearchLeaf):
    """SEARCH a: turn toward where the target went the nearer way, then the other way; FAILURE when both
    turns are done."""

    @dataclass(frozen=True, kw_only=True)
    class Params:
        target: str = port("target", "name of the target (a key of perception.targets)")
        angular_speed: float = port(1.0, "rotation rate (rad/s)")
        overshoot_deg: float = port(30.0, "turn this far past the predicted bearing before turning back")
        back_deg: float = port(180.0, "then turn the other way until this far past the bearing on the other side")
        horizon_s: float = port(2.0, "where the target went: its last velocity carried on this long")

        def __post_init__(self) -> None:
            if self.angular_speed <= 0 or self.overshoot_deg < 0 or self.back_deg < 0 or self.horizon_s < 0:
                raise ValueError("expected angular_speed > 0 and overshoot_deg, back_deg, horizon_s ≥ 0")

    NODE_TYPE = "Action"
    params: Params

    def __init__(self, name: str | None = None, **ports: Any) -> None:
        super().__init__(name, **ports)
        self.turn: Turn | None = None

    def initialise(self) -> None:
        track = self.track(self.params.target)
        state = self.robot()
        episode = None if track is None else track.last_seen
        if self.turn is not None and self.turn.episode == episode and episode is not None:
            self.turn.yaw_prev = None if state is None else state.pose.yaw
            return  # re-entered within the same loss: go on with the same turn
        yaw = state.pose.yaw if state is not None else 0.0
        bearing, side = self._bearing()
        o, b = math.radians(self.params.overshoot_deg), math.radians(self.params.back_deg)
        legs = [side * (abs(bearing) + o), side * (abs(bearing) - b)]
        why = f"predicted bearing {math.degrees(bearing):+.0f}°"
        belief = self.belief(track) if track is not None else None
        heavier = self._heavier_side(belief) if belief is not None else None
        if heavier is not None and heavier != side:  # what LOST has looked at and what is left say the other way
            side = heavier
            legs = [side * (max(0.0, side * bearing) + o), bearing - side * b]
            why = f"side where it can be (its predicted bearing {math.degrees(bearing):+.0f}° the other way)"
        self.turn = Turn(episode, yaw, legs, [side, -side], yaw_prev=None if state is None else yaw, started=self.now())
        self.turn.why = why
        glance = None if track is None or state is None else self.glance_heading(track, state.pose)
        if glance is not None and se3.wrap_angle(glance - yaw) * side > 0:  # it left the view on the side turned to
            self.turn.glance = se3.wrap_angle(glance - yaw)

    def _bearing(self) -> tuple[float, float]:
        """(bearing of where the target went, relative to the robot's heading; the side to turn first: ±1)."""
        track = self.track(self.params.target)
        state = self.robot()
        sg = self.grid()
        if track is None or state is None or track.pose_map is None:
            return 0.0, 1.0
        if sg is not None:
            _, aim = predicted_walk(sg, sg.target_free(), track, self.params.horizon_s)
        else:
            aim = (float(track.pose_map[0, 3]), float(track.pose_map[1, 3]))
        bearing = bearing_to(state.pose, aim)
        if abs(bearing) >= AHEAD_RAD:
            return bearing, math.copysign(1.0, bearing)
        v = fitted_velocity(track, HEADING_WINDOW_S, steady=True)
        if v is not None and math.hypot(*v) > 0.05:  # crossing the view: it walked off to that side
            across = math.sin(math.atan2(v[1], v[0]) - state.pose.yaw)
            return bearing, 1.0 if across >= 0 else -1.0
        return bearing, 1.0 if bearing >= 0 else -1.0

    def _heavier_side(self, belief: TargetBelief) -> float | None:
        """+1 (left) or -1 (right) when the quarter-turn on that side of the camera's heading shows
        SIDE_MAJORITY times as much of where the target can be (the loss's belief) as the other; else None.

        The predicted bearing is where the target's last velocity carried it; LOST has usually looked there
        already by the time SEARCH a starts, and the belief knows it. A target lost as it rounded a partition's
        end, with LOST's look toward the walk 8° left of the heading, had twice as much of the belief on the
        right, down the far side where it waited; turning left first cost 9 s (search_corner seed 5227,
        typical)."""
        if not belief.mass() > 0:
            return None
        rays = self._ray_masses(belief)
        if rays is None:
            return None
        masses, cam_yaw = rays
        rel = np.array([se3.wrap_angle(i * 2 * math.pi / RAYS - cam_yaw) for i in range(RAYS)])
        left = float(masses[(rel > 0) & (rel <= math.pi / 2)].sum())
        right = float(masses[(rel < 0) & (rel >= -math.pi / 2)].sum())
        if left >= SIDE_MAJORITY * right and left > 0:
            return 1.0
        if right >= SIDE_MAJORITY * left and right > 0:
            return -1.0
        return None

    def _ray_masses(self, belief: TargetBelief) -> tuple[np.ndarray, float] | None:
        """(the belief's weight each direction round the camera sees, the camera's yaw); None without a pose
        or map."""
        state = self.robot()
        sg = self.grid()
        if state is None or sg is None:
            return None
        cx, cy, cam_yaw = self.camera_pose(state.pose)
        blocked = self.sight_blocked(sg, state.pose)
        weights = belief.weights()
        return ray_masses(sg, blocked, weights, np.array([cx]), np.array([cy]), RAYS, belief.view_range_m)[0], cam_yaw

    def _edge_holds(self, rays: tuple[np.ndarray, float] | None, turn: Turn) -> bool:
        """The directions just past the view's edge, the way the first leg turns, hold where the target can be."""
        if turn.leg != 0 or turn.extended >= math.radians(EDGE_MAX_DEG):
            return False
        if rays is None or not rays[0].max() > 0:
            return False
        masses, cam_yaw = rays
        direction = turn.directions[0]
        edge = cam_yaw + direction * self.hfov() / 2
        first = edge / (2 * math.pi / RAYS)
        beyond = [math.floor(first + direction * (k + 0.5)) % RAYS for k in range(EDGE_SPAN)]
        return float(masses[beyond].max()) >= EDGE_FRACTION * float(masses.max())

    def _not_worth_turning(self, everywhere: float | None, rays: tuple[np.ndarray, float] | None) -> bool:
        """A whole turn here would show little of where the target can be (`everywhere`: the belief's mass):
        moving is what finds it."""
        if everywhere is None:
            return False
        if everywhere <= 0:
            return True
        return rays is not None and float(rays[0].sum()) < WORTH_FRACTION * everywhere

    def _leg_empty(self, everywhere: float | None, rays: tuple[np.ndarray, float] | None, turn: Turn) -> bool:
        """The directions the current leg still has to turn through show little of where the target can be."""
        if everywhere is None:
            return False
        if everywhere <= 0:
            return True
        if rays is None:
            return False
        masses, cam_yaw = rays
        here = float(masses.sum())
        half = self.hfov() / 2
        target = turn.legs[turn.leg]
        direction = turn.directions[turn.leg]
        a0 = cam_yaw + direction * half  # the far edge of the view now
        a1 = cam_yaw + (target - turn.turned) + direction * half
        lo, hi = min(a0, a1), max(a0, a1)
        if hi - lo >= 2 * math.pi:
            return False
        angles = np.arange(RAYS) * (2 * math.pi / RAYS)
        inside = np.mod(angles - lo, 2 * math.pi) <= hi - lo
        return float(masses[inside].sum()) < LEG_FRACTION * here

    def update(self) -> py_trees.common.Status:
        self.set_state(MissionState.SEARCH)
        p = self.params
        track = self.track(p.target)
        turn = self.turn
        assert turn is not None
        belief = self.belief(track) if track is not None else None
        state = self.robot()
        if state is not None and turn.yaw_prev is not None:
            turn.turned += se3.wrap_angle(state.pose.yaw - turn.yaw_prev)
        turn.yaw_prev = state.pose.yaw if state is not None else None
        # what the belief holds, and what each direction round the camera sees of it: once a tick, for every check
        everywhere = belief.mass() if belief is not None else None
        rays = self._ray_masses(belief) if belief is not None and everywhere and turn.leg < len(turn.legs) else None
        glancing = turn.leg == 0 and turn.glance is not None and (turn.glance - turn.turned) * turn.directions[0] > 0.05
        if turn.leg < len(turn.legs) and not glancing and self._not_worth_turning(everywhere, rays):
            turn.skipped += len(turn.legs) - turn.leg
            turn.leg = len(turn.legs)
            turn.handed_over = True
        while turn.leg < len(turn.legs):
            to_go = (turn.legs[turn.leg] - turn.turned) * turn.directions[turn.leg]
            step = math.radians(EDGE_STEP_DEG)
            if turn.leg == 0 and to_go < step and self._edge_holds(rays, turn):
                turn.legs[0] += turn.directions[0] * step  # what is just past the view is where it can be: go on
                turn.extended += step
                break
            if to_go <= 0.02:  # this leg is turned
                turn.leg += 1
                continue
            if to_go > math.radians(LEG_MIN_DEG) and not glancing and self._leg_empty(everywhere, rays, turn):
                turn.skipped += 1
                turn.leg += 1
                continue
            break
        if turn.leg >= len(turn.legs):
            took = self.now() - turn.started
            done = f"SEARCH a: turned toward {p.target}'s {turn.why} and back the other way ({took:.0f} s)"
            if turn.handed_over:
                done = (
                    f"SEARCH a: a whole turn here would show under {100 * WORTH_FRACTION:.0f} % of where "
                    f"{p.target} can be: moving instead ({took:.0f} s of turning, toward its {turn.why})"
                )
            elif turn.skipped:
                done += f"; {turn.skipped} turn(s) cut short: nothing it could be was left that way"
            if belief is not None and not (belief.log and belief.log[-1].startswith("turned")):
                belief.log.append(f"turned toward its bearing ({self.now() - turn.started:.0f} s)")
            return self.fail(done)
        error = turn.legs[turn.leg] - turn.turned
        self.drive(0.0, turn_rate(error, p.angular_speed, 0.3))
        side = "left" if error > 0 else "right"
        if turn.leg == 0 and turn.extended:
            how = f"on {math.degrees(turn.extended):.0f}° past the {turn.why}: where it can be goes on that way"
        else:
            how = f"{'toward' if turn.leg == 0 else 'back past'} the {turn.why}"
        self.feedback_message = f"SEARCH a: turning {side} ({how}), {math.degrees(abs(error)):.0f}° to go"
        return py_trees.common.Status.RUNNING


@dataclass
class Rotation:
    episode: float | None
    round: int
    start_yaw: float
    heading: int  # 0: to +angle, 1: to −angle
    round_started: float


class RotateSearch(MissionLeaf):
    """SEARCH (baseline): Nav2 opennav_following's rotation — to ±angle_deg of the start heading, `rounds`
    times; then FAILURE."""

    @dataclass(frozen=True, kw_only=True)
    class Params:
        target: str = port("target", "name of the target (a key of perception.targets)")
        angle_deg: float = port(90.0, "search_angle: turn to this far left, then this far right, of the start heading")
        angular_speed: float = port(1.0, "rotation rate (rad/s)")
        angular_tolerance: float = port(0.15, "a heading within this (rad) is reached")
        rounds: int = port(3, "max_retries: rounds of ±angle_deg before giving up")
        timeout_s: float = port(10.0, "rotate_to_object_timeout: one round's limit")

        def __post_init__(self) -> None:
            if self.angular_speed <= 0 or self.rounds < 1 or self.timeout_s <= 0 or self.angular_tolerance <= 0:
                raise ValueError("expected angular_speed > 0, rounds ≥ 1, timeout_s > 0, angular_tolerance > 0")

    NODE_TYPE = "Action"
    READS = (bbk.TRACKS,)
    COMMANDS = True
    params: Params

    def __init__(self, name: str | None = None, **ports: Any) -> None:
        super().__init__(name, **ports)
        self.rotation: Rotation | None = None

    def initialise(self) -> None:
        track = self.track(self.params.target)
        episode = None if track is None else track.last_seen
        if self.rotation is not None and self.rotation.episode == episode and episode is not None:
            return
        state = self.robot()
        self.rotation = Rotation(episode, 1, state.pose.yaw if state is not None else 0.0, 0, self.now())

    def update(self) -> py_trees.common.Status:
        self.set_state(MissionState.SEARCH)
        p = self.params
        rot = self.rotation
        state = self.robot()
        assert rot is not None
        if state is None:
            self.halt()
            self.feedback_message = self.waiting_for_pose("SEARCH (rotate): ")
            return py_trees.common.Status.RUNNING
        now = self.now()
        if now - rot.round_started > p.timeout_s:
            return self.fail(f"SEARCH (rotate ±{p.angle_deg:g}°): timed out rotating, round {rot.round} of {p.rounds}")
        a = math.radians(p.angle_deg)
        goal = rot.start_yaw + (a if rot.heading == 0 else -a)
        error = se3.wrap_angle(goal - state.pose.yaw)
        if abs(error) < p.angular_tolerance:
            if rot.heading == 0:
                rot.heading = 1
            elif rot.round >= p.rounds:
                return self.fail(f"SEARCH (rotate ±{p.angle_deg:g}°): {p.target} not found after {p.rounds} round(s)")
            else:
                rot.round, rot.heading, rot.round_started = rot.round + 1, 0, now  # ±angle of the same heading
            goal = rot.start_yaw + (a if rot.heading == 0 else -a)
            error = se3.wrap_angle(goal - state.pose.yaw)
        self.drive(0.0, turn_rate(error, p.angular_speed, 0.2))
        side = "left" if rot.heading == 0 else "right"
        self.feedback_message = (
            f"SEARCH (rotate): round {rot.round} of {p.rounds}, to {p.angle_deg:g}° {side}, "
            f"{math.degrees(abs(error)):.0f}° to go"
        )
        return py_trees.common.Status.RUNNING
