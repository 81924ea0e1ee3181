"""SearchSweep: the SEARCH state — turn to look, first toward where the target was last seen.

Direction: the sign of the bearing, relative to the robot's heading when the search starts, of where the
target was heading when last seen — its last position carried on at its last velocity for
PREDICT_HORIZON_S (just its last position when it stood still or too few sightings give no velocity).
CCW for positive, CW for negative; CCW when the target was never placed in the map. The last position
alone is a poor guide once LOST has brought the robot to it: it is then straight ahead, and which way
the target went is what matters.
The sweep first turns through that bearing, then a full circle, then keeps circling until `duration_s`,
after which it fails with a reason. One loss, one search: re-entering SEARCH before the target is seen
again continues the same sweep and its clock (it does not start over). Rotation progress is integrated
from the robot's yaw (odometry), so a slow base still completes its circle; without a robot pose it is
estimated from the commanded rate.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import py_trees

from mission.behaviours.approach import bearing_to
from mission.behaviours.leaf import MissionLeaf
from mission.behaviours.line_of_sight import PREDICT_HORIZON_S, predicted_position
from mission.behaviours.ports import port
from mission.core import blackboard as bbk
from mission.core import se3
from mission.core.blackboard import MissionState


class SearchSweep(MissionLeaf):
    """SEARCH: rotate in place (TWIST) toward the last-seen bearing, then a full circle; FAILURE after duration_s."""

    @dataclass(frozen=True, kw_only=True)
    class Params:
        target: str = port("target", "name of the target (a key of perception.targets)")
        duration_s: float = port(20.0, "give up after sweeping this long")
        angular_speed: float = port(0.6, "rotation rate (rad/s)")

    NODE_TYPE = "Action"
    READS = (bbk.TRACKS,)
    COMMANDS = True
    params: Params

    def __init__(self, name: str | None = None, **ports: Any) -> None:
        super().__init__(name, **ports)
        self.direction = 1.0
        self.first_turn = 0.0  # rad to turn toward the last-seen bearing before the full circle
        self._t0 = 0.0
        self._t_prev = 0.0
        self._yaw_prev: float | None = None
        self.turned = 0.0  # rad turned so far in `direction`
        self._episode: float | None = None  # the track's last_seen this search is about (one search per loss)

    @property
    def turn_rate(self) -> float:
        return abs(self.params.angular_speed)  # the sign of a turn is chosen per search

    def initialise(self) -> None:
        now = self.now()
        state = self.robot()
        tr = self.track(self.params.target)
        self._t_prev = now
        self._yaw_prev = state.pose.yaw if state is not None else None
        episode = None if tr is None else tr.last_seen
        if episode is not None and episode == self._episode:
            # Re-entered without a sighting in between (a higher branch ran for a moment): the same search
            # goes on — its clock, direction and progress are kept, so the sweep still ends after duration_s.
            self.feedback_message = self._describe()
            return
        self._episode = episode
        self._t0 = now
        self.direction, self.first_turn = 1.0, 0.0
        if state is not None and tr is not None and tr.pose_map is not None:
            where = predicted_position(tr, tr.last_seen + PREDICT_HORIZON_S) if tr.last_seen is not None else None
            if where is None:
                where = (float(tr.pose_map[0, 3]), float(tr.pose_map[1, 3]))
            bearing = bearing_to(state.pose, where)
            self.direction = 1.0 if bearing >= 0 else -1.0
            self.first_turn = abs(bearing)
        self.turned = 0.0
        self.feedback_message = self._describe()

    def _integrate(self, now: float) -> None:
        state = self.robot()
        if state is not None and self._yaw_prev is not None:
            self.turned += self.direction * se3.wrap_angle(state.pose.yaw - self._yaw_prev)
        else:
            self.turned += self.turn_rate * max(now - self._t_prev, 0.0)
        self._yaw_prev = state.pose.yaw if state is not None else None
        self._t_prev = now

    def _describe(self) -> str:
        side = "left" if self.direction > 0 else "right"
        if self.turned < self.first_turn:
            return (
                f"searching: turning {side} toward last bearing {math.degrees(self.first_turn):.0f}° "
                f"({math.degrees(self.first_turn - self.turned):.0f}° to go)"
            )
        circle = (self.turned - self.first_turn) / (2 * math.pi)
        lap = int(circle) + 1
        return f"searching: circle {lap} turning {side}, {100 * (circle - int(circle)):.0f}% done"

    def update(self) -> py_trees.common.Status:
        self.set_state(MissionState.SEARCH)
        now = self.now()
        self._integrate(now)
        elapsed = now - self._t0
        if elapsed > self.params.duration_s:
            return self.fail(
                f"SEARCH: {self.params.target} not found after {elapsed:.1f} s of sweeping "
                f"(limit {self.params.duration_s:g} s)"
            )
        self.drive(0.0, self.direction * self.turn_rate)
        self.feedback_message = f"{self._describe()}, {elapsed:.1f} s of {self.params.duration_s:g} s"
        return py_trees.common.Status.RUNNING
