"""The perception contract: a source turns a Frame into Detections, and nothing else.

Sources are found through the entry-point group ``mission.perception_plugins`` (see
perception_plugins/registry.py), so a third party adds one by installing a package.
"""

from __future__ import annotations

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
