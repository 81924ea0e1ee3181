"""HoldLastGoal: the LOST state — keep going to where the target was, for a while.

The goal is frozen at the last known target position, with the same approach offset as FollowTarget
(`offset_m` before it along the robot → target direction at the moment it was last seen, facing it):
the robot goes around the obstacle toward the target instead of driving into where it stood. The loss
timer is `now − last_seen`, so leaving and re-entering LOST does not restart it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import py_trees

from mission.behaviours.approach import approach_goal
from mission.behaviours.leaf import MissionLeaf
from mission.behaviours.ports import port
from mission.core import blackboard as bbk
from mission.core.blackboard import MissionState
from mission.core.types import NavGoal, Pose2D


class HoldLastGoal(MissionLeaf):
    """LOST: navigate to the frozen last-known goal; RUNNING until now − last_seen > timeout_s, then FAILURE."""

    @dataclass(frozen=True, kw_only=True)
    class Params:
        target: str = port("target", "name of the target (a key of perception.targets)")
        timeout_s: float = port(3.0, "give up holding this long after the target was last seen")
        offset_m: float = port(0.5, "approach offset before the last known position (as FollowTarget)")
        goal: Pose2D = port(doc="the frozen goal it holds (map frame)", direction="output")

    NODE_TYPE = "Action"
    READS = (bbk.TRACKS,)
    COMMANDS = True
    params: Params

    def __init__(self, name: str | None = None, **ports: Any) -> None:
        super().__init__(name, **ports)
        self._goal: NavGoal | None = None
        self._goal_for: float | None = None  # last_seen the frozen goal was computed from

    def initialise(self) -> None:
        self._goal = None
        self._goal_for = None
        self.feedback_message = f"LOST: holding the last goal for {self.params.target}"

    def update(self) -> py_trees.common.Status:
        tr = self.track(self.params.target)
        if tr is None or tr.last_seen is None or tr.pose_map is None:
            return self.fail(f"LOST: {self.params.target} was never placed in the map, no goal to hold")
        lost_for = self.now() - tr.last_seen
        if lost_for > self.params.timeout_s:  # the loss timer has run out: not LOST (any more), SEARCH takes over
            return self.fail(
                f"LOST: {self.params.target} unseen for {lost_for:.1f} s > timeout {self.params.timeout_s:.1f} s"
            )
        self.set_state(MissionState.LOST)
        if self._goal is None or self._goal_for != tr.last_seen:
            target_xy = (float(tr.pose_map[0, 3]), float(tr.pose_map[1, 3]))
            seen_from = tr.robot_at_last_seen
            state = self.robot()
            if seen_from is None and state is not None:
                seen_from = state.pose
            robot_xy = (seen_from.x, seen_from.y) if seen_from is not None else target_xy
            self._goal = self.navigate(approach_goal(robot_xy, target_xy, self.params.offset_m))
            self.set_output("goal", self._goal.pose)
            self._goal_for = tr.last_seen
        else:
            self.resend_goal(self._goal)
        g = self._goal.pose
        self.feedback_message = (
            f"LOST: frozen goal ({g.x:.2f}, {g.y:.2f}), {lost_for:.1f} s of {self.params.timeout_s:.1f} s"
        )
        return py_trees.common.Status.RUNNING
