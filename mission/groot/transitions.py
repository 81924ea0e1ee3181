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
* a child of a ``ReactiveSequence`` / ``ReactiveFallback`` that is RUNNING resets the children before it,
  as those controls do on every tick (so a condition checked on every tick shows as checked every tick);
* a finished node ticked again goes to IDLE first (BT.CPP's parents reset a child before re-running it);
* after the tick, a RUNNING node py_trees halted (INVALID) goes to IDLE with everything below it, and a
  root that finished goes to IDLE, as BT.CPP's ``tickOnce`` leaves it.

For trees of Sequence, Fallback, their reactive forms, Parallel, SubTrees, decorators and scripted leaves,
the transitions equal those BT.CPP 4.10's FileLogger2 writes for the same file, in the same order
(tests/groot/test_btlog.py). Statuses are BT.CPP's
numbers (mission.groot.protocol). It observes and never changes the tree.
"""

from __future__ import annotations

import logging
import threading
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import py_trees
from py_trees.behaviour import Behaviour
from py_trees.common import Status

from mission.groot.protocol import FAILURE, IDLE, RUNNING, SUCCESS
from mission.groot.uids import BindError, UidTree, bind, uid_tree

if TYPE_CHECKING:
    from mission.core.observers import Run

log = logging.getLogger(__name__)

BT_STATUS: dict[Status, int] = {
    Status.INVALID: IDLE,
    Status.RUNNING: RUNNING,
    Status.SUCCESS: SUCCESS,
    Status.FAILURE: FAILURE,
}
_FINISHED = (SUCCESS, FAILURE)
#: BT.CPP controls that reset the children before a RUNNING child on every tick
RESET_BEFORE_RUNNING = frozenset({"ReactiveSequence", "ReactiveFallback"})


@dataclass(frozen=True)
class Transition:
    uid: int
    previous: int
    status: int


class TransitionRecorder(py_trees.visitors.VisitorBase):
    """Add to a tree with ``tree.add_visitor``; :meth:`drain` after each tick returns what changed, in order.

    `uids` maps UID → behaviour (mission.groot.uids.bind): a SubTree's UID and its subtree root's share one
    behaviour. `children` maps UID → the UIDs of its children as BT.CPP builds the tree (a SubTree's only
    child is its subtree's root); `reactive` are the UIDs of controls in RESET_BEFORE_RUNNING.
    :meth:`for_tree` takes them from a numbered tree.
    """

    def __init__(
        self,
        uids: Mapping[int, Behaviour],
        children: Mapping[int, Sequence[int]],
        reactive: frozenset[int] = frozenset(),
    ) -> None:
        super().__init__(full=False)
        self._uids_of: dict[object, list[int]] = {}
        for uid, behaviour in sorted(uids.items(), reverse=True):  # inner first: a subtree root before its SubTree
            self._uids_of.setdefault(behaviour.id, []).append(uid)
        self._behaviours = dict(sorted(uids.items()))
        self._children = {uid: [c for c in children.get(uid, ()) if c in uids] for uid in uids}
        self._parent = {c: uid for uid, kids in self._children.items() for c in kids}
        self._reactive = reactive
        self.status: dict[int, int] = dict.fromkeys(uids, IDLE)  # as BT.CPP would show each node now
        self._pending: list[Transition] = []
        self._lock = threading.Lock()

    @classmethod
    def for_tree(cls, tree: UidTree, uids: Mapping[int, Behaviour]) -> TransitionRecorder:
        """A recorder for a numbered tree file bound to its py_trees tree."""
        children = {uid: [c.uid for c in node.children] for uid, node in tree.by_uid.items()}
        reactive = frozenset(uid for uid, node in tree.by_uid.items() if node.node_type in RESET_BEFORE_RUNNING)
        return cls(uids, children, reactive)

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

    def _reset_before(self, uid: int) -> None:
        """`uid` is RUNNING under a reactive control: the control resets the children before it."""
        parent = self._parent.get(uid)
        if parent not in self._reactive:
            return
        for sibling in self._children[parent]:
            if sibling == uid:
                return
            self._reset_below(sibling)
            if self.status[sibling] != IDLE:
                self._emit(sibling, IDLE)

    def _restart(self, uid: int) -> None:
        """A finished node is ticked again: in BT.CPP something reset it (and what is below it) first."""
        if self.status[uid] in _FINISHED:
            self._reset_below(uid)
            self._emit(uid, IDLE)

    def run(self, behaviour: Behaviour) -> None:
        uids = self._uids_of.get(behaviour.id)
        if not uids:
            return
        status = BT_STATUS.get(behaviour.status, IDLE)
        with self._lock:
            self._open_ancestors(behaviour)
            for uid in uids:
                self._restart(uid)
                self._set(uid, status)
                if status == RUNNING:
                    self._reset_before(uid)

    def _open_ancestors(self, behaviour: Behaviour) -> None:
        chain = []
        parent = behaviour.parent
        while parent is not None:
            chain.append(parent)
            parent = parent.parent
        for ancestor in reversed(chain):
            for uid in reversed(self._uids_of.get(ancestor.id, ())):
                if self.status[uid] != RUNNING:
                    self._restart(uid)
                    self._set(uid, RUNNING)

    def finalise(self) -> None:
        """After the tick: running nodes py_trees halted go to IDLE, with everything below them (BT.CPP's
        halt). A finished node py_trees invalidated keeps its status until a BT.CPP rule resets it."""
        with self._lock:
            for uid, behaviour in self._behaviours.items():
                if behaviour.status == Status.INVALID and self.status[uid] == RUNNING:
                    self._reset_below(uid)
                    self._emit(uid, IDLE)
            root = min(self._behaviours, default=None)
            if root is not None and self.status[root] in _FINISHED:  # BT.CPP resets a root its tick finished
                self._emit(root, IDLE)

    def drain(self) -> list[Transition]:
        """The transitions since the last drain, in the order they happened."""
        with self._lock:
            out, self._pending = self._pending, []
        return out


def watch_run(run: Run, who: str) -> tuple[UidTree, TransitionRecorder] | None:
    """The numbered tree file of `run` and a recorder of its transitions, attached to the tree: what the
    Groot2 monitor and the .btlog writer (`who`, for their warnings) both start from. None for a run without
    a tree. A built tree that differs from its file gets a recorder with no bound nodes: watching must never
    stop a mission, so the tree is still shown and its statuses stay IDLE."""
    if run.tree is None or run.tree_path is None:
        log.warning("%s: this run has no tree (perception only); nothing to show", who)
        return None
    tree = uid_tree(run.tree_path)
    try:
        uids = bind(tree, run.root)
    except BindError as err:
        log.warning("%s: statuses unavailable, the built tree differs from its file: %s", who, err)
        uids = {}
    recorder = TransitionRecorder.for_tree(tree, uids)
    run.tree.add_visitor(recorder)
    return tree, recorder
