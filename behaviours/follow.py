"""FollowTarget: the goal generator of the design notes (FOLLOW state).

Target pose camera → map is done once, in PerceiveTargets (T_map_target through the robot pose and the
camera extrinsics); this leaf smooths the map positions with a moving average over the last `window`
detections and sends a navigation goal `offset_m` short of the target on the robot's side, facing it,
at most `rate_hz` times a second (each with a new seq, as Nav2's /goal_pose republished).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import py_trees

from mission.behaviours.approach import approach_goal
from mission.behaviours.leaf import MissionLeaf
from mission.behaviours.ports import port
from mission.core import blackboard as bbk
from mission.core.blackboard import MissionState
from mission.core.types import NavGoal, Pose2D


class FollowTarget(MissionLeaf):
    """FOLLOW: keep sending a smoothed approach goal behind the target; always RUNNING."""

    @dataclass(frozen=True, kw_only=True)
    class Params:
        target: str = port("target", "name of the target (a key of perception.targets)")
        offset_m: float = port(0.5, "stop this far before the target, on the robot's side")
        window: int = port(5, "moving average over the last N detections (map frame)")
        rate_hz: float = port(10.0, "maximum goal rate")
        goal: Pose2D = port(doc="the approach goal last sent (map frame)", direction="output")

        def __post_init__(self) -> None:
            if self.window < 1 or self.rate_hz <= 0 or self.offset_m < 0:
                raise ValueError(
                    "expected window ≥ 1, rate_hz > 0, offset_m ≥ 0 "
                    f"(got {self.window}, {self.rate_hz}, {self.offset_m})"
                )

    NODE_TYPE = "Action"
    READS = (bbk.TRACKS,)
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

    def update(self) -> py_trees.common.Status:
        self.set_state(MissionState.FOLLOW)
        now = self.now()
        if self._goal is not None and self._sent_at is not None and now - self._sent_at < self.period - 1e-6:
            self.resend_goal(self._goal)  # same seq: the navigator sees nothing new; TWIST stays cleared
            return py_trees.common.Status.RUNNING
        target_xy = self.smoothed_target()
        state = self.robot()
        if target_xy is None or state is None:
            self.halt()
            self.feedback_message = (
                f"waiting for {self.params.target}'s map position"
                if state is not None
                else self.waiting_for_pose()
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
