"""Every node BehaviorTree.CPP 4.10's factory registers itself, as a :class:`NodeManifest` of this loader.

The ports are BT.CPP's ``providedPorts()`` (names, defaults, directions); every
:class:`~mission.trees.factory.BehaviourFactory` starts with these, as BT.CPP's factory does, and a tree
ID or a registered behaviour may not take one of their names. ``SubTree`` is not a manifest: the loader
reads it (trees/loader.py) and flattens it onto its tree's root.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from py_trees.behaviour import Behaviour

from mission.behaviours.ports import REQUIRED, Port
from mission.trees import actions, controls, decorators
from mission.trees.decorators import STATUS_NAMES
from mission.trees.manifest import BuildContext, Check, NodeKind, NodeManifest

Build = Callable[[str, list[Behaviour], dict[str, Any], BuildContext], Behaviour]


def _control(cls: type, **extra: Any) -> Build:
    return lambda name, children, _p, _c: cls(name, children, **extra)


def _decorator(cls: type, **extra: Any) -> Build:
    return lambda name, children, _p, _c: cls(name, children[0], **extra)


def _leaf(cls: type) -> Build:
    return lambda name, _ch, _p, _c: cls(name)


def _script(cls: type, port: str = "code") -> Build:
    def build(name: str, _children: list[Behaviour], ports: dict[str, Any], ctx: BuildContext) -> Behaviour:
        if port not in ctx.scripts:
            raise ValueError(
                f"port {port}={ports.get(port)}: write the script in the tree file (it is parsed when "
                "the tree loads), not in a blackboard entry"
            )
        return cls(name, ctx.scripts[port])

    return build


def _entry(key_text: str, ctx: BuildContext) -> str:
    text = str(key_text).strip()
    return ctx.entry_path(text[1:-1] if text.startswith("{") and text.endswith("}") else text)


def _entry_decorator(if_not_updated: Any) -> Build:
    return lambda name, children, p, ctx: decorators.EntryUpdated(
        name, children[0], _entry(p["entry"], ctx), if_not_updated
    )


def _positive_or_forever(port: str) -> Check:
    def check(values: dict[str, Any], _n: int) -> str | None:
        value = values[port]
        if not isinstance(value, int) or value >= 1 or value == -1:
            return None
        return f"port {port} expects an int ≥ 1 (or -1 for no limit), got {value}"

    return check


def _not_negative(port: str) -> Check:
    def check(values: dict[str, Any], _n: int) -> str | None:
        value = values[port]
        if not isinstance(value, int) or value >= 0:
            return None
        return f"port {port} expects milliseconds ≥ 0 (0: {'no timeout' if port == 'msec' else 'none'}), got {value}"

    return check


def _status_port(port: str, allowed: tuple[str, ...]) -> Check:
    def check(values: dict[str, Any], _n: int) -> str | None:
        value = values.get(port)
        if not isinstance(value, str) or value.upper() in allowed:
            return None
        return f"port {port} expects one of {', '.join(allowed)}, got {value!r}"

    return check


def _check_parallel(values: dict[str, Any], n: int) -> str | None:
    for port in ("success_count", "failure_count"):
        value = values.get(port)
        if not isinstance(value, int):
            continue
        resolved = controls.threshold(value, n)
        if not 1 <= resolved <= n:
            return f"port {port}={value} means {resolved} of {n} children; expected 1..{n} (or -1 for all)"
    return None


def _manifest(
    tag: str,
    kind: NodeKind,
    doc: str,
    build: Build,
    ports: dict[str, Port] | None = None,
    check: Check | None = None,
    **more: Any,
) -> NodeManifest:
    return NodeManifest(tag, kind, doc, build, ports or {}, check, **more)


def _switch(n: int) -> NodeManifest:
    ports = {"variable": Port(str, REQUIRED, "the value compared with the cases")}
    for i in range(1, n + 1):
        ports[f"case_{i}"] = Port(str, REQUIRED, f"child {i} runs when variable equals this")
    return _manifest(
        f"Switch{n}",
        "Control",
        f"the child whose case equals variable runs, else the last one ({n} cases)",
        lambda name, ch, _p, ctx: controls.Switch(name, ch, n, dict(ctx.enums)),
        ports,
        children=(n + 1, n + 1),
    )


def _loop(item: type, type_name: str) -> NodeManifest:
    return _manifest(
        f"Loop{type_name}",
        "Decorator",
        "ticks its child once per item of queue, the item in value",
        lambda name, ch, _p, _c: decorators.Loop(name, ch[0], item),
        {
            "queue": Port(str, REQUIRED, "items, ';'-separated, or an entry holding a list", "inout"),
            "if_empty": Port(str, "SUCCESS", "status when the queue is empty: SUCCESS, FAILURE or SKIPPED"),
            "value": Port(item, REQUIRED, "the current item", "output"),
        },
        _status_port("if_empty", ("SUCCESS", "FAILURE", "SKIPPED")),
        untyped=frozenset({"queue"}),
    )


_STATUSES = tuple(STATUS_NAMES)

BUILTINS: dict[str, NodeManifest] = {
    m.tag: m
    for m in (
        # -- controls
        _manifest("Sequence", "Control", "children in order until one fails; a RUNNING child is resumed",
                  _control(controls.Sequence)),
        _manifest("AsyncSequence", "Control", "a Sequence that hands control back after every child that succeeds",
                  _control(controls.Sequence, asynch=True)),
        _manifest("SequenceWithMemory", "Control", "a Sequence that does not start again from the first child "
                  "after a failure", _control(controls.SequenceWithMemory)),
        _manifest("ReactiveSequence", "Control", "children in order every tick (conditions re-checked)",
                  _control(controls.ReactiveSequence)),
        _manifest("Fallback", "Control", "children in order until one succeeds; a RUNNING child is resumed",
                  _control(controls.Fallback)),
        _manifest("AsyncFallback", "Control", "a Fallback that hands control back after every child that fails",
                  _control(controls.Fallback, asynch=True)),
        _manifest("ReactiveFallback", "Control", "children in priority order every tick (higher ones preempt)",
                  _control(controls.ReactiveFallback)),
        _manifest("Parallel", "Control", "ticks all children; returns once success_count succeeded or "
                  "failure_count failed, halting the rest", _control(controls.Parallel),
                  {"success_count": Port(int, -1, "children that must succeed (-1 = all)"),
                   "failure_count": Port(int, 1, "children whose failure fails the parallel (-1 = all)")},
                  _check_parallel),
        _manifest("ParallelAll", "Control", "ticks all children until each finished; FAILURE if at least "
                  "max_failures failed", _control(controls.ParallelAll),
                  {"max_failures": Port(int, 1, "failures that make it fail (-1 = all)")}),
        _manifest("IfThenElse", "Control", "if the first child succeeds the second runs, else the third (or FAILURE)",
                  _control(controls.IfThenElse), children=(2, 3)),
        _manifest("WhileDoElse", "Control", "the first child re-checked every tick chooses the second or the third",
                  _control(controls.WhileDoElse), children=(2, 3)),
        _manifest("TryCatch", "Control", "the children but the last in sequence; on a failure the last one runs",
                  _control(controls.TryCatch),
                  {"catch_on_halt": Port(bool, False, "also run the catch child when the node is halted")},
                  children=(2, None)),
        *(_switch(n) for n in range(2, 7)),
        # -- decorators
        _manifest("Inverter", "Decorator", "SUCCESS ↔ FAILURE", _decorator(decorators.Inverter)),
        _manifest("ForceSuccess", "Decorator", "a finished child is a SUCCESS (RUNNING stays RUNNING)",
                  _decorator(decorators.ForceSuccess)),
        _manifest("ForceFailure", "Decorator", "a finished child is a FAILURE (RUNNING stays RUNNING)",
                  _decorator(decorators.ForceFailure)),
        _manifest("RetryUntilSuccessful", "Decorator", "retries a failing child (num_attempts in all, -1 = forever)",
                  _decorator(decorators.RetryUntilSuccessful),
                  {"num_attempts": Port(int, REQUIRED, "attempts in all (-1 = no limit)")},
                  _positive_or_forever("num_attempts")),
        _manifest("KeepRunningUntilFailure", "Decorator", "RUNNING while the child succeeds, FAILURE when it fails",
                  _decorator(decorators.KeepRunningUntilFailure)),
        _manifest("Repeat", "Decorator", "repeats a succeeding child num_cycles times (-1 = forever)",
                  _decorator(decorators.Repeat),
                  {"num_cycles": Port(int, REQUIRED, "successful cycles before SUCCESS (-1 = forever)")},
                  _positive_or_forever("num_cycles")),
        _manifest("Timeout", "Decorator", "FAILURE if the child still runs after msec (blackboard CLOCK; 0 = never)",
                  _decorator(decorators.Timeout),
                  {"msec": Port(int, REQUIRED, "time limit in milliseconds (0 = no timeout)")}, _not_negative("msec")),
        _manifest("Delay", "Decorator", "ticks the child after delay_msec (blackboard CLOCK)",
                  _decorator(decorators.Delay),
                  {"delay_msec": Port(int, REQUIRED, "delay in milliseconds")}, _not_negative("delay_msec")),
        _manifest("RunOnce", "Decorator", "the child runs once; then SKIPPED (or its status again)",
                  _decorator(decorators.RunOnce),
                  {"then_skip": Port(bool, True, "skip after the first run, else repeat its status")}),
        _manifest("Precondition", "Decorator", "ticks the child when the script `if` is true, else returns `else`",
                  lambda name, ch, _p, ctx: decorators.Precondition(name, ch[0], ctx.scripts.get("if")),
                  {"if": Port(str, REQUIRED, "a script: the condition"),
                   "else": Port(str, "FAILURE", "status when the condition is false")},
                  _status_port("else", _STATUSES), scripts=frozenset({"if"})),
        *(_loop(item, name) for item, name in ((int, "Int"), (bool, "Bool"), (float, "Double"), (str, "String"))),
        _manifest("SkipUnlessUpdated", "Decorator", "SKIPPED unless the entry was written since the last tick",
                  _entry_decorator(decorators.SKIPPED),
                  {"entry": Port(str, REQUIRED, "the entry to watch")}, untyped=frozenset({"entry"})),
        _manifest("WaitValueUpdate", "Decorator", "RUNNING until the entry is written, then ticks the child",
                  _entry_decorator(decorators.RUNNING),
                  {"entry": Port(str, REQUIRED, "the entry to watch")}, untyped=frozenset({"entry"})),
        # -- leaves
        _manifest("AlwaysSuccess", "Action", "returns SUCCESS", _leaf(actions.AlwaysSuccess)),
        _manifest("AlwaysFailure", "Action", "returns FAILURE", _leaf(actions.AlwaysFailure)),
        _manifest("Script", "Action", "runs a script (assignments) and returns SUCCESS", _script(actions.ScriptNode),
                  {"code": Port(str, REQUIRED, "the script")}, scripts=frozenset({"code"})),
        _manifest("ScriptCondition", "Condition", "SUCCESS when the script is true, else FAILURE",
                  _script(actions.ScriptCondition),
                  {"code": Port(str, REQUIRED, "the script: true or false")}, scripts=frozenset({"code"})),
        _manifest("SetBlackboard", "Action", "writes value into the entry named by output_key",
                  _leaf(actions.SetBlackboard),
                  {"value": Port(str, REQUIRED, "the value, or {key} to copy another entry"),
                   "output_key": Port(str, REQUIRED, "the name of the entry to write", "inout")},
                  untyped=frozenset({"value", "output_key"})),
        _manifest("UnsetBlackboard", "Action", "removes the entry named by key", _leaf(actions.UnsetBlackboard),
                  {"key": Port(str, REQUIRED, "the name of the entry to remove")}),
        _manifest("Sleep", "Action", "RUNNING for msec (blackboard CLOCK), then SUCCESS", _leaf(actions.Sleep),
                  {"msec": Port(int, REQUIRED, "milliseconds")}, _not_negative("msec")),
        _manifest("WasEntryUpdated", "Condition", "SUCCESS when the entry was written since the last tick",
                  lambda name, _ch, p, ctx: actions.WasEntryUpdated(name, _entry(p["entry"], ctx)),
                  {"entry": Port(str, REQUIRED, "the entry to watch")}, untyped=frozenset({"entry"})),
    )
}  # fmt: skip

#: tags with a meaning in the file format itself (not nodes a factory may register)
RESERVED_TAGS = frozenset({"SubTree", "BehaviorTree", "root", "Root", "include", "TreeNodesModel"})

#: every ID BT.CPP 4.10's factory registers (SubTree included): no tree and no behaviour may use one
BUILTIN_IDS = frozenset({*BUILTINS, "SubTree"})
