"""SetMissionState: a tree announces a phase or an outcome (e.g. DONE at the end of explore → dock)."""

from __future__ import annotations

from dataclasses import dataclass

import py_trees

from mission.behaviours.leaf import MissionLeaf
from mission.behaviours.ports import port
from mission.core import blackboard as bbk
from mission.core.blackboard import MissionState

STATES = tuple(v for k, v in vars(MissionState).items() if not k.startswith("_"))


class SetMissionState(MissionLeaf):
    """Write `state` to /mission/state and succeed."""

    @dataclass(frozen=True, kw_only=True)
    class Params:
        state: str = port(doc="one of " + ", ".join(STATES))

        def __post_init__(self) -> None:
            if self.state not in STATES:
                raise ValueError(f"state: expected one of {', '.join(STATES)}, got {self.state!r}")

    NODE_TYPE = "Action"
    WRITES = (bbk.STATE,)
    params: Params

    def update(self) -> py_trees.common.Status:
        self.set_state(self.params.state)
        self.feedback_message = f"mission state ← {self.params.state}"
        return py_trees.common.Status.SUCCESS
