"""Where to stand to follow a target: `offset` short of it on the robot's side, facing it.

Shared by FollowTarget (live goal) and HoldLastGoal (frozen goal) so FOLLOW and LOST agree on what
"going to the target" means — the robot approaches rather than drives into the target.
"""

from __future__ import annotations

import math

from mission.core import se3
from mission.core.types import Pose2D


def approach_goal(robot_xy: tuple[float, float], target_xy: tuple[float, float], offset_m: float) -> Pose2D:
    """The goal `offset_m` before the target along robot → target, facing the target.

    When the robot is (almost) on the target there is no approach direction; the goal is then the target
    position itself with heading 0, which a navigator treats as "stay".
    """
    dx, dy = target_xy[0] - robot_xy[0], target_xy[1] - robot_xy[1]
    d = math.hypot(dx, dy)
    if d < 1e-6:
        return Pose2D(target_xy[0], target_xy[1], 0.0)
    ux, uy = dx / d, dy / d
    return Pose2D(target_xy[0] - offset_m * ux, target_xy[1] - offset_m * uy, math.atan2(uy, ux))


def bearing_to(pose: Pose2D, xy: tuple[float, float]) -> float:
    """Angle (rad, CCW positive, in (-π, π]) of point `xy` relative to the robot's heading."""
    return se3.wrap_angle(math.atan2(xy[1] - pose.y, xy[0] - pose.x) - pose.yaw)
