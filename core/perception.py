"""The perception contract: a source turns a Frame into Detections, and nothing else; the perception stage
(perception_plugins/pipeline.py) makes of each frame one :class:`Perceived`, which observers watch.

Sources are found through the entry-point group ``mission.perception_plugins`` (core/plugins.py,
perception_plugins/registry.py), so a third party adds one by installing a package.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import ClassVar, Protocol, runtime_checkable

from mission.core.plugins import PERCEPTION_SOURCES
from mission.core.types import Detection, Frame

ENTRY_POINT_GROUP = PERCEPTION_SOURCES.group  # where sources register (core/plugins.py)
TARGET_LABEL = "red box"  # the simulated target's label, and what the VLM source looks for unless told otherwise


@runtime_checkable
class PerceptionSource(Protocol):
    """What every perception plugin implements (a handful of methods, as Nav2's plugin interfaces).

    * The class attribute ``description`` is the one line ``mission plugins`` prints.
    * The constructor takes the validated params mapping and the instance name; a bad param raises
      :class:`mission.core.errors.ConfigError` naming the key. It must be light: no model loading
      that blocks for seconds (do that lazily, off the tick).
    * ``process(frame)`` returns the detections in that frame (possibly empty). It may raise; the
      caller isolates the failure.
    * ``close()`` releases threads, files and handles.
    * Optional: a class attribute ``requires`` (a set of ``Frame`` fields, e.g. ``{"depth"}``) names what a
      frame must carry for the source to find anything; tools that build frames (``mission detect``) say so
      instead of returning nothing. Optional: ``wait_idle(timeout) -> bool`` for sources that answer off
      the tick (the VLM), so a batch tool can wait for the answer to a frame.
    """

    description: ClassVar[str]
    name: str

    def process(self, frame: Frame) -> list[Detection]: ...

    def close(self) -> None: ...


@dataclass
class Perceived:
    """What the stage made of one frame: kept for observers (ROS outputs, logs) and the blackboard."""

    frame: Frame | None
    seq: int
    detections: list[Detection] = field(default_factory=list)  # kept after the policy, best first per target
    summary: str = ""  # one readable line: what was seen where, or why the frame was dropped
    errors: list[str] = field(default_factory=list)  # sources that raised on this frame
    dropped: str | None = None  # frames_dropped / frames_stale / frames_duplicate when not processed

    @property
    def processed(self) -> bool:
        return self.dropped is None
