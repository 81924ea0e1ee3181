"""VisualServoDock: the second half of DOCK — servo on the live tag pose to the final stand-off.

Each new detection of the dock tag (its map pose, from PerceiveTargets) updates a small floor-plane
filter (position and face normal, exponential smoothing with a gate against the flat-marker pose flips);
between frames the robot's own motion (ROBOT_STATE) carries the estimate, so the control runs every tick.
The control law is in behaviours/dock_control.py. The tag pose in the camera frame of every new detection
goes to DOCK_SETPOINT (what a Nav2 docking server would take as detected_dock_pose).

SUCCESS (and stop) when stand-off, lateral and skew are inside tolerance on two consecutive fresh
detections; FAILURE with a reason when the tag is unseen for > detection_timeout_s or at timeout_s.
Defaults follow Nav2 opennav_docking (v ≤ 0.25 m/s, ω ≤ 0.75 rad/s, detection timeout 1 s) and the
design notes' tolerances (3 cm lateral, 2.5 cm distance, 10° skew at a 0.30 m stand-off).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import py_trees

from mission.behaviours.dock_control import ServoGains, approach_command, backoff_command
from mission.behaviours.leaf import MissionLeaf
from mission.behaviours.ports import port
from mission.core import blackboard as bbk
from mission.core import se3
from mission.core.blackboard import MissionState
from mission.core.docking import DockOffsets, floor_normal, floor_offsets
from mission.core.types import DockSetpoint

SETTLE_DETECTIONS = 2  # consecutive fresh detections inside tolerance before declaring success
# Inside tolerance the servo keeps refining toward these fractions of the tolerances (margin for measurement
# noise), and declares success when it gets there, or after SETTLE_S inside tolerance without getting there.
TIGHT_DISTANCE, TIGHT_LATERAL, TIGHT_SKEW = 0.3, 0.7, 0.5
SETTLE_S = 1.5
TIGHT_BACKOFFS = 2  # re-approaches allowed for reaching the tight lateral band
DEADBAND = 0.3  # fraction of distance_tol_m within which the servo stops moving forward (turns only)


class FloorTagFilter:
    """Smooths a wall tag's floor pose (x, y, normal heading); rejects sudden normal flips.

    A flat marker's pose is two-fold ambiguous: a single frame can report the normal 20–40° off. A jump
    larger than `gate_rad` is ignored unless it persists for `reset_after` frames (then the tag really
    moved, or the old estimate was the wrong one).
    """

    def __init__(self, alpha: float = 0.5, gate_rad: float = math.radians(25.0), reset_after: int = 3) -> None:
        self.alpha = alpha
        self.gate_rad = gate_rad
        self.reset_after = reset_after
        self.xy: tuple[float, float] | None = None
        self.heading = 0.0
        self.rejected = 0
        self._streak = 0

    def update(self, T_map_tag: np.ndarray) -> bool:
        """Fold in one measurement; False when it was gated out as a flip."""
        nx, ny = floor_normal(T_map_tag)
        heading = math.atan2(ny, nx)
        x, y = float(T_map_tag[0, 3]), float(T_map_tag[1, 3])
        if self.xy is None:
            self.xy, self.heading = (x, y), heading
            return True
        kept = True
        jump = se3.wrap_angle(heading - self.heading)
        if abs(jump) > self.gate_rad:
            self._streak += 1
            self.rejected += 1
            if self._streak < self.reset_after:
                kept = False
            else:
                self.heading, self._streak = heading, 0
        else:
            self.heading = se3.wrap_angle(self.heading + self.alpha * jump)
            self._streak = 0
        a = self.alpha
        self.xy = ((1 - a) * self.xy[0] + a * x, (1 - a) * self.xy[1] + a * y)
        return kept

    @property
    def normal(self) -> tuple[float, float]:
        """The filtered face normal on the floor (unit)."""
        return math.cos(self.heading), math.sin(self.heading)


class VisualServoDock(MissionLeaf):
    """DOCK (final approach): TWIST commands from the live tag pose to the stand-off, within tolerance."""

    @dataclass(frozen=True, kw_only=True)
    class Params:
        target: str = port("dock", "name of the dock target (a key of perception.targets)")
        standoff_m: float = port(0.30, "final distance from the camera optical centre to the tag plane")
        lateral_tol_m: float = port(0.03, "success tolerance on the lateral offset")
        distance_tol_m: float = port(0.025, "success tolerance on |distance − standoff|")
        skew_tol_deg: float = port(10.0, "success tolerance on the skew")
        max_v: float = port(0.25, "forward speed limit (m/s)")
        max_w: float = port(0.75, "yaw rate limit (rad/s)")
        detection_timeout_s: float = port(1.0, "fail when the tag is unseen this long")
        timeout_s: float = port(30.0, "give up after this long")

    NODE_TYPE = "Action"
    READS = (bbk.TRACKS,)
    WRITES = (bbk.DOCK_SETPOINT,)
    COMMANDS = True
    params: Params

    def __init__(self, name: str | None = None, **ports: Any) -> None:
        super().__init__(name, **ports)
        self.gains = ServoGains()
        self._reset()

    # Derived from the ports when used: a port read from the blackboard may change between ticks.
    @property
    def skew_tol_rad(self) -> float:
        return math.radians(self.params.skew_tol_deg)

    @property
    def speed_limit(self) -> float:
        return abs(self.params.max_v)  # limits: the sign of what was written does not matter

    @property
    def turn_limit(self) -> float:
        return abs(self.params.max_w)

    def _reset(self) -> None:
        self.filter = FloorTagFilter()
        self.phase = "approach"
        self.backoffs = 0
        self.offsets: DockOffsets | None = None
        self._t0 = 0.0
        self._used_seen: float | None = None
        self._settled = 0
        self._within_since: float | None = None

    def initialise(self) -> None:
        self._reset()
        self._t0 = self.now()
        tr = self.track(self.params.target)
        if tr is not None and tr.pose_map is not None:
            self.filter.update(tr.pose_map)  # start from what staging saw; live detections take over
            self._used_seen = tr.last_seen
        self.feedback_message = f"DOCK: servoing on {self.params.target}"

    def _describe(self, off: DockOffsets) -> str:
        return (
            f"stand-off {off.standoff_m:.3f} m (→{self.params.standoff_m:.2f}), lateral {100 * off.lateral_m:+.1f} cm, "
            f"skew {off.skew_deg:+.1f}°"
        )

    def _where(self) -> str:
        """Where the servo last had the robot, for a failure's reason ('' before the first offsets)."""
        return f" at {self._describe(self.offsets)}" if self.offsets is not None else ""

    def _within(self, off: DockOffsets) -> bool:
        return (
            abs(off.standoff_m - self.params.standoff_m) <= self.params.distance_tol_m
            and abs(off.lateral_m) <= self.params.lateral_tol_m
            and abs(off.skew_rad) <= self.skew_tol_rad
        )

    def _tight(self, off: DockOffsets) -> bool:
        return (
            abs(off.standoff_m - self.params.standoff_m) <= TIGHT_DISTANCE * self.params.distance_tol_m
            and abs(off.lateral_m) <= TIGHT_LATERAL * self.params.lateral_tol_m
            and abs(off.skew_rad) <= TIGHT_SKEW * self.skew_tol_rad
        )

    def update(self) -> py_trees.common.Status:
        self.set_state(MissionState.DOCK)
        now = self.now()
        tr = self.track(self.params.target)
        if tr is None or tr.last_seen is None:
            return self.fail(f"DOCK: {self.params.target} was never seen, nothing to servo on")
        if now - self._t0 > self.params.timeout_s:
            return self.fail(f"DOCK: not docked within {self.params.timeout_s:g} s{self._where()}")
        unseen = now - max(tr.last_seen, self._t0)
        if unseen > self.params.detection_timeout_s:
            return self.fail(
                f"DOCK: {self.params.target} tag unseen for {unseen:.1f} s "
                f"(> {self.params.detection_timeout_s:.1f} s){self._where()}"
            )
        state = self.robot()
        if state is None:
            self.halt()
            self.feedback_message = self.waiting_for_pose("DOCK: ")
            return py_trees.common.Status.RUNNING
        fresh = tr.last_seen != self._used_seen and tr.pose_map is not None
        if fresh:
            self._used_seen = tr.last_seen
            self.filter.update(tr.pose_map)
            if tr.detection is not None:
                det = tr.detection
                pose_camera = (tuple(float(v) for v in det.position), tuple(float(v) for v in det.orientation))
                self.write(bbk.DOCK_SETPOINT, DockSetpoint(pose_camera=pose_camera, stamp=float(tr.last_seen)))
        if self.filter.xy is None:
            self.halt()
            self.feedback_message = f"DOCK: waiting for a map pose of {self.params.target}"
            return py_trees.common.Status.RUNNING
        off = floor_offsets(self.camera_xy(state.pose), self.filter.xy, self.filter.normal, state.pose.yaw)
        self.offsets = off

        if self._within(off):
            if self._within_since is None:
                self._within_since = now
            if fresh:
                self._settled += 1
            done = self._tight(off) or now - self._within_since >= SETTLE_S
            if done and self._settled >= SETTLE_DETECTIONS:
                self.halt()
                msg = (
                    f"DOCK: docked: lateral {100 * abs(off.lateral_m):.1f} cm, "
                    f"distance {100 * abs(off.standoff_m - self.params.standoff_m):.1f} cm, "
                    f"skew {abs(off.skew_deg):.1f}°"
                )
                self.write(bbk.REASON, msg)
                self.feedback_message = msg
                return py_trees.common.Status.SUCCESS
        else:
            self._settled = 0
            self._within_since = None

        remaining = off.standoff_m - self.params.standoff_m
        # Arriving with a lateral offset the servo cannot remove in place: back off and come in again. Aim for
        # the tight band the first times, then settle for the tolerance (no endless re-approaches).
        lateral_limit = (TIGHT_LATERAL if self.backoffs < TIGHT_BACKOFFS else 1.0) * self.params.lateral_tol_m
        if self.phase == "approach" and remaining < self.params.distance_tol_m and abs(off.lateral_m) > lateral_limit:
            self.phase = "backoff"
            self.backoffs += 1
        elif self.phase == "backoff" and remaining >= self.gains.backoff_m:
            self.phase = "approach"
        if self.phase == "backoff":
            cmd = backoff_command(off, self.speed_limit, self.turn_limit, self.gains)
            doing = f"backing off to re-approach (lateral off by more than {100 * self.params.lateral_tol_m:.0f} cm)"
        else:
            cmd = approach_command(
                off,
                self.params.standoff_m,
                self.speed_limit,
                self.turn_limit,
                self.gains,
                deadband_m=DEADBAND * self.params.distance_tol_m,
            )
            doing = "approaching"
        self.drive(cmd.v, cmd.w)
        self.feedback_message = f"DOCK: {doing}: {self._describe(off)}; v {cmd.v:.2f} w {cmd.w:+.2f}"
        return py_trees.common.Status.RUNNING
