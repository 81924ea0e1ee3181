"""BehaviorTree.CPP 4's built-in leaves: AlwaysSuccess/Failure, Script, ScriptCondition, SetBlackboard,
UnsetBlackboard, Sleep and WasEntryUpdated (src/actions/*, include/behaviortree_cpp/actions/* of BT.CPP 4.10).

Scripts are parsed when the tree is loaded (a syntax error is a load error at file:line:column) and run
in the node's blackboard scope. ``Sleep`` counts `msec` on the blackboard CLOCK, as the time-based
decorators do (trees/decorators.py).
"""

from __future__ import annotations

from typing import Any

import py_trees

from mission.behaviours.ports import Port, is_pointer
from mission.trees import scopes
from mission.trees.decorators import EPSILON_MS, Clock
from mission.trees.execution import FAILURE, IDLE, RUNNING, SUCCESS, BuiltinNode, PortError, Result, runtime
from mission.trees.script import Script, ScriptError, to_bool


class _Leaf(BuiltinNode, py_trees.behaviour.Behaviour):
    def __init__(self, name: str) -> None:
        super().__init__(name)

    def bt_halt(self) -> None:
        self.status = py_trees.common.Status.INVALID


class AlwaysSuccess(_Leaf):
    """Returns SUCCESS."""

    def bt_tick(self) -> Result:
        self.feedback_message = "SUCCESS"
        return SUCCESS


class AlwaysFailure(_Leaf):
    """Returns FAILURE."""

    def bt_tick(self) -> Result:
        self.feedback_message = "FAILURE"
        return FAILURE


class _Scripted(_Leaf):
    def __init__(self, name: str, script: Script) -> None:
        super().__init__(name)
        self.script = script

    def evaluate(self) -> Any:
        try:
            return self.script.run(runtime(self).own.conditions.env)
        except ScriptError as err:
            raise PortError(f"script {self.script.source!r}: {err}") from None


class ScriptNode(_Scripted):
    """BT.CPP ``Script``: runs `code` (assignments, usually) and returns SUCCESS."""

    def bt_tick(self) -> Result:
        value = self.evaluate()
        self.feedback_message = f"{self.script.source} → {value!r}"
        return SUCCESS


class ScriptCondition(_Scripted):
    """BT.CPP ``ScriptCondition``: SUCCESS when `code` is true, else FAILURE."""

    def bt_tick(self) -> Result:
        try:
            holds = to_bool(self.evaluate())
        except ScriptError as err:
            raise PortError(f"script {self.script.source!r}: {err}") from None
        self.feedback_message = f"{self.script.source} is {'true' if holds else 'false'}"
        return SUCCESS if holds else FAILURE


def _simple(value: Any) -> type | None:
    for kind in (bool, int, float, str):
        if isinstance(value, kind):
            return kind
    return None


class SetBlackboard(_Leaf):
    """BT.CPP ``SetBlackboard``: writes `value` (text, or another entry's value when written ``{key}``) into the
    entry named by `output_key`; text written over a number becomes a number."""

    def bt_tick(self) -> Result:
        rt = runtime(self)
        scope = rt.own.conditions.env.scope
        target_key = str(self.input("output_key"))
        target = scope.entry_path(target_key)
        written = rt.ports.written.get("value", "")
        if is_pointer(written):
            source = scope.entry_path(written.strip()[1:-1])
            try:
                value = scopes.read(source)
            except KeyError:
                raise PortError(f"port value: blackboard entry {written.strip()} was never written") from None
        else:
            value = written
            try:
                previous = scopes.read(target)
            except KeyError:
                previous = None
            kind = _simple(previous)
            if kind is not None and kind is not str and isinstance(value, str):
                try:
                    value = Port(kind).parse(value)
                except ValueError as err:
                    raise PortError(f"cannot write {value!r} into {target_key}, which holds {err}") from None
        scopes.write(target, value)
        self.feedback_message = f"{target_key} ← {value!r}"
        return SUCCESS


class UnsetBlackboard(_Leaf):
    """BT.CPP ``UnsetBlackboard``: removes the entry named by `key` from this blackboard (a remapped key, the
    parent's entry, is left alone, as in BT.CPP)."""

    def bt_tick(self) -> Result:
        env = runtime(self).own.conditions.env
        key = str(self.input("key"))
        path = env.scope.entry_path(key)
        if env.scope.is_local(key):
            scopes.unset(path)
            env.declared.discard(path)
        self.feedback_message = f"unset {key}"
        return SUCCESS


class Sleep(_Leaf):
    """BT.CPP ``Sleep``: RUNNING for `msec` on the blackboard CLOCK, then SUCCESS."""

    def __init__(self, name: str) -> None:
        super().__init__(name)
        self.clock = Clock()
        self.until: float | None = None

    def bt_halt(self) -> None:
        self.until = None
        super().bt_halt()

    def bt_tick(self) -> Result:
        own = self.bt_own_status
        if own is IDLE:  # StatefulActionNode: onStart
            msec = int(self.input("msec"))
            if msec <= 0:
                self.feedback_message = "slept 0 s"
                return SUCCESS
            self.until = self.clock.start() + msec / 1000.0
            return RUNNING
        if own is RUNNING:  # onRunning
            assert self.until is not None
            left = self.until - self.clock.now()
            if left * 1000.0 > EPSILON_MS:
                self.feedback_message = f"sleeping, {left:.1f} s left"
                return RUNNING
            self.until = None
            self.feedback_message = "slept"
            return SUCCESS
        return own  # finished and not reset: BT.CPP's StatefulActionNode returns the same status


class WasEntryUpdated(_Leaf):
    """BT.CPP ``WasEntryUpdated``: SUCCESS when the entry named by `entry` was written since this node last looked."""

    def __init__(self, name: str, path: str) -> None:
        super().__init__(name)
        self.path = path
        self.seen: Any = None

    def bt_tick(self) -> Result:
        current = scopes.version(self.path)
        if current is None:
            self.feedback_message = "no such entry"
            return FAILURE
        previous, self.seen = self.seen, current
        updated = previous != current
        self.feedback_message = "updated" if updated else "not updated"
        return SUCCESS if updated else FAILURE
