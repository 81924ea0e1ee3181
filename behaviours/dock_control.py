"""The visual-servo control law for docking a differential-drive robot in front of a tag.

A diff-drive base cannot move sideways, so lateral error is removed by heading changes: the camera
steers toward an aim point on the tag's normal line, `lookahead_m` closer to the tag than the camera
(never nearer than the stand-off), which pulls it onto the line like pure pursuit; over the last
`blend_m` the wanted heading blends into "square to the tag" so skew is gone on arrival. Two guards:

* the wanted heading is kept within `view_margin_rad` of the tag's direction, so steering never turns
  the tag out of the camera's view;
* forward speed is proportional to the remaining distance (slows down near the goal) and scaled by
  cos(heading error) (turn first when far off).

If the stand-off is reached with too much lateral error the only fix is to back off and come in again:
:func:`backoff_command` reverses along a line that crosses back toward the normal.

All in the tag's floor frame: tag at the origin, normal along +x, the camera at (standoff, lateral),
robot heading = π + skew (see mission.core.docking for the definitions).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from mission.core import se3
from mission.core.docking import DockOffsets
from mission.core.types import Twist


@dataclass(frozen=True)
class ServoGains:
    k_v: float = 0.8  # 1/s: forward speed per metre of distance error
    k_w: float = 1.5  # 1/s: yaw rate per radian of heading error
    lookahead_m: float = 0.20
    blend_m: float = 0.12
    view_margin_rad: float = math.radians(18.0)
    backoff_m: float = 0.20  # how far beyond the stand-off to back off before re-approaching
    backoff_lookahead_m: float = 0.25
    min_v: float = 0.01  # m/s: below this the approach creeps; keep moving until inside tolerance


def _steer(off: DockOffsets, wanted: float, max_w: float, gains: ServoGains) -> tuple[float, float]:
    """Yaw rate toward heading `wanted` (tag frame), kept within the view margin; returns (w, error)."""
    tag_dir = math.atan2(-off.lateral_m, -off.standoff_m)
    wanted = tag_dir + max(-gains.view_margin_rad, min(gains.view_margin_rad, se3.wrap_angle(wanted - tag_dir)))
    err = se3.wrap_angle(wanted - (math.pi + off.skew_rad))
    return max(-max_w, min(max_w, gains.k_w * err)), err


def approach_command(
    off: DockOffsets,
    standoff_m: float,
    max_v: float,
    max_w: float,
    gains: ServoGains = ServoGains(),
    deadband_m: float = 0.0,
) -> Twist:
    """Drive the camera onto the tag normal and to `standoff_m`, ending square to the tag.

    Within `deadband_m` of the stand-off the robot only turns (distance is already good enough).
    """
    s, lat = off.standoff_m, off.lateral_m
    remaining = s - standoff_m
    aim = max(standoff_m, s - gains.lookahead_m)
    to_aim = math.atan2(-lat, aim - s) if aim < s else math.pi
    beta = min(1.0, max(0.0, 1.0 - remaining / gains.blend_m))
    wanted = math.pi + (1.0 - beta) * se3.wrap_angle(to_aim - math.pi)
    w, err = _steer(off, wanted, max_w, gains)
    v = gains.k_v * remaining
    if abs(remaining) <= deadband_m:
        v = 0.0
    elif abs(v) < gains.min_v:
        v = math.copysign(gains.min_v, remaining)
    v = max(-max_v, min(max_v, v)) * max(0.0, math.cos(err))
    return Twist(v, w)


def backoff_command(off: DockOffsets, max_v: float, max_w: float, gains: ServoGains = ServoGains()) -> Twist:
    """Reverse away from the tag along a line that heads back toward the normal (for another approach)."""
    wanted = math.atan2(off.lateral_m, -gains.backoff_lookahead_m)
    w, err = _steer(off, wanted, max_w, gains)
    return Twist(-0.5 * max_v * max(0.0, math.cos(err)), w)
