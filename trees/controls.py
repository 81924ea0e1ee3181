"""BehaviorTree.CPP 4's control nodes, tick for tick (src/controls/*.cpp of BT.CPP 4.10).

Each is a py_trees composite (the matching py_trees class where there is one, so viewers draw a sequence
as a sequence) whose tick is BT.CPP's, written on trees/execution.py's protocol: children are ticked with
``self.run(child)``, a finished child is reset to IDLE the way BT.CPP resets it, halts go to
RUNNING children only, in child order. The golden traces (tests/trees/golden/btcpp/) replay every one of them
against the real BT.CPP.

Where BT.CPP differs from py_trees' namesakes: ``Parallel`` returns as soon as ``success_count`` or
``failure_count`` is reached and halts the children still running; a Sequence or Fallback child that is
SKIPPED is stepped over, and a control whose children were all skipped is itself SKIPPED.
"""

from __future__ import annotations

import re

import py_trees
from py_trees.behaviour import Behaviour
from py_trees.common import Status

from mission.trees.execution import (
    FAILURE,
    IDLE,
    RUNNING,
    SKIPPED,
    SUCCESS,
    BuiltinNode,
    PortError,
    Result,
    bt_status,
    halt_child,
    runtime,
)


def _active(status: Status) -> bool:
    """BT.CPP's isStatusActive: RUNNING, SUCCESS or FAILURE (not IDLE, not SKIPPED)."""
    return status is not IDLE


class _Control(BuiltinNode):
    def reset_children(self) -> None:
        """ControlNode::resetChildren: halt the RUNNING ones, every child back to IDLE."""
        for child in self.children:
            halt_child(child)

    def halt_children_from(self, first: int) -> None:
        for child in self.children[first:]:
            halt_child(child)

    def wake_up(self) -> None:
        runtime(self).tree.wake_up()  # type: ignore[arg-type]


class _Ordered(_Control):
    """BT.CPP's SequenceNode and FallbackNode, which differ only in the result that ends them early
    (`ENDS_ON`: FAILURE for a Sequence, SUCCESS for a Fallback) and the one they return when every child
    had the other (`ALL_DONE`)."""

    ENDS_ON: Result
    ALL_DONE: Result

    def __init__(self, name: str, children: list[Behaviour], asynch: bool = False) -> None:
        super().__init__(name, memory=True, children=children)  # type: ignore[call-arg]  # the py_trees composite
        self.asynch = asynch
        self.index = 0
        self.skipped = 0

    def bt_halt(self) -> None:
        self.index, self.skipped = 0, 0
        super().bt_halt()

    def bt_tick(self) -> Result:
        n = len(self.children)
        if not _active(self.bt_own_status):
            self.skipped = 0
        self.set_running()
        while self.index < n:
            child = self.children[self.index]
            before = bt_status(child)
            result = self.run(child)
            if result is RUNNING:
                return RUNNING
            if result is self.ENDS_ON:
                self.end_early()
                return result
            self.index += 1
            if result is SKIPPED:
                self.skipped += 1
            elif self.asynch and before is IDLE and self.index < n:
                self.wake_up()
                return RUNNING
        all_skipped = self.skipped == n
        if self.index == n:
            self.reset_children()
            self.index, self.skipped = 0, 0
        return SKIPPED if all_skipped else self.ALL_DONE

    def end_early(self) -> None:
        """The child at `index` ended the node: every child is reset and the next start is from the first."""
        self.reset_children()
        self.index = 0


class Sequence(_Ordered, py_trees.composites.Sequence):
    """BT.CPP ``Sequence`` (``AsyncSequence`` with `asynch`): a RUNNING child is resumed on the next tick;
    a failure resets every child and starts again from the first next time."""

    ENDS_ON, ALL_DONE = FAILURE, SUCCESS


class SequenceWithMemory(_Ordered, py_trees.composites.Sequence):
    """BT.CPP ``SequenceWithMemory``: a failed child is ticked again next time (earlier ones are not), and
    a child that succeeds at once hands control back (the tree is woken up and ticked again)."""

    ENDS_ON, ALL_DONE = FAILURE, SUCCESS

    def __init__(self, name: str, children: list[Behaviour]) -> None:
        super().__init__(name, children, asynch=True)

    def bt_halt(self) -> None:  # BT.CPP's halt keeps the index: a halted sequence resumes where it was
        _Control.bt_halt(self)

    def end_early(self) -> None:
        self.halt_children_from(self.index)


class Fallback(_Ordered, py_trees.composites.Selector):
    """BT.CPP ``Fallback`` (``AsyncFallback`` with `asynch`): children in order until one succeeds; a
    RUNNING child is resumed on the next tick."""

    ENDS_ON, ALL_DONE = SUCCESS, FAILURE


class _Reactive(_Control):
    """ReactiveSequence / ReactiveFallback: every child from the first, every tick."""

    stop_on: Status  # the child status that ends the tick (FAILURE for a sequence, SUCCESS for a fallback)
    otherwise: Status

    def bt_tick(self) -> Result:
        all_skipped = True
        self.set_running()
        for index, child in enumerate(self.children):
            result = self.run(child)
            all_skipped = all_skipped and result is SKIPPED
            if result is RUNNING:
                for i, other in enumerate(self.children):
                    if i != index:
                        halt_child(other)
                return RUNNING
            if result is self.stop_on:
                self.reset_children()
                return result
            if result is SKIPPED:
                halt_child(child)
        self.reset_children()
        return SKIPPED if all_skipped else self.otherwise


class ReactiveSequence(_Reactive, py_trees.composites.Sequence):
    """BT.CPP ``ReactiveSequence``: conditions re-checked every tick; a child that starts RUNNING halts the others."""

    stop_on, otherwise = FAILURE, SUCCESS

    def __init__(self, name: str, children: list[Behaviour]) -> None:
        super().__init__(name, memory=False, children=children)


class ReactiveFallback(_Reactive, py_trees.composites.Selector):
    """BT.CPP ``ReactiveFallback``: higher-priority children re-checked every tick and preempt lower ones."""

    stop_on, otherwise = SUCCESS, FAILURE

    def __init__(self, name: str, children: list[Behaviour]) -> None:
        super().__init__(name, memory=False, children=children)


def threshold(count: int, n_children: int) -> int:
    """BT.CPP's rule: a negative count means ``n_children + 1 + count`` (-1 = all children)."""
    return max(n_children + count + 1, 0) if count < 0 else count


class Parallel(_Control, py_trees.composites.Parallel):
    """BT.CPP ``Parallel``: ticks the unfinished children in order and returns as soon as `success_count`
    succeeded or `failure_count` failed (or success became impossible), halting the children still running.
    Finished children are not ticked again until the parallel itself finishes."""

    def __init__(self, name: str, children: list[Behaviour]) -> None:
        policy = py_trees.common.ParallelPolicy.SuccessOnAll(synchronise=False)  # unused: the tick is BT.CPP's
        super().__init__(name, policy=policy, children=children)
        self.done: set[int] = set()
        self.successes = 0
        self.failures = 0

    def clear(self) -> None:
        self.done.clear()
        self.successes, self.failures = 0, 0

    def bt_halt(self) -> None:
        self.clear()
        super().bt_halt()

    def bt_tick(self) -> Result:
        success_count = self.input("success_count", -1)
        failure_count = self.input("failure_count", 1)
        n = len(self.children)
        need_success, need_failure = threshold(success_count, n), threshold(failure_count, n)
        self.set_running()
        skipped = 0
        for i, child in enumerate(self.children):
            if i not in self.done:
                result = self.run(child)
                if result is SKIPPED:
                    skipped += 1
                elif result is SUCCESS:
                    self.done.add(i)
                    self.successes += 1
                elif result is FAILURE:
                    self.done.add(i)
                    self.failures += 1
            self.feedback_message = f"{self.successes}/{need_success} succeeded, {self.failures}/{need_failure} failed"
            if self.successes >= need_success or (success_count < 0 and self.successes + skipped >= need_success):
                self.clear()
                self.reset_children()
                return SUCCESS
            if n - self.failures < need_success or self.failures == need_failure:
                self.clear()
                self.reset_children()
                return FAILURE
        return SKIPPED if skipped == n else RUNNING


class ParallelAll(_Control, py_trees.composites.Parallel):
    """BT.CPP ``ParallelAll``: every child runs to the end; FAILURE if at least `max_failures` failed."""

    def __init__(self, name: str, children: list[Behaviour]) -> None:
        policy = py_trees.common.ParallelPolicy.SuccessOnAll(synchronise=False)
        super().__init__(name, policy=policy, children=children)
        self.done: set[int] = set()
        self.failures = 0

    def bt_halt(self) -> None:
        self.done.clear()
        self.failures = 0
        super().bt_halt()

    def bt_tick(self) -> Result:
        n = len(self.children)
        need_failure = threshold(self.input("max_failures", 1), n)
        skipped = 0
        self.set_running()
        for i, child in enumerate(self.children):
            if i in self.done:
                continue
            result = self.run(child)
            if result is SUCCESS:
                self.done.add(i)
            elif result is FAILURE:
                self.done.add(i)
                self.failures += 1
            elif result is SKIPPED:
                skipped += 1
        if skipped == n:
            return SKIPPED
        if skipped + len(self.done) >= n:
            self.reset_children()
            self.done.clear()
            status = FAILURE if self.failures >= need_failure else SUCCESS
            self.failures = 0
            return status
        return RUNNING


class IfThenElse(_Control, py_trees.composites.Composite):
    """BT.CPP ``IfThenElse``: the first child decides; the second runs on SUCCESS, the third (or FAILURE) on
    FAILURE. The condition is not re-checked while the chosen branch runs."""

    def __init__(self, name: str, children: list[Behaviour]) -> None:
        super().__init__(name, children=children)
        self.branch = 0

    def bt_halt(self) -> None:
        self.branch = 0
        super().bt_halt()

    def bt_tick(self) -> Result:
        self.set_running()
        if self.branch == 0:
            condition = self.run(self.children[0])
            if condition is RUNNING:
                return RUNNING
            if condition is SUCCESS:
                self.branch = 1
            elif condition is FAILURE:
                if len(self.children) != 3:
                    return FAILURE
                self.branch = 2
            else:
                return condition  # a SKIPPED condition: BT.CPP throws here; the control is skipped instead
        result = self.run(self.children[self.branch])
        if result is RUNNING:
            return RUNNING
        self.reset_children()
        self.branch = 0
        return result


class WhileDoElse(_Control, py_trees.composites.Composite):
    """BT.CPP ``WhileDoElse``: the condition is re-checked every tick; a change of answer halts the other branch."""

    def bt_tick(self) -> Result:
        self.set_running()
        condition = self.run(self.children[0])
        if condition is RUNNING:
            return RUNNING
        result: Result = IDLE
        if condition is SUCCESS:
            if len(self.children) == 3:
                halt_child(self.children[2])
            result = self.run(self.children[1])
        elif condition is FAILURE:
            if len(self.children) == 3:
                halt_child(self.children[1])
                result = self.run(self.children[2])
            else:
                result = FAILURE
        else:
            return condition
        if result is RUNNING:
            return RUNNING
        self.reset_children()
        return result


class TryCatch(_Control, py_trees.composites.Composite):
    """BT.CPP ``TryCatch``: the children but the last in sequence; if one fails, the last (catch) child runs
    and the node fails when it finishes. With catch_on_halt the catch child also runs when the node is halted."""

    def __init__(self, name: str, children: list[Behaviour]) -> None:
        super().__init__(name, children=children)
        self.index = 0
        self.skipped = 0
        self.in_catch = False

    def bt_halt(self) -> None:
        catch_on_halt = bool(self.input("catch_on_halt", False))
        if catch_on_halt and not self.in_catch and _active(self.bt_own_status) and len(self.children) >= 2:
            for child in self.children[:-1]:
                halt_child(child)
            self.run(self.children[-1])  # BT.CPP ticks the catch child once, inside halt()
            if bt_status(self.children[-1]) is RUNNING:
                halt_child(self.children[-1])
        self.index, self.skipped, self.in_catch = 0, 0, False
        super().bt_halt()

    def bt_tick(self) -> Result:
        n = len(self.children)
        if not _active(self.bt_own_status):
            self.skipped = 0
            self.in_catch = False
        self.set_running()
        while True:
            if self.in_catch:
                result = self.run(self.children[-1])
                if result is RUNNING:
                    return RUNNING
                self.reset_children()
                self.index, self.in_catch = 0, False
                return FAILURE
            tries = n - 1
            while self.index < tries:
                result = self.run(self.children[self.index])
                if result is RUNNING:
                    return RUNNING
                if result is FAILURE:
                    self.reset_children()
                    self.index, self.in_catch = 0, True
                    break
                self.index += 1
                if result is SKIPPED:
                    self.skipped += 1
            else:
                all_skipped = self.skipped == tries
                self.reset_children()
                self.index, self.skipped = 0, 0
                return SKIPPED if all_skipped else SUCCESS


_INT = re.compile(r"-?[0-9]+")
_REAL = re.compile(r"-?([0-9]+\.?[0-9]*|\.[0-9]+)([eE][+-]?[0-9]+)?|-?(inf|infinity|nan)", re.IGNORECASE)
#: BT.CPP compares real cases within float's epsilon
_CASE_EPSILON = 1.1920928955078125e-07


def same_case(variable: str, case: str, enums: dict[str, int]) -> bool:
    """BT.CPP's Switch comparison (CheckStringEquality): equal strings, else equal integers, else reals within
    float's epsilon, an enum name counting as its value. A number must be the whole text, as std::from_chars
    reads it: ``"5"`` matches ``"5.0"``, ``"5 "`` does not match ``"5"``."""
    if variable == case:
        return True

    def number(text: str, pattern: re.Pattern[str], kind: type) -> float | None:
        if text in enums:
            return enums[text]
        return kind(text) if pattern.fullmatch(text) else None

    a, b = number(variable, _INT, int), number(case, _INT, int)
    if a is not None and a == b:
        return True
    x, y = number(variable, _REAL, float), number(case, _REAL, float)
    return x is not None and y is not None and abs(x - y) <= _CASE_EPSILON


class Switch(_Control, py_trees.composites.Composite):
    """BT.CPP ``Switch2`` … ``Switch6``: the child whose ``case_N`` equals `variable` runs, else the last one;
    a change of case halts the child that was running."""

    def __init__(self, name: str, children: list[Behaviour], cases: int, enums: dict[str, int]) -> None:
        super().__init__(name, children=children)
        self.cases = cases
        self.enums = enums
        self.running = -1

    def bt_halt(self) -> None:
        self.running = -1
        super().bt_halt()

    def bt_tick(self) -> Result:
        match = self.cases
        try:
            variable: str | None = str(self.input("variable"))
        except PortError:  # BT.CPP: no variable → the default child
            variable = None
        if variable is not None:
            for index in range(self.cases):
                try:
                    case = self.input(f"case_{index + 1}")
                except PortError:  # an unset case matches nothing
                    continue
                if same_case(variable, str(case), self.enums):
                    match = index
                    break
        if self.running != -1 and self.running != match:
            halt_child(self.children[self.running])
        result = self.run(self.children[match])
        if result is SKIPPED:
            self.running = -1
            return SKIPPED
        if result is RUNNING:
            self.running = match
        else:
            self.reset_children()
            self.running = -1
        return result
