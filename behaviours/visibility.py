"""IsTargetVisible: is the target being seen right now (tolerating a few dropped frames)?"""

from __future__ import annotations

from typing import ClassVar

import py_trees

from mission.behaviours.leaf import MissionLeaf
from mission.behaviours.ports import Port
from mission.behaviours.registry import register
from mission.core import blackboard as bbk


@register
class IsTargetVisible(MissionLeaf):
    """SUCCESS when the track has been seen and its consecutive misses ≤ max_misses.

    ``max_misses`` lets FOLLOW ride through a few frames where the detector blinks (the design notes ask for
    tolerance of 1–2 frame intermittent occlusions) instead of flickering into LOST/SEARCH.
    """

    NODE_TYPE = "Condition"
    PORTS: ClassVar[dict[str, Port]] = {
        "target": Port(str, "target", "name of the target (a key of perception.targets)"),
        "max_misses": Port(int, 0, "consecutive missed frames still counted as visible"),
    }
    READS = (bbk.TRACKS,)

    def __init__(self, name: str = "IsTargetVisible", *, target: str = "target", max_misses: int = 0) -> None:
        super().__init__(name)
        self.target = target
        self.max_misses = int(max_misses)

    def update(self) -> py_trees.common.Status:
        tr = self.track(self.target)
        if tr is None or tr.last_seen is None:
            self.feedback_message = f"{self.target} never seen"
            return py_trees.common.Status.FAILURE
        age = self.now() - tr.last_seen
        if tr.misses <= self.max_misses:
            self.feedback_message = (
                f"{self.target} visible (seen {age:.1f} s ago, {tr.misses} miss(es) ≤ {self.max_misses})"
            )
            return py_trees.common.Status.SUCCESS
        self.feedback_message = (
            f"{self.target} not visible: {tr.misses} misses > {self.max_misses}, last seen {age:.1f} s ago"
        )
        return py_trees.common.Status.FAILURE
