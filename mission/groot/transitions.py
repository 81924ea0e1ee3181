"""py_trees ticks as BehaviorTree.CPP status transitions, per node UID — what Groot2 shows and replays.

BT.CPP reports every status change of every node as it happens (``prev → new``); py_trees has no such
callback and a slightly different bookkeeping, so a :class:`TransitionRecorder` (a py_trees visitor)
reports what BT.CPP would have reported for the same tick:

* a node reached by the tick makes every node above it RUNNING first, outermost first (BT.CPP's control
  nodes are RUNNING while they tick a child; py_trees reports a parent only after its children);
* the node's own status, when it changed;
* a node that finishes (SUCCESS or FAILURE) first resets its finished or running descendants to IDLE,
  deepest first, as BT.CPP's controls and decorators reset their children when they complete (py_trees
  leaves them at their last status until the parent starts again);
* after the tick, a node py_trees halted (INVALID) goes to IDLE.

On the same tree the sequence of transitions equals BT.CPP 4.10's except the root's own reset after a
completed ``tickOnce`` (measured against a FileLogger2 log; README "Groot2"). Statuses are BT.CPP's
numbers (mission.groot.protocol). It observes and never changes the tree.
"""

from __future__ import annotations

import threading
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import py_trees
from py_trees.behaviour import Behaviour
from py_trees.common import Status

from mission.groot.protocol import FAILURE, IDLE, RUNNING, SUCCESS
from mission.groot.uids import UidTree

BT_STATUS: dict[Status, int] = {Status.INVALID: IDLE, Status.RUNNING: RUNNING, Status.SUCCESS: SUCCESS,
                                Status.FAILURE: FAILURE}  # fmt: skip
_FINISHED = (SUCCESS, FAILURE)


@dataclass(frozen=True)
class Transition:
    uid: int
    previous: int
    status: int


class TransitionRecorder(py_trees.visitors.VisitorBase):
    """Add to a tree with ``tree.add_visitor``; :meth:`drain` after each tick returns what changed, in order.

    `uids` maps UID → behaviour (mission.groot.uids.bind): a SubTree's UID and its subtree root's share one
    behaviour. `children` maps UID → the UIDs of its children as BT.CPP builds the tree (a SubTree's only
    child is its subtree's root); :meth:`for_tree` takes both from a numbered tree.
    """

    def __init__(self, uids: Mapping[int, Behaviour], children: Mapping[int, Sequence[int]]) -> None:
        super().__init__(full=False)
        self._uids_of: dict[object, list[int]] = {}
        for uid, behaviour in sorted(uids.items(), reverse=True):  # inner first: a subtree root before its SubTree
            self._uids_of.setdefault(behaviour.id, []).append(uid)
        self._behaviours = dict(sorted(uids.items()))
        self._children = {uid: [c for c in children.get(uid, ()) if c in uids] for uid in uids}
        self.status: dict[int, int] = dict.fromkeys(uids, IDLE)  # as BT.CPP would show each node now
        self._pending: list[Transition] = []
        self._lock = threading.Lock()

    @classmethod
    def for_tree(cls, tree: UidTree, uids: Mapping[int, Behaviour]) -> TransitionRecorder:
        """A recorder for a numbered tree file bound to its py_trees tree."""
        return cls(uids, {uid: [c.uid for c in node.children] for uid, node in tree.by_uid.items()})

    def _emit(self, uid: int, status: int) -> None:
        self._pending.append(Transition(uid, self.status[uid], status))
        self.status[uid] = status

    def _reset_below(self, uid: int) -> None:
        for child in self._children[uid]:
            self._reset_below(child)
            if self.status[child] != IDLE:
                self._emit(child, IDLE)

    def _set(self, uid: int, status: int) -> None:
        if status == self.status[uid]:
            return
        if status in _FINISHED:
            self._reset_below(uid)
        self._emit(uid, status)

    def run(self, behaviour: Behaviour) -> None:
        uids = self._uids_of.get(behaviour.id)
        if not uids:
            return
        status = BT_STATUS.get(behaviour.status, IDLE)
        with self._lock:
            self._open_ancestors(behaviour)
            for uid in uids:
                self._set(uid, status)

    def _open_ancestors(self, behaviour: Behaviour) -> None:
        chain = []
        parent = behaviour.parent
        while parent is not None:
            chain.append(parent)
            parent = parent.parent
        for ancestor in reversed(chain):
            for uid in reversed(self._uids_of.get(ancestor.id, ())):
                if self.status[uid] != RUNNING:
                    self._set(uid, RUNNING)

    def finalise(self) -> None:
        """After the tick: nodes py_trees halted go to IDLE."""
        with self._lock:
            for uid, behaviour in self._behaviours.items():
                if behaviour.status == Status.INVALID and self.status[uid] != IDLE:
                    self._emit(uid, IDLE)

    def drain(self) -> list[Transition]:
        """The transitions since the last drain, in the order they happened."""
        with self._lock:
            out, self._pending = self._pending, []
        return out
