"""FollowTarget: the goal generator of the design notes (FOLLOW state).

Target pose camera → map is done once, in PerceiveTargets (T_map_target through the robot pose and the
camera extrinsics); this leaf smooths the map positions with a moving average over the last `window`
detections and sends a navigation goal `offset_m` short of the target on the robot's side, facing it,
at most `rate_hz` times a second (each with a new seq, as Nav2's /goal_pose republished).

A target close by that the robot has lost off the image's side is faced first, by a turn on the spot: the
navigator's path to a goal 0.5 m short of a near target bends round whatever stands beside it, and driving
on along that bend pushes the target further off the image while IsTargetVisible's grace keeps FOLLOW
running (hide_and_wait seed 5601, typical: a target standing 0.9 m away slid off the left side as the path
bent round the crates, and SEARCH, when the grace ran out, turned right first). Only a near target
(`face_range_m`): farther off, the navigator's own turns at the path's bends bring it back, and a face turn
fought the path at the crates' corner of hide_and_wait (at 2 m the robot dithered there: seeds 5103, 5105,
typical; at 1.2 m they succeed and 5601 is mended).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import py_trees

from mission.behaviours.approach import approach_goal, bearing_to
from mission.behaviours.leaf import MissionLeaf
from mission.behaviours.line_of_sight import predicted_position
from mission.behaviours.ports import port
from mission.behaviours.search_leaf import GLANCE_EDGE_RAD, turn_rate
from mission.core import blackboard as bbk
from mission.core.blackboard import MissionState
from mission.core.types import NavGoal, Pose2D

FACE_RATE_RAD_S = 0.8  # the face turn's top rate: the search ladder's sweep rate at a viewpoint


class FollowTarget(MissionLeaf):
    """FOLLOW: keep sending a smoothed approach goal behind the target; always RUNNING."""

    @dataclass(frozen=True, kw_only=True)
    class Params:
        target: str = port("target", "name of the target (a key of perception.targets)")
        offset_m: float = port(0.5, "stop this far before the target, on the robot's side")
        window: int = port(5, "moving average over the last N detections (map frame)")
        rate_hz: float = port(10.0, "maximum goal rate")
        face_range_m: float = port(
            0.0,
            "a target this close that is not detected, at the image's side or past it, is faced by a turn on the "
            "spot before the robot drives on; 0 = never",
        )
        goal: Pose2D = port(doc="the approach goal last sent (map frame)", direction="output")

        def __post_init__(self) -> None:
            if self.window < 1 or self.rate_hz <= 0 or self.offset_m < 0:
                raise ValueError(
                    "expected window ≥ 1, rate_hz > 0, offset_m ≥ 0 "
                    f"(got {self.window}, {self.rate_hz}, {self.offset_m})"
                )
            if self.face_range_m < 0:
                raise ValueError(f"expected face_range_m ≥ 0 (got {self.face_range_m})")

    NODE_TYPE = "Action"
    READS = (bbk.TRACKS, bbk.FRAME)
    COMMANDS = True
    params: Params

    def __init__(self, name: str | None = None, **ports: Any) -> None:
        super().__init__(name, **ports)
        self._goal: NavGoal | None = None
        self._sent_at: float | None = None

    @property
    def period(self) -> float:
        """Seconds between goals (from rate_hz, which a tree may read from the blackboard)."""
        return 1.0 / self.params.rate_hz

    def initialise(self) -> None:
        self._goal = None
        self._sent_at = None
        self.feedback_message = f"following {self.params.target}"

    def smoothed_target(self) -> tuple[float, float] | None:
        """Mean map position over the last `window` detections of the target (None before any)."""
        tr = self.track(self.params.target)
        if tr is None or not tr.history:
            return None
        pts = tr.history[-self.params.window :]
        # summed in order on Python floats, as numpy's mean over rows would (a tenth of its cost per tick)
        sx = sy = 0.0
        for _, x, y in pts:
            sx += x
            sy += y
        return sx / len(pts), sy / len(pts)

    def off_image_by(self, robot: Pose2D) -> float | None:
        """The target's bearing from the camera's axis (rad, positive to the left) when it has to be faced
        before the robot drives on: not detected this frame, its place (predicted from its walk, or where it
        was last seen) within face_range_m, and at the image's side (within GLANCE_EDGE_RAD of it, where its
        marker is partly cut off) or past it. None otherwise."""
        if self.params.face_range_m <= 0:
            return None
        tr = self.track(self.params.target)
        if tr is None or tr.misses == 0 or tr.pose_map is None:
            return None
        place = predicted_position(tr, self.now()) or (float(tr.pose_map[0, 3]), float(tr.pose_map[1, 3]))
        camera = Pose2D(*self.camera_pose(robot))
        if math.hypot(place[0] - camera.x, place[1] - camera.y) > self.params.face_range_m:
            return None
        bearing = bearing_to(camera, place)
        if abs(bearing) < self.hfov() / 2 - GLANCE_EDGE_RAD:
            return None
        return bearing

    def update(self) -> py_trees.common.Status:
        self.set_state(MissionState.FOLLOW)
        now = self.now()
        state = self.robot()
        bearing = None if state is None else self.off_image_by(state.pose)
        if bearing is not None:
            self.drive(0.0, turn_rate(bearing, FACE_RATE_RAD_S))
            self._goal = self._sent_at = None  # once faced, a new goal at once
            side = "left" if bearing > 0 else "right"
            self.feedback_message = (
                f"turning to face {self.params.target}: {abs(math.degrees(bearing)):.0f}° to the {side}, "
                "at the image's side or past it"
            )
            return py_trees.common.Status.RUNNING
        if self._goal is not None and self._sent_at is not None and now - self._sent_at < self.period - 1e-6:
            self.resend_goal(self._goal)  # same seq: the navigator sees nothing new; TWIST stays cleared
            return py_trees.common.Status.RUNNING
        target_xy = self.smoothed_target()
        if target_xy is None or state is None:
            self.halt()
            self.feedback_message = (
                f"waiting for {self.params.target}'s map position" if state is not None else self.waiting_for_pose()
            )
            return py_trees.common.Status.RUNNING
        robot_xy = (state.pose.x, state.pose.y)
        goal = approach_goal(robot_xy, target_xy, self.params.offset_m)
        self._goal = self.navigate(goal)
        self.set_output("goal", goal)
        self._sent_at = now
        dist = math.hypot(target_xy[0] - robot_xy[0], target_xy[1] - robot_xy[1])
        self.feedback_message = (
            f"following {self.params.target} {dist:.1f} m away, goal ({goal.x:.2f}, {goal.y:.2f}) seq {self._goal.seq}"
        )
        return py_trees.common.Status.RUNNING
