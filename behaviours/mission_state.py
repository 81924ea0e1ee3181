"""SetMissionState: a tree announces a phase or an outcome (e.g. DONE at the end of explore → dock)."""

from __future__ import annotations

from typing import ClassVar

import py_trees

from mission.behaviours.leaf import MissionLeaf
from mission.behaviours.ports import REQUIRED, Port
from mission.behaviours.registry import register
from mission.core import blackboard as bbk
from mission.core.blackboard import MissionState

STATES = tuple(v for k, v in vars(MissionState).items() if not k.startswith("_"))


@register
class SetMissionState(MissionLeaf):
    """Write `state` to /mission/state and succeed."""

    NODE_TYPE = "Action"
    PORTS: ClassVar[dict[str, Port]] = {
        "state": Port(str, REQUIRED, "one of " + ", ".join(STATES)),
    }
    WRITES = (bbk.STATE,)

    def __init__(self, name: str = "SetMissionState", *, state: str) -> None:
        super().__init__(name)
        if state not in STATES:
            raise ValueError(f"state: expected one of {', '.join(STATES)}, got {state!r}")
        self.state = state

    def update(self) -> py_trees.common.Status:
        self.set_state(self.state)
        self.feedback_message = f"mission state ← {self.state}"
        return py_trees.common.Status.SUCCESS
