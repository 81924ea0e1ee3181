"""WaitForTarget: wait, standing still, until perception sees a target — Nav2 docking's INITIAL_PERCEPTION.

Between reaching a staging pose and controlling onto the dock, the robot must see the dock first; a camera
needs a few frames (and a detector a few agreeing ones) before a track is trusted. This leaf holds the robot
still and succeeds on the first frame the target is seen, or fails after `timeout_s` with the reason Nav2
calls FAILED_TO_DETECT_DOCK.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import py_trees

from mission.behaviours.leaf import MissionLeaf
from mission.behaviours.ports import port
from mission.core import blackboard as bbk


class WaitForTarget(MissionLeaf):
    """RUNNING (robot stopped) until `target` is seen after this leaf started; FAILURE after `timeout_s`."""

    @dataclass(frozen=True, kw_only=True)
    class Params:
        target: str = port("dock", "name of the target (a key of perception.targets)")
        timeout_s: float = port(5.0, "give up after this long without a sighting (Nav2: initial_perception_timeout)")

    NODE_TYPE = "Action"
    READS = (bbk.TRACKS,)
    COMMANDS = True
    params: Params

    def __init__(self, name: str | None = None, **ports: Any) -> None:
        super().__init__(name, **ports)
        self._t0 = 0.0

    def initialise(self) -> None:
        self._t0 = self.now()
        self.feedback_message = f"looking for {self.params.target}"

    def update(self) -> py_trees.common.Status:
        target, now = self.params.target, self.now()
        tr = self.track(target)
        if tr is not None and tr.last_seen is not None and tr.last_seen >= self._t0 and tr.misses == 0:
            self.feedback_message = f"{target} in view"
            return py_trees.common.Status.SUCCESS
        if now - self._t0 > self.params.timeout_s:
            return self.fail(f"{target} not seen within {self.params.timeout_s:g} s")
        self.halt()
        self.feedback_message = f"looking for {target} ({now - self._t0:.1f} of {self.params.timeout_s:g} s)"
        return py_trees.common.Status.RUNNING
