"""Explore: the EXPLORE phase — look around until the wanted marker shows up.

With waypoints ("x,y;x,y;…", map metres) the robot navigates to each in turn and turns a full circle
there; a waypoint the navigator cannot reach is skipped (and counted). Without waypoints it sweeps by
rotating in place. SUCCESS (and stop) the moment the target is visible; FAILURE with a reason at
`timeout_s` or when every waypoint has been visited without seeing it.

The turns are no faster than the camera's exposure allows: a frame that says how long its shutter was open
caps them at the rate that smears the image by READABLE_SMEAR_PX. A 30 ms exposure (a cheap webcam indoors)
turning at the default 0.5 rad/s smears a marker over 6 px, and the sweep turns past the dock without
ever reading it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import py_trees

from mission.behaviours.leaf import MissionLeaf
from mission.behaviours.ports import port
from mission.core import blackboard as bbk
from mission.core import se3
from mission.core.blackboard import MissionState
from mission.core.types import Frame, NavGoal, NavStatus, Pose2D

# The smear (px) a sweep may give a marker and still read it: about half a marker cell at the range it is
# read from. Measured on the simulation's 15 cm dock tag (4×4, 4 px cells at 2.5 m; `realism: harsh`'s
# 30 ms camera, 12 views each): 11/12 read at 2.5 px, 4/12 at 3.7 px, 0/12 at 6.2 px (the 0.5 rad/s sweep);
# `typical`'s 10 ms: 12/12 at 2.1 px, 9/12 at 3.3 px.
READABLE_SMEAR_PX = 2.0


def parse_waypoints(text: str) -> list[tuple[float, float]]:
    """ "x,y;x,y;…" → [(x, y), …]; raises ValueError naming the bad item (empty text → no waypoints)."""
    out: list[tuple[float, float]] = []
    for i, item in enumerate(p.strip() for p in text.split(";")):
        if not item:
            continue
        parts = [v.strip() for v in item.split(",")]
        try:
            if len(parts) != 2:
                raise ValueError
            x, y = float(parts[0]), float(parts[1])
            if not (math.isfinite(x) and math.isfinite(y)):
                raise ValueError
        except ValueError:
            raise ValueError(
                f"waypoints: item {i + 1} {item!r} is not 'x,y' in metres (expected 'x,y;x,y;…')"
            ) from None
        out.append((x, y))
    return out


class Explore(MissionLeaf):
    """EXPLORE: waypoints with a full turn at each, or an in-place sweep, until `target` is visible."""

    @dataclass(frozen=True, kw_only=True)
    class Params:
        target: str = port("dock", "stop exploring when this target is visible")
        waypoints: str = port("", "'x,y;x,y;…' in the map frame; empty = rotate in place")
        angular_speed: float = port(0.5, "rotation rate of the sweeps (rad/s)")
        timeout_s: float = port(120.0, "give up after this long")

        def __post_init__(self) -> None:
            parse_waypoints(self.waypoints)  # raises ValueError naming the bad item

    NODE_TYPE = "Action"
    READS = (bbk.TRACKS, bbk.FRAME)
    COMMANDS = True
    params: Params

    def __init__(self, name: str | None = None, **ports: Any) -> None:
        super().__init__(name, **ports)
        self.route: list[tuple[float, float]] = []  # [(x, y), …] in the map frame, from the waypoints port
        self._reset()

    @property
    def turn_rate(self) -> float:
        """`angular_speed`, or slower when the newest frame's exposure would smear a marker past reading."""
        frame: Frame | None = self.read(bbk.FRAME)
        cap = math.inf if frame is None else frame.turn_rate_for_smear(READABLE_SMEAR_PX)
        return min(abs(self.params.angular_speed), cap)

    def _rate_note(self) -> str:
        """' at 0.16 rad/s (30 ms exposure)' when the exposure slows the turn, else ''."""
        rate = self.turn_rate
        if rate >= abs(self.params.angular_speed):
            return ""
        frame: Frame | None = self.read(bbk.FRAME)
        exposure = 0.0 if frame is None or frame.exposure_s is None else frame.exposure_s
        return f" at {rate:.2f} rad/s ({exposure * 1000:.0f} ms exposure)"

    def _reset(self) -> None:
        if isinstance(self.params.waypoints, str):  # not yet read when the port is a blackboard entry
            self.route = parse_waypoints(self.params.waypoints)
        self._t0 = 0.0
        self.index = 0
        self.unreachable = 0
        self.phase = "navigate" if self.route else "sweep"
        self._goal: NavGoal | None = None
        self.turned = 0.0
        self._yaw_prev: float | None = None
        self._t_prev = 0.0

    def initialise(self) -> None:
        self._reset()
        self._t0 = self._t_prev = self.now()
        self.feedback_message = f"exploring for {self.params.target}"

    def _turn_progress(self, now: float) -> None:
        state = self.robot()
        if state is not None and self._yaw_prev is not None:
            self.turned += abs(se3.wrap_angle(state.pose.yaw - self._yaw_prev))
        elif state is None:
            self.turned += self.turn_rate * max(now - self._t_prev, 0.0)
        self._yaw_prev = state.pose.yaw if state is not None else None
        self._t_prev = now

    def _start_turn(self, now: float) -> None:
        self.phase = "turn"
        self.turned = 0.0
        state = self.robot()
        self._yaw_prev = state.pose.yaw if state is not None else None
        self._t_prev = now

    def update(self) -> py_trees.common.Status:
        self.set_state(MissionState.EXPLORE)
        now = self.now()
        elapsed = now - self._t0
        tr = self.track(self.params.target)
        if tr is not None and tr.last_seen is not None and tr.misses == 0:
            self.halt()
            msg = f"EXPLORE: {self.params.target} found after {elapsed:.1f} s"
            if tr.detection is not None:
                msg += f", {tr.detection.distance:.2f} m away"
            self.write(bbk.REASON, msg)
            self.feedback_message = msg
            return py_trees.common.Status.SUCCESS
        if elapsed > self.params.timeout_s:
            return self.fail(f"EXPLORE: {self.params.target} not found within {self.params.timeout_s:g} s")
        if self.phase == "sweep":
            self._turn_progress(now)
            self.drive(0.0, self.turn_rate)
            self.feedback_message = (
                f"EXPLORE: sweeping for {self.params.target}{self._rate_note()}, "
                f"turned {math.degrees(self.turned):.0f}°, {elapsed:.0f} s of {self.params.timeout_s:g} s"
            )
            return py_trees.common.Status.RUNNING
        if self.phase == "turn":
            self._turn_progress(now)
            if self.turned < 2 * math.pi:
                self.drive(0.0, self.turn_rate)
                self.feedback_message = (
                    f"EXPLORE: looking around at waypoint {self.index + 1}/{len(self.route)}{self._rate_note()}, "
                    f"{math.degrees(self.turned):.0f}° of 360°"
                )
                return py_trees.common.Status.RUNNING
            self.index += 1
            self.phase = "navigate"
            self._goal = None
        if self.index >= len(self.route):
            return self.fail(
                f"EXPLORE: visited {len(self.route)} waypoint(s) ({self.unreachable} unreachable) "
                f"without seeing {self.params.target}"
            )
        return self._navigate(now)

    def _navigate(self, now: float) -> py_trees.common.Status:
        wx, wy = self.route[self.index]
        state = self.robot()
        if self._goal is None:
            yaw = math.atan2(wy - state.pose.y, wx - state.pose.x) if state is not None else 0.0
            self._goal = self.navigate(Pose2D(wx, wy, yaw))
        else:
            self.resend_goal(self._goal)
        outcome = self.nav_outcome(self._goal)
        if outcome == NavStatus.SUCCEEDED:
            self._start_turn(now)
            self.drive(0.0, self.turn_rate)
            self.feedback_message = f"EXPLORE: reached waypoint {self.index + 1}/{len(self.route)}, looking around"
            return py_trees.common.Status.RUNNING
        if outcome == NavStatus.FAILED:
            self.unreachable += 1
            self.index += 1
            self._goal = None
            self.halt()
            why = self.nav_reason()
            self.feedback_message = f"EXPLORE: waypoint {self.index}/{len(self.route)} unreachable, skipping it" + (
                f" ({why})" if why else ""
            )
            return py_trees.common.Status.RUNNING
        dist = math.hypot(wx - state.pose.x, wy - state.pose.y) if state is not None else float("nan")
        self.feedback_message = (
            f"EXPLORE: going to waypoint {self.index + 1}/{len(self.route)} ({wx:.1f}, {wy:.1f}), {dist:.1f} m away"
        )
        return py_trees.common.Status.RUNNING
