"""BehaviorTree.CPP's blackboards (the root one and one per SubTree instance) in py_trees' one blackboard.

There is one store: py_trees' blackboard, where the mission keys live (core/blackboard.py). A BT.CPP
blackboard entry is an entry of that store, found by a static rule when the tree is loaded (BT.CPP's
remapping is static too, so nothing is looked up per tick):

* the root blackboard's entry ``k`` is the mission key whose BT.CPP name is ``k`` — its path without the
  leading ``/``, ``/`` → ``_``: ``mission_state`` is ``/mission/state``, ``robot_clock`` is ``/robot/clock``,
  ``target_tracks`` is ``/target/tracks`` — and otherwise ``/tree/k``;
* a SubTree instance's own entry ``k`` is ``/tree/<instance path>/k``, the instance path being BT.CPP's
  (``Follow::4``, or the SubTree's ``name``; nested instances joined by ``/``);
* ``{@k}`` is the root blackboard's ``k`` from anywhere; in a SubTree, a remapped port (``target="{tgt}"``)
  is the parent's ``tgt``, ``_autoremap="true"`` makes every key the parent's key of the same name (except
  ``_private`` keys), and a constant (``speed="0.5"``) is an entry of the SubTree's own blackboard.

Entries have a version that every write through this module increments (BT.CPP's ``sequence_id``, read by
``WasEntryUpdated`` / ``SkipUnlessUpdated`` / ``WaitValueUpdate``).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import py_trees

from mission.core import blackboard as bbk
from mission.trees.script import EMPTY

#: where the BT.CPP entries that are not mission keys live
NAMESPACE = "/tree"


def bt_name(key: bbk.Key) -> str:
    """The name a tree file uses for a mission key: ``/mission/state`` → ``mission_state``."""
    return key.path.strip("/").replace("/", "_")


#: the mission keys by their BT.CPP names
MISSION_KEYS: dict[str, bbk.Key] = {bt_name(k): k for k in bbk.ALL_KEYS}
assert len(MISSION_KEYS) == len(bbk.ALL_KEYS), "two mission keys map to the same BT.CPP name"

#: the Python type a mission key holds, where it is one a port can carry (for the load-time type check)
_SIMPLE_TYPES = {"str": str, "float": float, "int": int, "bool": bool}


def key_problem(key: str) -> str | None:
    """Why `key` cannot name a blackboard entry, or None (py_trees reads '.' as an attribute access)."""
    if not key:
        return "an empty key"
    bare = key[1:] if key.startswith("@") else key
    if not bare or "@" in bare:
        return "'@' may only start a key (the root blackboard)"
    if "." in bare:
        return "'.' cannot be part of a key here"
    return None


@dataclass(eq=False)
class Scope:
    """One BT.CPP blackboard: the root (``parent`` None) or a SubTree instance's."""

    path: str = ""  # BT.CPP's instance path: "" for the root, "Follow::4", "Mission::2/Follow::4"
    parent: Scope | None = None
    remap: dict[str, str] = field(default_factory=dict)  # own key → the parent's key (may start with '@')
    constants: dict[str, str] = field(default_factory=dict)  # SubTree attributes with constant values
    autoremap: bool = False

    @property
    def root(self) -> Scope:
        scope = self
        while scope.parent is not None:
            scope = scope.parent
        return scope

    def child(self, path: str, remap: dict[str, str], constants: dict[str, str], autoremap: bool) -> Scope:
        full = f"{self.path}/{path}" if self.path else path
        return Scope(full, self, remap, constants, autoremap)

    def is_local(self, key: str) -> bool:
        """Whether `key` is an entry of this blackboard itself (not the root's, not remapped to the parent's)."""
        if key.startswith("@"):
            return self.parent is None and self.is_local(key[1:])
        return (
            self.parent is None
            or key in self.constants
            or (key not in self.remap and not (self.autoremap and not key.startswith("_")))
        )

    def entry_path(self, key: str) -> str:
        """The py_trees blackboard entry a key of this blackboard is (BT.CPP's getEntry, resolved statically)."""
        if key.startswith("@"):
            return self.root.entry_path(key[1:])
        if key not in self.constants and self.parent is not None:
            if key in self.remap:
                return self.parent.entry_path(self.remap[key])
            if self.autoremap and not key.startswith("_"):
                return self.parent.entry_path(key)
        if self.parent is None:
            mission_key = MISSION_KEYS.get(key)
            return mission_key.path if mission_key is not None else f"{NAMESPACE}/{key}"
        return f"{NAMESPACE}/{self.path}/{key}"


def mission_key_type(path: str) -> type | None:
    """The port type a mission key holds (str, float, …), None when it is not one a port can carry."""
    for key in bbk.ALL_KEYS:
        if key.path == path:
            return _SIMPLE_TYPES.get(key.type)
    return None


# ------------------------------------------------------------------------------- the entries
_versions: dict[str, int] = {}


def read(path: str) -> Any:
    """The entry's value; KeyError when nothing was written there."""
    return py_trees.blackboard.Blackboard.storage[path]


def exists(path: str) -> bool:
    return path in py_trees.blackboard.Blackboard.storage


def write(path: str, value: Any) -> None:
    """Write an entry (creating it) and count the write."""
    py_trees.blackboard.Blackboard.set(path, value)
    _versions[path] = _versions.get(path, 0) + 1


def unset(path: str) -> None:
    py_trees.blackboard.Blackboard.unset(path)
    _versions[path] = _versions.get(path, 0) + 1


def version(path: str) -> tuple[int, int] | None:
    """Changes whenever the entry is written (None while it does not exist). Writes through this module are
    counted; a write through a py_trees client is seen when it stores another object."""
    storage = py_trees.blackboard.Blackboard.storage
    if path not in storage:
        return None
    return _versions.get(path, 0), id(storage[path])


def clear_tree_entries() -> None:
    """Forget every BT.CPP entry of earlier trees (``/tree/…``): a tree starts with empty blackboards, as in
    BT.CPP. The mission keys are the world's and stay."""
    storage = py_trees.blackboard.Blackboard.storage
    for path in [p for p in storage if p == NAMESPACE or p.startswith(NAMESPACE + "/")]:
        del storage[path]
        _versions.pop(path, None)


@dataclass(eq=False)
class ScriptEnv:
    """Where a node's scripts find their names: its blackboard scope, the entries its tree declared, enums.

    ``declared`` holds the entries the tree file's ports mention: BT.CPP creates them (empty) when the tree
    is built, so ``x = 1`` may assign one that was never written, and reading one is "never written"."""

    scope: Scope
    enums: Mapping[str, int]
    declared: set[str]

    def lookup(self, name: str) -> Any:
        path = self.scope.entry_path(name)
        try:
            return read(path)
        except KeyError:
            if path in self.declared:
                return EMPTY
            raise

    def assign(self, name: str, value: Any, create: bool) -> None:
        path = self.scope.entry_path(name)
        if not create and not exists(path) and path not in self.declared:
            raise KeyError(name)
        write(path, value)
