"""IsTargetVisible: is the target being seen right now (tolerating a few dropped frames)?"""

from __future__ import annotations

from dataclasses import dataclass

import py_trees

from mission.behaviours.leaf import MissionLeaf
from mission.behaviours.ports import port
from mission.core import blackboard as bbk
from mission.core.docking import floor_pose
from mission.core.types import Pose2D


class IsTargetVisible(MissionLeaf):
    """SUCCESS when the track has been seen and its consecutive misses ≤ max_misses.

    ``max_misses`` lets FOLLOW ride through a few frames where the detector blinks (the design notes ask for
    tolerance of 1–2 frame intermittent occlusions) instead of flickering into LOST/SEARCH.
    """

    @dataclass(frozen=True, kw_only=True)
    class Params:
        target: str = port("target", "name of the target (a key of perception.targets)")
        max_misses: int = port(0, "consecutive missed frames still counted as visible")
        visible: bool = port(doc="the answer, as true/false (for scripts and other nodes)", direction="output")
        last_seen_pose: Pose2D = port(
            doc="where the target was last seen (map frame; heading = its face normal's)", direction="output"
        )

    NODE_TYPE = "Condition"
    READS = (bbk.TRACKS,)
    params: Params

    def update(self) -> py_trees.common.Status:
        target, max_misses = self.params.target, self.params.max_misses
        tr = self.track(target)
        if tr is None or tr.last_seen is None:
            self.set_output("visible", False)
            self.feedback_message = f"{target} never seen"
            return py_trees.common.Status.FAILURE
        if tr.pose_map is not None and self.output_connected("last_seen_pose"):
            self.set_output("last_seen_pose", floor_pose(tr.pose_map))
        age = self.now() - tr.last_seen
        self.set_output("visible", tr.misses <= max_misses)
        if tr.misses <= max_misses:
            self.feedback_message = f"{target} visible (seen {age:.1f} s ago, {tr.misses} miss(es) ≤ {max_misses})"
            return py_trees.common.Status.SUCCESS
        self.feedback_message = f"{target} not visible: {tr.misses} misses > {max_misses}, last seen {age:.1f} s ago"
        return py_trees.common.Status.FAILURE
