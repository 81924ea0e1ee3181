"""BehaviorTree.CPP 4's decorators, tick for tick (src/decorators/*.cpp of BT.CPP 4.10).

As in BT.CPP, a decorator resets its child to IDLE once the child has finished (DecoratorNode::executeTick).
``RetryUntilSuccessful`` and ``Repeat`` restart a child that finished at once within the same tick (they
wake the tree up and the root is ticked again, BT.CPP's ``tickOnce``); a child that ran first and then
failed (or succeeded) is restarted at once, inside the same tick.

Time-based decorators (``Timeout``, ``Delay``) measure time on the blackboard CLOCK (``/robot/clock``: sim
time in the simulation, ROS time on a robot), not on a wall-clock timer thread as BT.CPP does: a faster than
real-time simulation times out in sim seconds, and a timer can only expire when the tree is ticked. Without a
CLOCK entry (a bare tree in a script) they fall back to ``time.monotonic()``.
"""

from __future__ import annotations

import contextlib
import time
from collections import deque
from typing import Any

import py_trees
from py_trees.behaviour import Behaviour
from py_trees.common import Status

from mission.behaviours.ports import Port
from mission.core import blackboard as bbk
from mission.trees import scopes
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
    completed,
    halt_child,
    reset_status,
    runtime,
)
from mission.trees.script import Script, ScriptError, ScriptSyntaxError, parse, to_bool

#: clock readings are sums of float steps (0.3 + 0.2 s): a timer is due this close to its time
EPSILON_MS = 1e-6

#: statuses a port such as Precondition's ``else`` or a loop's ``if_empty`` may name
STATUS_NAMES: dict[str, Result] = {"SUCCESS": SUCCESS, "FAILURE": FAILURE, "RUNNING": RUNNING, "SKIPPED": SKIPPED}


class Clock:
    """Seconds on the blackboard CLOCK (or ``time.monotonic()`` when the blackboard has none), chosen per start."""

    def __init__(self) -> None:
        self.use_blackboard = False

    def start(self) -> float:
        self.use_blackboard = scopes.exists(bbk.CLOCK.path)
        return self.now()

    def now(self) -> float:
        if self.use_blackboard:
            try:
                return float(scopes.read(bbk.CLOCK.path))
            except (KeyError, TypeError, ValueError):
                pass
        return time.monotonic()


class _Decorator(BuiltinNode, py_trees.decorators.Decorator):
    def __init__(self, name: str, child: Behaviour) -> None:
        super().__init__(name=name, child=child)

    @property
    def child(self) -> Behaviour:
        return self.decorated

    def reset_child(self) -> None:
        """DecoratorNode::resetChild: halt the child if RUNNING, then IDLE."""
        halt_child(self.decorated)

    def bt_execute(self) -> Result:
        result = super().bt_execute()
        if completed(bt_status(self.decorated)):  # DecoratorNode::executeTick resets a finished child
            reset_status(self.decorated)
        return result

    def wake_up(self) -> None:
        runtime(self).tree.wake_up()  # type: ignore[arg-type]


class Inverter(_Decorator):
    """BT.CPP ``Inverter``: SUCCESS ↔ FAILURE; RUNNING and SKIPPED pass through."""

    def bt_tick(self) -> Result:
        self.set_running()
        result = self.run(self.child)
        if completed(result):
            self.reset_child()
            return FAILURE if result is SUCCESS else SUCCESS
        return result


class ForceSuccess(_Decorator):
    """BT.CPP ``ForceSuccess``: a finished child is a SUCCESS; RUNNING and SKIPPED pass through."""

    forced: Status = SUCCESS

    def bt_tick(self) -> Result:
        self.set_running()
        result = self.run(self.child)
        if completed(result):
            self.reset_child()
            return self.forced
        return result


class ForceFailure(ForceSuccess):
    """BT.CPP ``ForceFailure``: a finished child is a FAILURE; RUNNING and SKIPPED pass through."""

    forced = FAILURE


class KeepRunningUntilFailure(_Decorator):
    """BT.CPP ``KeepRunningUntilFailure``: RUNNING while the child succeeds (it is restarted), FAILURE when it fails."""

    def bt_tick(self) -> Result:
        self.set_running()
        result = self.run(self.child)
        if result is FAILURE:
            self.reset_child()
            return FAILURE
        if result is SUCCESS:
            self.reset_child()
            return RUNNING
        return RUNNING if result is RUNNING else self.bt_own_status


class RetryUntilSuccessful(_Decorator):
    """BT.CPP ``RetryUntilSuccessful``: a failing child is retried, `num_attempts` times in all (-1: forever)."""

    count_on: Status = FAILURE  # the child status that counts an attempt (Repeat counts successes)

    def __init__(self, name: str, child: Behaviour) -> None:
        super().__init__(name, child)
        self.count = 0

    def bt_halt(self) -> None:
        self.count = 0
        super().bt_halt()

    def _limit(self) -> int:
        return int(self.input("num_attempts"))

    def bt_tick(self) -> Result:
        limit = self._limit()
        more = self.count < limit or limit == -1
        self.set_running()
        while more:
            before = bt_status(self.child)
            result = self.run(self.child)
            if result is RUNNING:
                return RUNNING
            if result is SKIPPED:
                self.reset_child()
                return SKIPPED
            if result is not self.count_on:  # retry: SUCCESS ends it; repeat: FAILURE ends it
                self.count = 0
                self.reset_child()
                return result
            self.count += 1
            with contextlib.suppress(PortError):
                limit = self._limit()  # BT.CPP reads the port again: a child may have changed it
            more = self.count < limit or limit == -1
            self.reset_child()
            self.feedback_message = f"{self.count} of {'∞' if limit == -1 else limit}"
            if before is IDLE and more:  # it finished at once: hand control back, the root ticks again
                self.wake_up()
                return RUNNING
        self.count = 0
        return FAILURE if self.count_on is FAILURE else SUCCESS


class Repeat(RetryUntilSuccessful):
    """BT.CPP ``Repeat``: a succeeding child is run again, `num_cycles` times in all (-1: forever)."""

    count_on = SUCCESS

    def _limit(self) -> int:
        return int(self.input("num_cycles"))


class _Timed(_Decorator):
    """A decorator timed on the blackboard CLOCK from its first tick (Timeout, Delay): the timer starts when the
    node starts, and stops when the node is halted or its child finishes or is cut off."""

    def __init__(self, name: str, child: Behaviour) -> None:
        super().__init__(name, child)
        self.clock = Clock()
        self.started: float | None = None

    def bt_halt(self) -> None:
        self.started = None
        super().bt_halt()

    def elapsed(self) -> float:
        """Seconds since the node started; the first tick starts the timer and sets the node RUNNING."""
        if self.started is None:
            self.started = self.clock.start()
            self.set_running()
        return self.clock.now() - self.started

    def stop_timer(self) -> None:
        """The child finished or was cut off: it is reset, and the next tick starts a new timer."""
        self.started = None
        self.reset_child()


class Timeout(_Timed):
    """BT.CPP ``Timeout``: FAILURE, and the child halted, when it still runs `msec` after it started (blackboard
    CLOCK); ``msec="0"`` means no timeout, as in BT.CPP."""

    def bt_tick(self) -> Result:
        msec = int(self.input("msec"))
        elapsed = self.elapsed()
        if msec > 0 and elapsed * 1000.0 >= msec - EPSILON_MS and bt_status(self.child) is RUNNING:
            self.stop_timer()
            self.feedback_message = f"timed out after {msec / 1000.0:g} s"
            return FAILURE
        result = self.run(self.child)
        if completed(result):
            self.stop_timer()
            self.feedback_message = f"child finished after {elapsed:.1f} s"
        elif msec > 0:
            self.feedback_message = f"{max(msec / 1000.0 - elapsed, 0.0):.1f} s left"
        return result


class Delay(_Timed):
    """BT.CPP ``Delay``: RUNNING for `delay_msec` (blackboard CLOCK), then the child is ticked."""

    def bt_tick(self) -> Result:
        msec = int(self.input("delay_msec"))
        elapsed = self.elapsed()
        if elapsed * 1000.0 < msec - EPSILON_MS:
            self.feedback_message = f"delaying: {max(msec / 1000.0 - elapsed, 0.0):.1f} s left"
            return RUNNING
        result = self.run(self.child)
        if completed(result):
            self.stop_timer()
        return result


class RunOnce(_Decorator):
    """BT.CPP ``RunOnce``: the child runs until it finishes once; afterwards SKIPPED (``then_skip``, the default)
    or the status it finished with."""

    def __init__(self, name: str, child: Behaviour) -> None:
        super().__init__(name, child)
        self.finished: Result | None = None

    def bt_tick(self) -> Result:
        then_skip = bool(self.input("then_skip", True))
        if self.finished is not None:
            return SKIPPED if then_skip else self.finished
        self.set_running()
        result = self.run(self.child)
        if completed(result):
            self.finished = result
            self.reset_child()
        return result


def status_port(value: Any, port: str) -> Result:
    text = str(value).strip().upper()
    if text not in STATUS_NAMES:
        raise PortError(f"port {port}: expected one of {', '.join(STATUS_NAMES)}, got {value!r}")
    return STATUS_NAMES[text]


class Precondition(_Decorator):
    """BT.CPP ``Precondition``: the child is ticked when the `if` script is true (and, once started, until it
    finishes); otherwise the `else` status (FAILURE by default)."""

    def __init__(self, name: str, child: Behaviour, script: Script | None) -> None:
        super().__init__(name, child)
        self.script = script
        self.child_running = False

    def _script(self) -> Script:
        source = str(self.input("if"))
        if self.script is None or self.script.source != source:  # a script read from the blackboard
            try:
                self.script = parse(source)
            except ScriptSyntaxError as err:
                raise PortError(f"port if: {err.message} (line {err.line}, column {err.column})") from None
        return self.script

    def bt_tick(self) -> Result:
        script = self._script()
        otherwise = status_port(self.input("else", "FAILURE"), "else")
        if not self.child_running:
            try:
                self.child_running = to_bool(script.run(runtime(self).own.conditions.env))
            except ScriptError as err:
                raise PortError(f"port if: {err}") from None
        if not self.child_running:
            self.feedback_message = f"{script.source!r} is false"
            return otherwise
        result = self.run(self.child)
        if completed(result):
            self.reset_child()
            self.child_running = False
        return result


class Loop(_Decorator):
    """BT.CPP ``LoopInt`` / ``LoopDouble`` / ``LoopString`` / ``LoopBool``: the child once per item of `queue`
    (``"1;2;3"`` in the file, or an entry holding a list or such a string), the item in `value`."""

    def __init__(self, name: str, child: Behaviour, item: type) -> None:
        super().__init__(name, child)
        self.item = item
        self.queue: deque[Any] | None = None
        self.child_running = False

    def _parse(self, text: str) -> deque[Any]:
        port = Port(self.item)
        try:
            return deque(port.parse(part) for part in text.split(";") if part != "" or self.item is str)
        except ValueError as err:
            raise PortError(f"port queue: {text!r} is not a ';'-separated list of {err}") from None

    def bt_tick(self) -> Result:
        ports = runtime(self).ports
        popped = False
        static = "queue" not in ports.inputs
        if self.bt_own_status is IDLE:
            self.child_running = False
            self.queue = self._parse(str(ports.constants.get("queue", ""))) if static else None
        if not self.child_running:
            if not static:
                ref = ports.inputs["queue"]
                try:
                    held = scopes.read(ref.path)
                except KeyError:
                    held = None
                if isinstance(held, deque):
                    self.queue = held  # a shared queue: popping it empties the entry, as in BT.CPP
                elif self.queue is None and isinstance(held, (list, tuple)):
                    self.queue = deque(held)
                elif self.queue is None and isinstance(held, str):
                    self.queue = self._parse(held)
                elif self.queue is None and held is not None:
                    raise PortError(f"port queue: {ref} holds {held!r}; expected a list or a ';'-separated string")
            if self.queue:
                ports.write("value", self.queue.popleft())
                popped = True
        if not popped and not self.child_running:
            return status_port(self.input("if_empty", "SUCCESS"), "if_empty")
        if self.bt_own_status is IDLE:
            self.set_running()
        result = self.run(self.child)
        self.child_running = result is RUNNING
        if completed(result):
            self.reset_child()
        return FAILURE if result is FAILURE else RUNNING


class EntryUpdated(_Decorator):
    """BT.CPP ``SkipUnlessUpdated`` (SKIPPED) / ``WaitValueUpdate`` (RUNNING): the child is ticked only when the
    entry named by `entry` was written since the last time this node looked; otherwise `if_not_updated`."""

    def __init__(self, name: str, child: Behaviour, path: str, if_not_updated: Result) -> None:
        super().__init__(name, child)
        self.path = path
        self.if_not_updated = if_not_updated
        self.seen: Any = None
        self.child_running = False

    def bt_halt(self) -> None:
        self.child_running = False
        super().bt_halt()

    def bt_tick(self) -> Result:
        if self.child_running:
            result = self.run(self.child)
            self.child_running = result is RUNNING
            return result
        current = scopes.version(self.path)
        if current is None:
            return self.if_not_updated
        previous, self.seen = self.seen, current
        if previous == current:
            return self.if_not_updated
        result = self.run(self.child)
        self.child_running = result is RUNNING
        return result
