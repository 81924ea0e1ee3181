"""TreeRunner: one tree, one world adapter, one perception stack — the loop every world shares.

The simulated run (`mission run`), the ROS node (`mission tree`) and replay all drive a world through
this class, so the same tree behaves the same way everywhere::

    runner = TreeRunner(config, adapter)
    runner.setup()            # validate the tree, create sources, build the tree, connect the world
    while ...:
        status = runner.tick()   # sense → tick → act
        adapter.advance(dt)      # simulated worlds only
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import py_trees

from mission.app.snapshot import active_branch, snapshot
from mission.behaviours.ports import Dependencies
from mission.core import blackboard as bbk
from mission.core.config import MissionConfig
from mission.core.errors import TreeError
from mission.core.perception import PerceptionSource
from mission.core.types import NavStatus
from mission.core.world import WorldAdapter
from mission.perception_plugins import registry
from mission.trees.factory import shipped_factory
from mission.trees.loader import check_targets, load_tree, resolve_tree_path, validate_tree


def resolve_tree(tree: str, config_file: str | Path | None = None) -> Path:
    """A tree named in config: relative to the config file if it exists there, else a shipped tree."""
    if config_file is not None:
        candidate = Path(config_file).parent / tree
        if candidate.is_file():
            return candidate
    return resolve_tree_path(tree)


class TreeRunner:
    """Owns the tree, the perception sources and the blackboard; borrows the world adapter."""

    def __init__(
        self,
        config: MissionConfig,
        adapter: WorldAdapter,
        tree: str | None = None,
        *,
        config_file: str | Path | None = None,
        sources: list[PerceptionSource] | None = None,
    ) -> None:
        self.config = config
        self.adapter = adapter
        self.tree_name = tree or config.tree
        self.config_file = config_file
        self.sources: list[PerceptionSource] = list(sources) if sources is not None else []
        self._own_sources = sources is None
        self.tree_path: Path | None = None
        self.tree: py_trees.trees.BehaviourTree | None = None
        self.bb = bbk.writer("runner")
        self.ticks = 0

    # -- lifecycle ---------------------------------------------------------------------------------
    def setup(self) -> None:
        """Validate before anything heavy, then create sources, build the tree and connect the world."""
        try:
            self.tree_path = resolve_tree(self.tree_name, self.config_file)
        except TreeError as err:
            if self.config_file is None or self.tree_name != self.config.tree:
                raise
            raise TreeError(f"{self.config_file}: tree: {err}") from None  # say which config named it
        validate_tree(self.tree_path)
        check_targets(self.tree_path, self.config.perception.targets)
        if self._own_sources:
            file = None if self.config_file is None else str(self.config_file)
            self.sources = registry.create_all(self.config.perception.sources, file=file)
        deps = Dependencies(
            sources=self.sources, targets=dict(self.config.perception.targets), policy=self.config.perception.policy
        )
        root = load_tree(self.tree_path, shipped_factory(deps))
        self._seed_blackboard()
        self.tree = py_trees.trees.BehaviourTree(root)
        self.tree.setup(timeout=30.0)
        self.adapter.setup()

    def _seed_blackboard(self) -> None:
        for key, value in (
            (bbk.NAV_GOAL, None),
            (bbk.TWIST, None),
            (bbk.NAV_STATUS, NavStatus.IDLE),
            (bbk.DOCK_SETPOINT, None),
            (bbk.STATE, ""),
            (bbk.REASON, ""),
            (bbk.TRACKS, {}),
            (bbk.DETECTIONS, []),
            (bbk.PERCEPTION_STATS, {}),
            (bbk.FRAME, None),
            (bbk.FRAME_SEQ, 0),
        ):
            bbk.set_(self.bb, key, value)

    def tick(self) -> py_trees.common.Status:
        """One cycle: the world's newest inputs → one tree tick → the tree's commands to the world."""
        assert self.tree is not None, "call setup() first"
        self.adapter.sense(self.bb)
        self.tree.tick()
        self.adapter.act(self.bb)
        self.ticks += 1
        return self.tree.root.status

    def close(self) -> None:
        if self.tree is not None:
            self.tree.shutdown()
        if self._own_sources:
            for s in self.sources:
                s.close()
        self.adapter.close()

    # -- what viewers read -------------------------------------------------------------------------
    @property
    def root(self) -> py_trees.behaviour.Behaviour:
        assert self.tree is not None, "call setup() first"
        return self.tree.root

    def snapshot(self) -> dict[str, Any]:
        """The tree with statuses and feedback, plus the mission state (JSON-serialisable)."""
        return {
            "tick": self.ticks,
            "clock": bbk.get(self.bb, bbk.CLOCK, 0.0),
            "state": bbk.get(self.bb, bbk.STATE, ""),
            "tree": snapshot(self.root),
        }

    def active_branch(self) -> list[str]:
        return active_branch(self.root)

    def get(self, key: bbk.Key, default: Any = None) -> Any:
        return bbk.get(self.bb, key, default)
