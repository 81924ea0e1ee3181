"""What BehaviorTree.CPP's tests use, in our terms: a factory, trees from XML text, the root blackboard, ticks.

The translated tests (test_btcpp_*.py beside this file) read like their C++ originals::

    bt = Harness(tmp_path)                              # BT::BehaviorTreeFactory factory;
    counters = bt.register_test_tick("Test", 3)         # BT::test::RegisterTestTick(factory, "Test", counters);
    tree = bt.load(xml_text)                            # auto tree = factory.createTreeFromText(xml_text);
    assert tree.tick_while_running() == "SUCCESS"       # ASSERT_EQ(status, NodeStatus::SUCCESS);
    assert counters == [1, 1, 0]
    assert tree.get("x") == 3                           # tree.rootBlackboard()->get<int>("x")

Statuses are BT.CPP's names ("SUCCESS", "FAILURE", "RUNNING", "SKIPPED", "IDLE"). Loading is our real
loader on a file (the XML verbatim, written to `tmp_path`); ticking is our real executeTick; the blackboard is
our real store (trees/scopes.py). Nothing here decides an outcome.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, ClassVar

import py_trees
import pytest
from py_trees.behaviour import Behaviour
from py_trees.common import Status

from mission.behaviours.ports import PortsDeclared, field_name, port
from mission.trees import scopes
from mission.trees.execution import SKIPPED, TreeRuntime, result_name
from mission.trees.factory import BehaviourFactory
from mission.trees.loader import load_tree

#: BT.CPP's NodeStatus by name, for callbacks written as in C++
STATUS = {"SUCCESS": Status.SUCCESS, "FAILURE": Status.FAILURE, "RUNNING": Status.RUNNING}


def TEST(suite_and_name: str) -> pytest.MarkDecorator:
    """Marks a test as the translation of BT.CPP's ``TEST(Suite, Name)`` (tree TESTs)."""
    return pytest.mark.btcpp(suite_and_name, kind="tree")


def SCRIPT(suite_and_name: str) -> pytest.MarkDecorator:
    """Marks a test as assertions of BT.CPP's script_parser_test.cpp ``TEST(Suite, Name)``: parametrize it
    with one case per assertion, so each assertion counts."""
    return pytest.mark.btcpp(suite_and_name, kind="script")


# ----------------------------------------------------------------------------- test nodes
class SimpleAction(Behaviour, PortsDeclared):
    """BT.CPP's ``registerSimpleAction(ID, fn)``: every tick calls `fn(node)` and returns its status.

    `fn` returns a Status or a BT.CPP status name; ``node.input(name)`` reads a port, ``node.set_output``
    writes one. Subclasses made by :meth:`Harness.register_simple_action` declare the ports."""

    def __init__(self, name: str, fn: Callable[[SimpleAction], Any], **ports: Any) -> None:
        super().__init__(name)
        self.fn = fn
        self.params = self.bind_params(ports)
        self.ticks = 0
        self.halts = 0

    def input(self, name: str) -> Any:
        return getattr(self.params, field_name(name))

    def update(self) -> Status:
        self.ticks += 1
        result = self.fn(self)
        status = STATUS[result] if isinstance(result, str) else result
        self.feedback_message = f"tick {self.ticks}: {status.name}"
        return status

    def terminate(self, new_status: Status) -> None:
        if new_status == Status.INVALID:
            self.halts += 1


class SimpleCondition(SimpleAction):
    NODE_TYPE = "Condition"


class Counters(list):
    """``std::array<int, N>`` of RegisterTestTick: how often TestA, TestB, … were ticked."""


class TestNode(Behaviour, PortsDeclared):
    """BT.CPP's SyncActionTest / ConditionTestNode / AsyncActionTest (tests/include/*.h) in one: returns
    `expected` ("SUCCESS" or "FAILURE"), after `time_s` of RUNNING when it is asynchronous, and counts."""

    __test__ = False  # not a pytest class

    @dataclass(frozen=True, kw_only=True)
    class Params:
        pass

    def __init__(self, name: str, registry: dict[str, TestNode], *, time_s: float = 0.0) -> None:
        super().__init__(name)
        self.params = self.bind_params({})
        self.expected = "SUCCESS"
        self.time_s = time_s
        self.tick_count = self.success_count = self.failure_count = self.halt_count = 0
        self._started: float | None = None
        registry[name] = self

    def initialise(self) -> None:
        self._started = time.monotonic()

    def update(self) -> Status:
        self.tick_count += 1
        if self.time_s > 0 and time.monotonic() - (self._started or 0.0) < self.time_s:
            self.feedback_message = "running"
            return Status.RUNNING
        if self.expected == "SUCCESS":
            self.success_count += 1
        else:
            self.failure_count += 1
        self.feedback_message = self.expected
        return STATUS[self.expected]

    def terminate(self, new_status: Status) -> None:
        if new_status == Status.INVALID:
            self.halt_count += 1


class ConditionTestNode(TestNode):
    NODE_TYPE = "Condition"


# ----------------------------------------------------------------------------- the tree
class Tree:
    """A loaded tree: BT.CPP's ``Tree`` (tickOnce, tickExactlyOnce, tickWhileRunning, haltTree, rootBlackboard)."""

    def __init__(self, root: Behaviour, runtime: TreeRuntime) -> None:
        self.root = root
        self.runtime = runtime
        self._tree = py_trees.trees.BehaviourTree(root)

    @property
    def status(self) -> str:
        """The root's BT.CPP status after the last tick."""
        return result_name(self.root.bt.result)  # type: ignore[attr-defined]

    def tick_once(self) -> str:
        self._tree.tick()
        return self.status

    def tick_exactly_once(self) -> str:
        return self.tick_once()

    def tick_while_running(self, sleep_s: float = 0.001, max_ticks: int = 100_000) -> str:
        """Tick until the root is not RUNNING (BT.CPP sleeps between ticks unless a node wakes the tree)."""
        for _ in range(max_ticks):
            status = self.tick_once()
            if status != "RUNNING":
                return status
            time.sleep(sleep_s)
        raise AssertionError(f"the tree was still RUNNING after {max_ticks} ticks")

    def halt(self) -> None:
        """BT.CPP's haltTree()."""
        self.root.stop(Status.INVALID)

    def nodes(self, tag_or_name: str | None = None) -> list[Behaviour]:
        """The tree's behaviours, all or those whose name or class is `tag_or_name`."""
        return [n for n in self.root.iterate() if tag_or_name is None or tag_or_name in (n.name, type(n).__name__)]

    # ------------------------------------------------------------------ root blackboard
    @staticmethod
    def _path(key: str, instance: str = "") -> str:
        key = key.removeprefix("@")
        if not instance and key in scopes.MISSION_KEYS:
            return scopes.MISSION_KEYS[key].path
        return f"{scopes.NAMESPACE}/{instance}/{key}" if instance else f"{scopes.NAMESPACE}/{key}"

    def get(self, key: str, instance: str = "") -> Any:
        """The entry `key` of the root blackboard (or of the SubTree `instance`'s, e.g. ``"MySub::2"``)."""
        return scopes.read(self._path(key, instance))

    def has(self, key: str, instance: str = "") -> bool:
        return scopes.exists(self._path(key, instance))

    def set(self, key: str, value: Any, instance: str = "") -> None:
        scopes.write(self._path(key, instance), value)


@dataclass
class NodeStatistics:
    transitions_count: int = 0
    success_count: int = 0
    failure_count: int = 0
    skip_count: int = 0


class TreeObserver:
    """BT::TreeObserver (loggers/bt_observer.cpp) for the leaves of a tree: per node (by its name), how often its
    status changed to something other than IDLE, to SUCCESS, to FAILURE, to SKIPPED.

    A change is seen at the node's executeTick (TreeRuntime.observer): the status it returned differs from the one
    BT.CPP held for it before (IDLE after a parent reset it). A control's own ``setStatus(RUNNING)`` inside its
    tick is not seen, so only leaves are counted as BT.CPP does."""

    def __init__(self, tree: Tree) -> None:
        self._layers = {layer.uid: layer for node in tree.nodes() for layer in node.bt.layers}
        self._uid_of = {layer.name: uid for uid, layer in self._layers.items()}
        self._stats = {uid: NodeStatistics() for uid in self._layers}
        tree.runtime.observer = self._callback

    def _callback(self, event: tuple[Any, ...]) -> None:
        if event[0] != "exec":
            return
        _, uid, status = event[:3]
        if status in (result_name(self._layers[uid].status), "IDLE"):
            return
        stats = self._stats[uid]
        stats.transitions_count += 1
        if status == "SUCCESS":
            stats.success_count += 1
        elif status == "FAILURE":
            stats.failure_count += 1
        elif status == "SKIPPED":
            stats.skip_count += 1

    def get_statistics(self, path: str) -> NodeStatistics:
        return self._stats[self._uid_of[path]]


# ----------------------------------------------------------------------------- the factory
class Harness:
    """BT.CPP's ``BehaviorTreeFactory`` for a test: registrations, XML texts, and trees made from them."""

    _CLASSES: ClassVar[int] = 0

    def __init__(self, tmp_path: Path) -> None:
        self.factory = BehaviourFactory()
        self.tmp_path = tmp_path
        self.texts: list[Path] = []
        self.test_nodes: dict[str, TestNode] = {}
        self._files = 0

    def register(self, cls: type[PortsDeclared], tag: str | None = None, /, **args: Any) -> None:
        """``registerNodeType<T>(ID, args…)``."""
        self.factory.register(cls, tag, **args)

    def register_simple_action(
        self,
        tag: str,
        fn: Callable[[SimpleAction], Any],
        ports: Iterable[tuple[str, type, Any]] | None = None,
        *,
        kind: type[SimpleAction] = SimpleAction,
    ) -> None:
        """``registerSimpleAction(ID, fn, ports)``; `ports` are (name, type, ``port(…)``), e.g.
        ``("msg", str, port(doc="the text"))`` for ``InputPort<std::string>("msg")``."""
        fields = [(field_name(name), kind_, spec) for name, kind_, spec in (ports or ())]
        params = dataclasses.make_dataclass("Params", fields, frozen=True, kw_only=True)
        Harness._CLASSES += 1
        cls = type(f"{tag}Node{Harness._CLASSES}", (kind,), {"Params": params})
        self.factory.register(cls, tag, fn=fn)

    def register_simple_condition(
        self, tag: str, fn: Callable[[SimpleAction], Any], ports: Iterable[tuple[str, type, Any]] | None = None
    ) -> None:
        """``registerSimpleCondition(ID, fn, ports)``."""
        self.register_simple_action(tag, fn, ports, kind=SimpleCondition)

    def register_test_tick(self, prefix: str, n: int) -> Counters:
        """``BT::test::RegisterTestTick(factory, prefix, counters)``: prefixA, prefixB, … count their ticks and
        return SUCCESS."""
        counters = Counters([0] * n)
        for i in range(n):

            def tick(_node: SimpleAction, i: int = i) -> str:
                counters[i] += 1
                return "SUCCESS"

            self.register_simple_action(f"{prefix}{chr(ord('A') + i)}", tick)
        return counters

    def register_test_nodes(self, tag: str = "TestNode", *, condition: bool = False, time_s: float = 0.0) -> None:
        """Every ``<tag name="X">`` is a :class:`TestNode` found as ``self.test_nodes["X"]`` once built."""
        self.factory.register(
            ConditionTestNode if condition else TestNode, tag, registry=self.test_nodes, time_s=time_s
        )

    def register_tree_text(self, xml: str) -> None:
        """``registerBehaviorTreeFromText(xml)``: its trees can be created by ID, or used as SubTrees."""
        self.texts.append(self._write(xml))

    def _write(self, xml: str) -> Path:
        self._files += 1
        path = self.tmp_path / f"tree{self._files}.xml"
        path.write_text(xml)  # verbatim: line numbers in errors are the C++ string's
        return path

    def raises_by_first_tick(self, xml: str | None = None, main_tree: str | None = None) -> Exception:
        """BT.CPP's ``EXPECT_ANY_THROW`` around creating and ticking a tree: the error, whether our loader
        raised it (we check more at load) or the first ``tickWhileRunning``. Fails the test when neither does."""
        try:
            self.load(xml, main_tree).tick_while_running()
        except Exception as exc:
            return exc
        pytest.fail("expected an error when loading or ticking the tree; there was none")

    def load(
        self, xml: str | None = None, main_tree: str | None = None, blackboard: dict[str, Any] | None = None
    ) -> Tree:
        """``createTreeFromText(xml)``, or ``createTree(main_tree)`` from the registered texts; `blackboard` is
        what the C++ test set on the blackboard it passed in (``createTree(ID, blackboard)``)."""
        runtime = TreeRuntime()
        if xml is not None:
            path = self._write(xml)
        else:
            includes = "".join(f'<include path="{p.name}"/>' for p in self.texts)
            path = self._write(f'<root BTCPP_format="4">{includes}</root>')
        root = load_tree(path, self.factory, runtime, main_tree=main_tree, blackboard=blackboard)
        return Tree(root, runtime)


__all__ = [
    "SCRIPT",
    "SKIPPED",
    "STATUS",
    "TEST",
    "ConditionTestNode",
    "Counters",
    "Harness",
    "SimpleAction",
    "TestNode",
    "Tree",
    "TreeObserver",
    "port",
]
