"""BehaviorTree.CPP's tick, run on py_trees behaviours: pre/post conditions, SKIPPED, halts, IDLE resets.

Every node the loader builds keeps py_trees' own ``status`` (what viewers, the tick log and the live view
show: the status it returned when last ticked, INVALID once halted) and, beside it, the status BT.CPP
would hold for it (:attr:`Layer.status`), which BT.CPP's rules read: a parent resets a finished child to
IDLE, ``_skipIf`` / ``_successIf`` / ``_failureIf`` are evaluated only on an IDLE node, ``_while`` also
while it runs. py_trees' INVALID stands for BT.CPP's IDLE.

**SKIPPED.** py_trees has no SKIPPED status. A node that is skipped (a precondition, or a control whose
children were all skipped) returns :data:`SKIPPED` to its parent through :attr:`NodeRuntime.result`; its
BT.CPP status stays what it was (IDLE, as in BT.CPP) and py_trees shows it INVALID (not ticked). Our
controls and decorators treat SKIPPED as BT.CPP's do; a py_trees composite that is not ours sees INVALID.

**One tick.** :func:`execute` is BT.CPP's ``executeTick`` (plain calls; :func:`install` keeps py_trees'
generator ``tick`` at the edge, yielding the nodes ticked, in py_trees' order): preconditions,
the node's own tick (py_trees' for a leaf: initialise when not RUNNING, update, terminate when it
finishes), postconditions. The root's tick is BT.CPP's ``tickOnce``: when a node asked to be woken up
(RetryUntilSuccessful / Repeat restarting a child that finished at once, SequenceWithMemory, the async
controls) the root is ticked again within the same tick while it is RUNNING. A halt is BT.CPP's
``haltNode``: a RUNNING leaf gets ``terminate(INVALID)``, a control halts its running children in order,
then the node's ``_onHalted`` script runs.

**SubTrees.** The loader flattens a ``<SubTree>`` into the root of its tree (one py_trees node per XML
node otherwise, so viewers keep their shape); the SubTree's own BT.CPP state (its status, its conditions)
is a :class:`Layer` of that root's runtime, outside the root's own layer.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from typing import Any

from py_trees.behaviour import Behaviour
from py_trees.common import Status

from mission.trees.script import Script, ScriptError, to_bool

IDLE = Status.INVALID
RUNNING, SUCCESS, FAILURE = Status.RUNNING, Status.SUCCESS, Status.FAILURE


class Skipped:
    """BT.CPP's SKIPPED: what a skipped node returns to its parent (never a py_trees status)."""

    name = "SKIPPED"

    def __repr__(self) -> str:
        return "SKIPPED"


SKIPPED: Any = Skipped()
Result = Any  # Status | Skipped

log = logging.getLogger(__name__)

#: re-ticks of the root within one tick at most (BT.CPP has no limit: a child that always finishes at once under
#: a Repeat or Retry without a limit would spin the mission's loop for ever)
MAX_WAKE_UPS = 1000

#: precondition attributes in the order BT.CPP checks them, and post-condition attributes
PRECONDITIONS = ("_failureIf", "_successIf", "_skipIf", "_while")
POSTCONDITIONS = ("_onSuccess", "_onFailure", "_post", "_onHalted")

#: (event, uid, status name) for every executeTick, given to TreeRuntime.observer (conformance tests)
Event = tuple[Any, ...]


def completed(result: Result) -> bool:
    return result is SUCCESS or result is FAILURE


def result_name(result: Result) -> str:
    return "IDLE" if result is IDLE else result.name


@dataclass(eq=False)
class TreeRuntime:
    """What the nodes of one loaded tree share: the wake-up signal and an optional observer."""

    observer: Callable[[Event], None] | None = None
    woken: bool = False
    warned_wake_ups: bool = False
    #: the nodes ticked so far in this tick, in the order py_trees' generators would have yielded them
    visited: list[Behaviour] = field(default_factory=list)

    def wake_up(self) -> None:
        """BT.CPP's emitWakeUpSignal: tick the root again at once if it is still RUNNING."""
        self.woken = True

    def consume_wake_up(self) -> bool:
        woken, self.woken = self.woken, False
        return woken

    def emit(self, *event: Any) -> None:
        if self.observer is not None:
            self.observer(event)


@dataclass(eq=False)
class Conditions:
    """A node's ``_skipIf`` … ``_post`` scripts (parsed at load) and the scope they run in."""

    pre: tuple[tuple[str, Script], ...] = ()  # in PRECONDITIONS order
    post: dict[str, Script] = field(default_factory=dict)
    env: Any = None  # scopes.ScriptEnv

    def run(self, script: Script) -> Any:
        return script.run(self.env)


@dataclass(eq=False)
class Layer:
    """BT.CPP's state of one XML node: the node itself, or a ``<SubTree>`` flattened onto it."""

    uid: int
    name: str
    conditions: Conditions = field(default_factory=Conditions)
    status: Status = IDLE  # BT.CPP's status (INVALID = IDLE)
    #: the node's attributes starting with ``_`` that are no port or condition (BT.CPP's other_attributes)
    other_attributes: dict[str, str] = field(default_factory=dict)


@dataclass(eq=False)
class NodeRuntime:
    """Attached to every built node as ``node.bt``."""

    tree: TreeRuntime
    layers: list[Layer]  # outermost first; the last one is the node's own
    ports: Any = None  # wiring.Wiring: the node's ports (constants, entries it reads and writes)
    refresh: Callable[[Behaviour], None] | None = None  # re-reads blackboard inputs into the node's params
    result: Result = IDLE  # what the last executeTick returned to the parent

    @property
    def own(self) -> Layer:
        return self.layers[-1]

    @property
    def uid(self) -> int:
        return self.layers[-1].uid

    @property
    def other_attributes(self) -> dict[str, str]:
        """The node's own attributes that are no port or condition, as written (BT.CPP's other_attributes)."""
        return self.layers[-1].other_attributes


class PortError(RuntimeError):
    """A port that cannot be read now (an entry that was never written, a value of another type)."""


# ------------------------------------------------------------------------------ what parents use
def runtime(node: Behaviour) -> NodeRuntime:
    return node.bt  # type: ignore[attr-defined,no-any-return]


def bt_status(node: Behaviour) -> Status:
    """The status BT.CPP holds for `node` (its outermost layer's)."""
    return runtime(node).layers[0].status


def tick_child(child: Behaviour) -> Result:
    """``child->executeTick()``: tick it and return what it returned (SKIPPED included)."""
    return execute(child)


def reset_status(child: Behaviour) -> None:
    """``child->resetStatus()``: BT.CPP's status back to IDLE (py_trees' display is left as it is)."""
    runtime(child).layers[0].status = IDLE


def halt_node(node: Behaviour) -> None:
    """``node->haltNode()``: halt it (and what runs below it), then its ``_onHalted`` script."""
    _halt_layer(node, runtime(node), 0)


def halt_child(child: Behaviour) -> None:
    """BT.CPP's haltChild: halt the child if it is RUNNING, then reset it to IDLE."""
    if bt_status(child) is RUNNING:
        halt_node(child)
    reset_status(child)


def _halt_layer(node: Behaviour, rt: NodeRuntime, i: int) -> None:
    layer = rt.layers[i]
    if i < len(rt.layers) - 1:  # a SubTree: DecoratorNode::halt resets (and halts) its child
        inner = rt.layers[i + 1]
        if inner.status is RUNNING:
            _halt_layer(node, rt, i + 1)
        inner.status = IDLE
    else:
        if isinstance(node, BuiltinNode):
            node.bt_halt()
        elif node.status is RUNNING:
            node.stop(Status.INVALID)  # a py_trees leaf: terminate(INVALID), shown INVALID
        else:
            node.status = Status.INVALID
    layer.status = IDLE
    script = layer.conditions.post.get("_onHalted")
    if script is not None:
        _run_quietly(node, layer.conditions, script)


def _run_quietly(node: Behaviour, conditions: Conditions, script: Script) -> None:
    try:
        conditions.run(script)
    except ScriptError as err:
        node.feedback_message = f"script {script.source!r}: {err}"


# --------------------------------------------------------------------------------- executeTick
def install(node: Behaviour, rt: NodeRuntime, *, root: bool = False) -> None:
    """Give `node` BT.CPP's executeTick (``tickOnce`` for the root) as its py_trees ``tick``.

    Inside a tree the ticks are plain calls (:func:`execute`); py_trees' generator protocol is kept at the
    edge: the installed ``tick`` yields the nodes it ticked, in the order py_trees' own ticks would, for
    BehaviourTree's visitors and for a py_trees composite that is not one of ours."""
    node.bt = rt  # type: ignore[attr-defined]
    node.tick = (lambda: _tick_root(node)) if root else (lambda: _tick(node))  # type: ignore[method-assign]


def _visited_since(tree: TreeRuntime, start: int) -> list[Behaviour]:
    batch = tree.visited[start:]
    del tree.visited[start:]
    return batch


def _tick(node: Behaviour) -> Iterator[Behaviour]:
    tree = runtime(node).tree
    start = len(tree.visited)
    execute(node)
    yield from _visited_since(tree, start)


def _tick_root(node: Behaviour) -> Iterator[Behaviour]:
    """BT.CPP's Tree::tickOnce: tick the root again at once while it is RUNNING and a node woke the tree up."""
    rt = runtime(node)
    rt.tree.visited.clear()  # a tick that raised half-way leaves nothing behind for this one
    start = 0
    for _ in range(MAX_WAKE_UPS + 1):
        execute(node)
        if not (rt.result is RUNNING and rt.tree.consume_wake_up()):
            break
    else:  # BT.CPP would loop for ever (Repeat num_cycles="-1" over a child that succeeds at once)
        if not rt.tree.warned_wake_ups:
            rt.tree.warned_wake_ups = True
            log.warning(
                "%s: woken up %d times within one tick; the rest of this tick waits for the next one",
                node.name,
                MAX_WAKE_UPS,
            )
    if completed(rt.result):
        rt.layers[0].status = IDLE
    yield from _visited_since(rt.tree, start)


def execute(node: Behaviour) -> Result:
    """BT.CPP's executeTick on `node` (and the SubTrees flattened onto it); what it returns to its parent."""
    rt = runtime(node)
    rt.result = _execute_layer(node, rt, 0)
    return rt.result


def _execute_layer(node: Behaviour, rt: NodeRuntime, i: int) -> Result:
    layer = rt.layers[i]
    own = i == len(rt.layers) - 1
    result = None
    if layer.conditions.pre:
        try:
            result = _check_preconditions(node, rt, i)
        except ScriptError as err:
            result = _fail(node, rt, i, f"precondition: {err}")
    if result is not None:
        if own:
            node.status = result if completed(result) else Status.INVALID
            rt.tree.visited.append(node)
    elif not own:  # SubTreeNode::tick: RUNNING while its tree runs; its finished child is reset
        if layer.status is IDLE:
            layer.status = RUNNING
        result = _execute_layer(node, rt, i + 1)
        if completed(result):
            rt.layers[i + 1].status = IDLE
    else:
        result = _tick_own(node, rt)
    post = layer.conditions.post
    if post and completed(result):
        for name in ("_onSuccess" if result is SUCCESS else "_onFailure", "_post"):
            if name in post:
                _run_quietly(node, layer.conditions, post[name])
    if rt.tree.observer is not None:
        rt.tree.emit("exec", layer.uid, result_name(result))
    if result is not SKIPPED:
        layer.status = result
    return result


def _check_preconditions(node: Behaviour, rt: NodeRuntime, i: int) -> Result | None:
    layer = rt.layers[i]
    for name, script in layer.conditions.pre:
        if layer.status is IDLE:
            if to_bool(layer.conditions.run(script)):
                if name == "_failureIf":
                    return FAILURE
                if name == "_successIf":
                    return SUCCESS
                if name == "_skipIf":
                    return SKIPPED
            elif name == "_while":
                return SKIPPED
        elif layer.status is RUNNING and name == "_while" and not to_bool(layer.conditions.run(script)):
            _halt_layer(node, rt, i)
            return SKIPPED
    return None


def _fail(node: Behaviour, rt: NodeRuntime, i: int, message: str) -> Result:
    """A script or a port that cannot be evaluated: BT.CPP throws; here the node fails and says why."""
    if rt.layers[i].status is RUNNING:
        _halt_layer(node, rt, i)
    node.feedback_message = message
    return FAILURE


def _tick_own(node: Behaviour, rt: NodeRuntime) -> Result:
    visited = rt.tree.visited
    if rt.refresh is not None:
        try:
            rt.refresh(node)
        except PortError as err:
            result = _fail(node, rt, len(rt.layers) - 1, str(err))
            node.status = Status.FAILURE
            visited.append(node)
            return result
    if isinstance(node, BuiltinNode):
        return node.bt_execute()
    if not node.children and type(node).tick is _PY_TREES_TICK:
        _tick_leaf(node)  # py_trees' own leaf lifecycle, as a plain call
        visited.append(node)
    else:
        for visit in type(node).tick(node):  # a py_trees behaviour: initialise when not RUNNING, update, terminate
            visited.append(visit)
    returned = node.status
    if returned is IDLE:
        node.feedback_message = f"{node.feedback_message} (returned no status; counted as FAILURE)".strip()
        node.status = Status.FAILURE
        return FAILURE
    for child in node.children:  # a py_trees composite that is not ours: reset what finished below it
        child_rt = getattr(child, "bt", None)
        if child_rt is not None and completed(child_rt.layers[0].status):
            child_rt.layers[0].status = IDLE
    return returned


_PY_TREES_TICK = Behaviour.tick


def _tick_leaf(node: Behaviour) -> None:
    """What py_trees' ``Behaviour.tick`` does for a leaf — initialise unless RUNNING, update, stop when it
    finished — without its generator, its per-tick debug line and its list of every status; a leaf ticks
    every time the tree does, and this is most of a tick's cost beside the leaves' own work."""
    if node.status != Status.RUNNING:
        node.initialise()
    new_status = node.update()
    if not isinstance(new_status, Status):  # as py_trees does: said, and counted as INVALID
        node.logger.error(f"A behaviour returned an invalid status, setting to INVALID [{new_status}][{node.name}]")
        new_status = Status.INVALID
    if new_status != Status.RUNNING:
        node.stop(new_status)
    node.status = new_status


# ------------------------------------------------------------------------ the built-ins' base
class BuiltinNode:
    """Mixin for the BT.CPP built-ins implemented here (trees/controls.py, decorators.py, actions.py).

    A subclass writes BT.CPP's ``tick()`` as :meth:`bt_tick`, which ticks children with ``self.run(child)``
    and returns the status (possibly SKIPPED), and BT.CPP's ``halt()`` as :meth:`bt_halt`.
    ``self.bt_own_status`` is BT.CPP's ``status()``; ports are read with :meth:`input`.
    """

    returned: Result = IDLE
    children: list[Behaviour]
    status: Status
    feedback_message: str

    def bt_tick(self) -> Result:
        raise NotImplementedError

    def bt_halt(self) -> None:
        """ControlNode::halt / DecoratorNode::halt: halt the running children, reset them all."""
        for child in self.children:
            halt_child(child)
        self.status = Status.INVALID

    @property
    def bt_own_status(self) -> Status:
        return runtime(self).own.status  # type: ignore[arg-type]

    def set_running(self) -> None:
        """BT.CPP's ``setStatus(RUNNING)`` inside tick()."""
        runtime(self).own.status = RUNNING  # type: ignore[arg-type]

    def input(self, name: str, default: Any = ...) -> Any:
        """The port's value now (constant or blackboard entry); PortError when it cannot be read."""
        ports = getattr(runtime(self), "ports", None)  # type: ignore[arg-type]
        if ports is None:
            raise PortError(f"port {name} is not set")
        return ports.get(name) if default is ... else ports.get(name, default)

    def run(self, child: Behaviour) -> Result:
        """``child->executeTick()`` (py_trees' current_child follows it for viewers)."""
        if hasattr(self, "current_child"):
            self.current_child = child
        return execute(child)

    def bt_execute(self) -> Result:
        """This node's own tick within executeTick: bt_tick, what py_trees shows, the visit."""
        try:
            result = self.bt_tick()
        except PortError as err:
            for child in self.children:
                halt_child(child)
            self.feedback_message = str(err)
            result = FAILURE
        self.returned = result
        self.status = result if isinstance(result, Status) else Status.INVALID
        runtime(self).tree.visited.append(self)  # type: ignore[arg-type]
        return result

    def tick(self) -> Iterator[Behaviour]:
        """py_trees' tick, for a caller that is not a tree of ours (install() replaces it on built nodes)."""
        tree = runtime(self).tree  # type: ignore[arg-type]
        start = len(tree.visited)
        self.bt_execute()
        yield from _visited_since(tree, start)

    def stop(self, new_status: Status = Status.INVALID) -> None:
        """py_trees' stop (BehaviourTree.interrupt, a py_trees parent): INVALID means BT.CPP's halt."""
        if new_status is Status.INVALID:
            halt_node(self)  # type: ignore[arg-type]
        else:
            self.status = new_status

    def update(self) -> Status:  # py_trees' abstract update: the tick above replaces it
        return self.status
