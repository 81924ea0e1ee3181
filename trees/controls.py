"""BehaviorTree.CPP v4 built-in nodes, mapped to py_trees.

Each built-in is a :class:`~mission.trees.manifest.NodeManifest`: its XML tag, Groot2 kind, ports (the
same :class:`mission.behaviours.ports.Port` as leaves, so the loader checks them the same way) and a
``build`` function; every :class:`~mission.trees.factory.BehaviourFactory` starts with them, as
BT.CPP's factory does. Mapping (and where it differs from BT.CPP):

=======================  ==========================================================================
XML                      py_trees
=======================  ==========================================================================
Sequence                 ``Sequence(memory=True)``: a RUNNING child is resumed on the next tick
ReactiveSequence         ``Sequence(memory=False)``: every tick restarts from the first child
Fallback                 ``Selector(memory=True)``
ReactiveFallback         ``Selector(memory=False)``
Parallel                 :class:`BtParallel` (a ``py_trees.composites.Parallel`` with BT.CPP's
                         ``success_count`` / ``failure_count`` thresholds; negative = N + 1 + value)
Inverter                 ``decorators.Inverter``
ForceSuccess             ``decorators.FailureIsSuccess`` (RUNNING stays RUNNING)
ForceFailure             ``decorators.SuccessIsFailure``
RetryUntilSuccessful     :class:`RetryUntilSuccessful` (``decorators.Retry``; -1 = forever). A failed
                         attempt is retried on the NEXT tick (BT.CPP retries within the same tick).
Repeat                   ``decorators.Repeat(num_success=num_cycles)``; one cycle per tick; -1 = forever
Timeout                  :class:`ClockTimeout`: ``msec`` measured on the blackboard CLOCK (sim or ROS
                         time), so a faster-than-real-time simulation times out in sim seconds
AlwaysSuccess / Failure  ``behaviours.Success`` / ``behaviours.Failure``
=======================  ==========================================================================

``SubTree`` is not here: the loader flattens it (see trees/loader.py).
"""

from __future__ import annotations

import time
from typing import Any

import py_trees
from py_trees.behaviour import Behaviour
from py_trees.common import Status

from mission.behaviours.ports import REQUIRED, Port
from mission.core import blackboard as bbk
from mission.trees.manifest import Check, NodeManifest


class BtParallel(py_trees.composites.Parallel):
    """BehaviorTree.CPP v4 ``Parallel``: SUCCESS once `success_count` children succeeded, FAILURE once
    `failure_count` failed (or success became impossible). Children that finished are not ticked
    again until the parallel itself finishes; running children are halted when it does.

    py_trees' own policies only cover "all succeed" / "one succeeds" with "any failure fails", so this
    keeps py_trees' Parallel type (viewers draw it as a parallel) and replaces the status rule.
    """

    def __init__(
        self, name: str, children: list[Behaviour], success_count: int, failure_count: int
    ) -> None:
        super().__init__(name, policy=py_trees.common.ParallelPolicy.SuccessOnAll(synchronise=False), children=children)
        self.success_count = success_count
        self.failure_count = failure_count

    def tick(self):  # type: ignore[no-untyped-def]  # same generator signature as Parallel.tick
        if self.status != Status.RUNNING:
            for child in self.children:
                if child.status != Status.INVALID:
                    child.stop(Status.INVALID)
            self.current_child = None
            self.initialise()
        for child in self.children:
            if child.status in (Status.SUCCESS, Status.FAILURE):
                continue
            yield from child.tick()
        successes = sum(c.status == Status.SUCCESS for c in self.children)
        failures = sum(c.status == Status.FAILURE for c in self.children)
        if successes >= self.success_count:
            new_status = Status.SUCCESS
        elif failures >= self.failure_count or len(self.children) - failures < self.success_count:
            new_status = Status.FAILURE
        else:
            new_status = Status.RUNNING
        self.feedback_message = (
            f"{successes}/{self.success_count} succeeded, {failures}/{self.failure_count} failed"
        )
        self.current_child = self.children[-1] if self.children else None
        if new_status != Status.RUNNING:
            self.stop(new_status)
        self.status = new_status
        yield self


class RetryUntilSuccessful(py_trees.decorators.Retry):
    """BT.CPP ``RetryUntilSuccessful``: a failed child is retried up to `num_attempts` times in all
    (``-1`` = forever). The retry starts on the next tick so one tick never loops."""

    def update(self) -> Status:
        if self.num_failures < 0 and self.decorated.status == Status.FAILURE:
            self.failures += 1
            self.feedback_message = f"attempt {self.failures} failed, retrying (no limit)"
            return Status.RUNNING
        return super().update()


class ClockTimeout(py_trees.decorators.Decorator):
    """BT.CPP ``Timeout``: FAILURE (and the child halted) when the child is still RUNNING after
    `duration_s` on the blackboard CLOCK. Without a CLOCK (a bare tree in a test or a script) the
    timer falls back to ``time.monotonic()`` for that run."""

    def __init__(self, name: str, child: Behaviour, duration_s: float) -> None:
        super().__init__(name=name, child=child)
        self.duration_s = duration_s
        self._bb = py_trees.blackboard.Client(name=name)
        bbk.register(self._bb, read=(bbk.CLOCK,))
        self._use_clock = False
        self._start = 0.0

    def _now(self) -> float:
        if self._use_clock:
            return float(bbk.get(self._bb, bbk.CLOCK, self._start))  # type: ignore[arg-type]
        return time.monotonic()

    def initialise(self) -> None:
        clock = bbk.get(self._bb, bbk.CLOCK)
        self._use_clock = clock is not None
        self._start = float(clock) if clock is not None else time.monotonic()  # type: ignore[arg-type]
        self.feedback_message = ""

    def update(self) -> Status:
        elapsed = self._now() - self._start
        if self.decorated.status == Status.RUNNING and elapsed > self.duration_s:
            self.decorated.stop(Status.INVALID)
            self.feedback_message = f"timed out after {self.duration_s:g} s"
            return Status.FAILURE
        if self.decorated.status == Status.RUNNING:
            self.feedback_message = f"{self.duration_s - elapsed:.1f} s left"
        else:
            self.feedback_message = f"child finished after {elapsed:.1f} s"
        return self.decorated.status


def _at_least_one_or_forever(port: str) -> Check:
    def check(values: dict[str, Any], _n: int) -> str | None:
        value = values[port]
        if value >= 1 or value == -1:
            return None
        return f"port {port} expects an int ≥ 1 (or -1 for no limit), got {value}"

    return check


def _positive(port: str) -> Check:
    def check(values: dict[str, Any], _n: int) -> str | None:
        return None if values[port] > 0 else f"port {port} expects an int > 0, got {values[port]}"

    return check


def parallel_thresholds(success_count: int, failure_count: int, n_children: int) -> tuple[int, int]:
    """BT.CPP's rule: a negative count means ``n_children + 1 + count`` (-1 = all children)."""

    def resolve(count: int) -> int:
        return n_children + 1 + count if count < 0 else count

    return resolve(success_count), resolve(failure_count)


def _check_parallel(values: dict[str, Any], n: int) -> str | None:
    success, failure = parallel_thresholds(values["success_count"], values["failure_count"], n)
    for port, resolved in (("success_count", success), ("failure_count", failure)):
        if not 1 <= resolved <= n:
            return (
                f"port {port}={values[port]} means {resolved} of {n} children; "
                f"expected 1..{n} (or -1 for all)"
            )
    return None


def _build_parallel(name: str, children: list[Behaviour], ports: dict[str, Any]) -> Behaviour:
    success, failure = parallel_thresholds(ports["success_count"], ports["failure_count"], len(children))
    return BtParallel(name, children, success, failure)


BUILTINS: dict[str, NodeManifest] = {
    node.tag: node
    for node in (
        NodeManifest(
            "Sequence", "Control", "children in order until one fails; a RUNNING child is resumed",
            lambda name, ch, _p: py_trees.composites.Sequence(name, memory=True, children=ch),
        ),
        NodeManifest(
            "ReactiveSequence", "Control", "children in order every tick (conditions re-checked)",
            lambda name, ch, _p: py_trees.composites.Sequence(name, memory=False, children=ch),
        ),
        NodeManifest(
            "Fallback", "Control", "children in order until one succeeds; a RUNNING child is resumed",
            lambda name, ch, _p: py_trees.composites.Selector(name, memory=True, children=ch),
        ),
        NodeManifest(
            "ReactiveFallback", "Control", "children in priority order every tick (higher ones preempt)",
            lambda name, ch, _p: py_trees.composites.Selector(name, memory=False, children=ch),
        ),
        NodeManifest(
            "Parallel", "Control", "ticks all children; thresholds decide success and failure",
            _build_parallel,
            {
                "success_count": Port(int, -1, "children that must succeed (-1 = all)"),
                "failure_count": Port(int, 1, "children whose failure fails the parallel (-1 = all)"),
            },
            _check_parallel,
        ),
        NodeManifest(
            "Inverter", "Decorator", "SUCCESS ↔ FAILURE",
            lambda name, ch, _p: py_trees.decorators.Inverter(name, child=ch[0]),
        ),
        NodeManifest(
            "ForceSuccess", "Decorator", "FAILURE → SUCCESS (RUNNING stays RUNNING)",
            lambda name, ch, _p: py_trees.decorators.FailureIsSuccess(name, child=ch[0]),
        ),
        NodeManifest(
            "ForceFailure", "Decorator", "SUCCESS → FAILURE (RUNNING stays RUNNING)",
            lambda name, ch, _p: py_trees.decorators.SuccessIsFailure(name, child=ch[0]),
        ),
        NodeManifest(
            "RetryUntilSuccessful", "Decorator", "retries a failing child (num_attempts in all, -1 = forever)",
            lambda name, ch, p: RetryUntilSuccessful(name, child=ch[0], num_failures=p["num_attempts"]),
            {"num_attempts": Port(int, REQUIRED, "attempts in all (-1 = no limit)")},
            _at_least_one_or_forever("num_attempts"),
        ),
        NodeManifest(
            "Repeat", "Decorator", "repeats a succeeding child num_cycles times (-1 = forever)",
            lambda name, ch, p: py_trees.decorators.Repeat(name, child=ch[0], num_success=p["num_cycles"]),
            {"num_cycles": Port(int, REQUIRED, "successful cycles before SUCCESS (-1 = forever)")},
            _at_least_one_or_forever("num_cycles"),
        ),
        NodeManifest(
            "Timeout", "Decorator", "FAILURE if the child still runs after msec (blackboard CLOCK)",
            lambda name, ch, p: ClockTimeout(name, child=ch[0], duration_s=p["msec"] / 1000.0),
            {"msec": Port(int, REQUIRED, "time limit in milliseconds")},
            _positive("msec"),
        ),
        NodeManifest(
            "AlwaysSuccess", "Action", "returns SUCCESS",
            lambda name, _ch, _p: py_trees.behaviours.Success(name),
        ),
        NodeManifest(
            "AlwaysFailure", "Action", "returns FAILURE",
            lambda name, _ch, _p: py_trees.behaviours.Failure(name),
        ),
    )
}

#: BT.CPP v4 built-ins this loader does not map (yet): named in their own error message
UNSUPPORTED_BUILTINS = frozenset(
    {
        "SequenceWithMemory", "ParallelAll", "IfThenElse", "WhileDoElse", "Switch2", "Switch3", "Switch4",
        "Switch5", "Switch6", "ManualSelector", "KeepRunningUntilFailure", "Delay", "RunOnce", "Precondition",
        "Sleep", "Script", "ScriptCondition", "SetBlackboard", "UnsetBlackboard", "WasEntryUpdated",
        "SkipUnlessUpdated", "WaitValueUpdate", "LoopInt", "LoopDouble", "LoopString", "LoopBool",
    }
)

#: tags with a meaning in the file format itself (not nodes a factory may register)
RESERVED_TAGS = frozenset({"SubTree", "BehaviorTree", "root", "include", "TreeNodesModel"})
