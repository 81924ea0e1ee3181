"""GoToStaging: the first half of DOCK — navigate to a pose in front of the dock marker, facing it.

The staging pose is `offset_m` in front of the tag along its face normal (Nav2 opennav_docking's staging
offset, 0.7 m), computed with mission.core.docking from the dock track's map pose. Seen from far away a
flat marker's orientation is unreliable (two-fold pose ambiguity), so the goal is refined when the tag has
been re-measured from clearly closer (≥ 0.2 m nearer) and the staging pose moved by more than 10 cm / 10°;
refinements are what the feedback counts.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import py_trees

from mission.behaviours.leaf import MissionLeaf
from mission.behaviours.ports import port
from mission.core import blackboard as bbk
from mission.core import se3
from mission.core.blackboard import MissionState
from mission.core.docking import floor_pose, staging_pose
from mission.core.types import NavGoal, NavStatus, Pose2D

REFINE_CLOSER_M = 0.2
REFINE_MOVE_M = 0.10
REFINE_TURN_RAD = math.radians(10.0)


class GoToStaging(MissionLeaf):
    """DOCK (approach): SUCCESS when the navigator reports the staging pose reached; FAILURE with a reason otherwise."""

    @dataclass(frozen=True, kw_only=True)
    class Params:
        target: str = port("dock", "name of the dock target (a key of perception.targets)")
        offset_m: float = port(0.7, "staging distance in front of the tag, along its normal (base pose)")
        timeout_s: float = port(40.0, "give up after this long")
        dock_pose: Pose2D = port(
            doc="the dock marker on the floor (map frame; heading = its face normal)", direction="output"
        )
        staging_pose: Pose2D = port(doc="the staging pose it navigates to (map frame)", direction="output")

    NODE_TYPE = "Action"
    READS = (bbk.TRACKS,)
    COMMANDS = True
    params: Params

    def __init__(self, name: str | None = None, **ports: Any) -> None:
        super().__init__(name, **ports)
        self._goal: NavGoal | None = None
        self._from_distance = math.inf  # range of the detection the current goal came from
        self._t0 = 0.0
        self.refinements = 0
        self._staged_from: np.ndarray | None = None
        self._staged: Pose2D | None = None
        self._staged_offset = math.nan
        self._where_for: Pose2D | None = None
        self._where_text = ""

    def initialise(self) -> None:
        self._goal = None
        self._from_distance = math.inf
        self._t0 = self.now()
        self.refinements = 0
        self.feedback_message = f"DOCK: going to the staging pose of {self.params.target}"

    def _staging(self, pose_map: np.ndarray) -> Pose2D:
        """The staging pose for the tag at `pose_map`, computed once per new tag pose (the track replaces its
        pose_map with a new array on each detection; between detections it is the same object, and every
        tick reads it)."""
        offset = self.params.offset_m  # a port the tree may connect to the blackboard: part of the key
        if pose_map is not self._staged_from or offset != self._staged_offset:
            self._staged = staging_pose(pose_map, offset)
            self._staged_from, self._staged_offset = pose_map, offset
        assert self._staged is not None
        return self._staged

    def _where(self, g: Pose2D) -> str:
        """The goal as the feedback shows it, formatted once per goal (every tick reads it)."""
        if self._where_for is not g:
            self._where_text = f"({g.x:.2f}, {g.y:.2f}, {round(math.degrees(g.yaw))}°)"
            self._where_for = g
        return self._where_text

    def _wanted(self, pose: Pose2D, distance: float) -> bool:
        if self._goal is None:
            return True
        g = self._goal.pose
        moved = math.hypot(pose.x - g.x, pose.y - g.y) > REFINE_MOVE_M
        turned = abs(se3.wrap_angle(pose.yaw - g.yaw)) > REFINE_TURN_RAD
        return distance < self._from_distance - REFINE_CLOSER_M and (moved or turned)

    def update(self) -> py_trees.common.Status:
        self.set_state(MissionState.DOCK)
        now = self.now()
        tr = self.track(self.params.target)
        if tr is None or tr.pose_map is None:
            if tr is not None and tr.last_seen is not None:  # seen, but the camera pose was unknown (TF)
                fault = self.world_fault()
                return self.fail(
                    f"DOCK: {self.params.target} seen but not placed in the map" + (f" ({fault})" if fault else "")
                )
            return self.fail(f"DOCK: {self.params.target} was never seen, no staging pose")
        if now - self._t0 > self.params.timeout_s:
            return self.fail(f"DOCK: staging pose not reached within {self.params.timeout_s:g} s")
        try:
            pose = self._staging(tr.pose_map)
        except ValueError as err:
            return self.fail(f"DOCK: {self.params.target}: {err}")
        if self.output_connected("dock_pose"):
            self.set_output("dock_pose", floor_pose(tr.pose_map))
        self.set_output("staging_pose", pose)
        distance = tr.detection.distance if tr.detection is not None else math.inf
        if self._wanted(pose, distance):
            if self._goal is not None:
                self.refinements += 1
            self._goal = self.navigate(pose)
            self._from_distance = distance
        else:
            assert self._goal is not None
            self.resend_goal(self._goal)
        outcome = self.nav_outcome(self._goal)
        g = self._goal.pose
        where = self._where(g)
        if outcome == NavStatus.SUCCEEDED:
            self.halt()
            self.feedback_message = f"DOCK: at the staging pose {where}"
            return py_trees.common.Status.SUCCESS
        if outcome == NavStatus.FAILED:
            why = self.nav_reason()
            return self.fail(f"DOCK: navigation to the staging pose {where} failed" + (f": {why}" if why else ""))
        state = self.robot()
        togo = f", {math.hypot(g.x - state.pose.x, g.y - state.pose.y):.2f} m to go" if state is not None else ""
        self.feedback_message = (
            f"DOCK: to staging {where} {self.params.offset_m:.2f} m in front of {self.params.target}{togo}"
            + (f" ({self.refinements} refinement(s))" if self.refinements else "")
        )
        return py_trees.common.Status.RUNNING
