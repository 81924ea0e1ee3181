"""Things that watch a run tick by tick (live terminal, tick log, web view, recordings, bags).

The run loop calls every observer at start, after each tick and at the end; an observer never changes
what the tree does. Keeping them out of the loop keeps the loop the same with or without viewers.
"""

from __future__ import annotations

from typing import Any, Protocol


class TickObserver(Protocol):
    def on_start(self, runner: Any, adapter: Any) -> None: ...

    def on_tick(self, runner: Any, adapter: Any, ground_truth: Any) -> None: ...

    def on_end(self, runner: Any, adapter: Any, outcome: Any) -> None: ...
