"""GoToPose: navigate to a pose the tree is given — a dock's staging pose from the dock database, a pose a
Nav2 client sent — rather than one perception found.

The pose comes from a port (a blackboard entry the server or another node wrote, ``pose="{staging_pose}"``,
or a literal ``"x;y;yaw"`` in the map frame). The navigator decides how to get there (Nav2's
``navigate_to_pose`` on a robot, the simulated planner in the sim); this leaf sends the goal once, keeps it
while it is being followed, and reports the navigator's verdict.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import py_trees

from mission.behaviours.leaf import MissionLeaf
from mission.behaviours.ports import port
from mission.core.types import NavGoal, NavStatus, Pose2D


class GoToPose(MissionLeaf):
    """Navigate to `pose`: SUCCESS when the navigator reports it reached; FAILURE with the navigator's reason, or
    after `timeout_s`."""

    @dataclass(frozen=True, kw_only=True)
    class Params:
        pose: Pose2D = port(doc="where to go (map frame): a blackboard entry such as {staging_pose}, or 'x;y;yaw'")
        timeout_s: float = port(0.0, "give up after this long; 0 = no limit")
        what: str = port("the goal", "what the pose is, as the feedback and a failure's reason name it")

    NODE_TYPE = "Action"
    COMMANDS = True
    params: Params

    def __init__(self, name: str | None = None, **ports: Any) -> None:
        super().__init__(name, **ports)
        self._goal: NavGoal | None = None
        self._t0 = 0.0

    def initialise(self) -> None:
        self._goal = None
        self._t0 = self.now()
        self.feedback_message = f"going to {self.params.what}"

    def update(self) -> py_trees.common.Status:
        pose, what = self.params.pose, self.params.what
        where = f"{what} ({pose.x:.2f}, {pose.y:.2f}, {round(math.degrees(pose.yaw))}°)"
        if self.params.timeout_s > 0 and self.now() - self._t0 > self.params.timeout_s:
            return self.fail(f"{where} not reached within {self.params.timeout_s:g} s")
        if self._goal is None or self._goal.pose != pose:  # a new pose (the entry was rewritten): a new goal
            self._goal = self.navigate(pose)
        else:
            self.resend_goal(self._goal)
        outcome = self.nav_outcome(self._goal)
        if outcome == NavStatus.SUCCEEDED:
            self.halt()
            self.feedback_message = f"at {where}"
            return py_trees.common.Status.SUCCESS
        if outcome == NavStatus.FAILED:
            why = self.nav_reason()
            return self.fail(f"navigation to {where} failed" + (f": {why}" if why else ""))
        state = self.robot()
        togo = f", {math.hypot(pose.x - state.pose.x, pose.y - state.pose.y):.2f} m to go" if state else ""
        self.feedback_message = f"to {where}{togo}"
        return py_trees.common.Status.RUNNING
