"""DriveToPose: drive straight to a nearby pose with velocity commands, no planner — Nav2 docking's undock.

Nav2's docking server undocks by driving the robot off the dock to its staging pose with a control law on
/cmd_vel, not through the navigator: the staging pose is a few decimetres away (Nav2's ``staging_x_offset``,
−0.7 m: behind the robot), in free space the robot has just come through on its way in, and a planner (which
would see the dock as an obstacle the robot stands in) has nothing to add. This leaf does the same: from the
robot pose, steer toward the point (the rear toward it when `backward`, as off a dock the robot faced), with a
speed proportional to the distance, limited by `max_v` and slowed while the heading is off; then turn in place
to the pose's yaw. SUCCESS (robot stopped) within `linear_tolerance` and `angular_tolerance`; FAILURE after
`timeout_s` with a reason naming the pose (Nav2: "Undocking timed out").

It does not check obstacles (no map, no scan): it is for short moves through space known to be free, as
Nav2's undock is. Anything longer belongs to GoToPose and the navigator.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import py_trees

from mission.behaviours.leaf import MissionLeaf
from mission.behaviours.ports import port
from mission.core import se3
from mission.core.types import Pose2D

K_V = 1.0  # forward speed per metre to go (1/s): the last decimetres slow down over about a second
K_W = 2.0  # yaw rate per radian of heading error (1/s)
MIN_V = 0.02  # m/s: slower than this the base's friction wins; the last centimetres still close
MIN_W = 0.05  # rad/s: likewise for turning
# The drive ends within this fraction of linear_tolerance, so that turning in place to the yaw (which moves
# a real base's centre a little) still ends within the tolerance; it starts again only beyond the tolerance.
ARRIVE_FRACTION = 0.5
# This close to the point, a point behind the driving end (an overshoot) is reached by driving the other way,
# not by turning round to face it.
NEAR_M = 0.15


def _limit(value: float, floor: float, cap: float) -> float:
    """`value` with its magnitude kept within [floor, cap] (its sign kept)."""
    return math.copysign(min(max(abs(value), floor), cap), value)


class DriveToPose(MissionLeaf):
    """Drive straight to `pose` (reversing when `backward`), then turn to its yaw: SUCCESS within the
    tolerances; FAILURE after `timeout_s`. No planner, no obstacle check: for short moves (Nav2's undock)."""

    @dataclass(frozen=True, kw_only=True)
    class Params:
        pose: Pose2D = port(doc="where to go (map frame): a blackboard entry such as {staging_pose}, or 'x;y;yaw'")
        backward: bool = port(False, "drive there in reverse, the rear leading (as off a dock the robot faces)")
        max_v: float = port(0.15, "speed limit (m/s)")
        max_w: float = port(0.5, "yaw rate limit (rad/s)")
        linear_tolerance: float = port(0.05, "success within this distance of the pose (m)")
        angular_tolerance: float = port(0.05, "success within this of the pose's yaw (rad)")
        timeout_s: float = port(0.0, "give up after this long; 0 = no limit")
        what: str = port("the goal", "what the pose is, as the feedback and a failure's reason name it")

        def __post_init__(self) -> None:
            if self.max_v <= 0 or self.max_w <= 0:
                raise ValueError("expected max_v > 0 and max_w > 0")
            if self.linear_tolerance <= 0 or self.angular_tolerance <= 0:
                raise ValueError("expected linear_tolerance > 0 and angular_tolerance > 0")
            if self.timeout_s < 0:
                raise ValueError("expected timeout_s ≥ 0 (0 = no limit)")

    NODE_TYPE = "Action"
    COMMANDS = True
    params: Params

    def __init__(self, name: str | None = None, **ports: Any) -> None:
        super().__init__(name, **ports)
        self._t0 = 0.0
        self._arrived = False  # at the point: turning to the yaw

    def initialise(self) -> None:
        self._t0 = self.now()
        self._arrived = False
        self.feedback_message = f"driving to {self.params.what}"

    def update(self) -> py_trees.common.Status:
        p = self.params
        pose = p.pose
        where = f"{p.what} ({pose.x:.2f}, {pose.y:.2f}, {round(math.degrees(pose.yaw))}°)"
        if p.timeout_s > 0 and self.now() - self._t0 > p.timeout_s:
            return self.fail(f"{where} not reached within {p.timeout_s:g} s")
        state = self.robot()
        if state is None:
            self.halt()
            self.feedback_message = self.waiting_for_pose()
            return py_trees.common.Status.RUNNING
        robot = state.pose
        dx, dy = pose.x - robot.x, pose.y - robot.y
        distance = math.hypot(dx, dy)
        yaw_error = se3.wrap_angle(pose.yaw - robot.yaw)
        if distance > p.linear_tolerance:
            self._arrived = False
        elif distance <= ARRIVE_FRACTION * p.linear_tolerance:
            self._arrived = True

        if not self._arrived:
            v, w = self._steer(robot, dx, dy, distance)
            self.drive(v, w)
            self.feedback_message = f"{'reversing' if v < 0 else 'driving'} to {where}, {distance:.2f} m to go"
            return py_trees.common.Status.RUNNING
        if abs(yaw_error) <= p.angular_tolerance:
            self.halt()
            self.feedback_message = f"at {where}"
            return py_trees.common.Status.SUCCESS
        self.drive(0.0, _limit(K_W * yaw_error, MIN_W, p.max_w))
        self.feedback_message = f"turning to {where}, {math.degrees(abs(yaw_error)):.0f}° to go"
        return py_trees.common.Status.RUNNING

    def _steer(self, robot: Pose2D, dx: float, dy: float, distance: float) -> tuple[float, float]:
        """(v, w) toward the point: the driving end (the rear when backward) turned toward it, the speed
        proportional to the distance and scaled by how well that end faces the point (none beyond 90°)."""
        p = self.params
        sign = -1.0 if p.backward else 1.0
        bearing = se3.wrap_angle(math.atan2(dy, dx) - robot.yaw)  # of the point, from the robot's front
        error = se3.wrap_angle(bearing - (math.pi if p.backward else 0.0))  # from the driving end
        if distance < NEAR_M and abs(error) > math.pi / 2:  # overshot: drive the other end to it
            sign, error = -sign, se3.wrap_angle(error + math.pi)
        speed = _limit(K_V * distance, MIN_V, p.max_v) * max(0.0, math.cos(error)) ** 2
        w = max(-p.max_w, min(p.max_w, K_W * error))
        return sign * speed, w
