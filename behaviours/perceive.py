"""PerceiveTargets: kept so trees written before perception became a stage still load and run.

Perception used to be a leaf that trees ticked first (``<ForceSuccess><PerceiveTargets/></ForceSuccess>``).
It is now a stage of the runner that runs on every new frame before the tree ticks
(perception_plugins/pipeline.py), so the leaf has nothing left to do: it succeeds at once, says so in
its feedback, and logs one warning when the tree is set up. Remove it from your trees.
"""

from __future__ import annotations

import logging
from typing import ClassVar

import py_trees

from mission.behaviours.leaf import MissionLeaf

log = logging.getLogger(__name__)

NOTE = "perception runs as a stage before every tick; this leaf does nothing (remove it from the tree)"


class PerceiveTargets(MissionLeaf):
    """Deprecated no-op: perception runs as a stage before every tick. SUCCESS at once."""

    NODE_TYPE = "Action"
    DEPRECATED: ClassVar[bool] = True  # loads and runs; Groot2's palette (TreeNodesModel) leaves it out

    def setup(self, **kwargs: object) -> None:
        log.warning("%s: %s", self.name, NOTE)

    def update(self) -> py_trees.common.Status:
        self.feedback_message = NOTE
        return py_trees.common.Status.SUCCESS
