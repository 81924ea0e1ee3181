"""BehaviorTree.CPP 4.10 tests/gtest_reactive_backchaining.cpp, translated (XML verbatim; see btcpp_harness.py)."""

from __future__ import annotations

import pytest
from py_trees.behaviour import Behaviour
from py_trees.common import Status

from mission.behaviours.ports import PortsDeclared
from mission.trees import scopes
from tests.trees.btcpp.btcpp_harness import TEST, Harness, TreeObserver

#: TESTs of this file that only use the C++ API, and why they are not translated
SKIPPED: dict[str, str] = {}


def _entry(node: Behaviour, key: str) -> str:
    """The entry `key` of the node's own blackboard (BT.CPP's ``config().blackboard``)."""
    return node.bt.own.conditions.env.scope.entry_path(key)  # type: ignore[attr-defined,no-any-return]


class SimpleCondition(Behaviour, PortsDeclared):
    """BT::test::SimpleCondition: SUCCESS when the bool entry `port_name` of its blackboard is true."""

    NODE_TYPE = "Condition"

    def __init__(self, name: str, port_name: str) -> None:
        super().__init__(name)
        self.port_name = port_name

    def update(self) -> Status:
        return Status.SUCCESS if scopes.read(_entry(self, self.port_name)) else Status.FAILURE


class AsyncTestAction(Behaviour, PortsDeclared):
    """BT::test::AsyncTestAction (a StatefulActionNode): RUNNING on start; on its second onRunning it sets the bool
    entry `port_name` of its blackboard to true and succeeds."""

    def __init__(self, name: str, port_name: str) -> None:
        super().__init__(name)
        self.port_name = port_name
        self.counter = 0
        self.starting = False

    def initialise(self) -> None:  # onStart
        self.counter = 0
        self.starting = True

    def update(self) -> Status:
        if self.starting:  # onStart's result
            self.starting = False
            return Status.RUNNING
        self.counter += 1  # onRunning
        if self.counter == 2:
            scopes.write(_entry(self, self.port_name), True)
            return Status.SUCCESS
        return Status.RUNNING


# ----------------------------------------------------------------------------- BT::TreeObserver
@pytest.fixture
def bt(tmp_path):
    """BehaviorTreeFactory factory;"""
    return Harness(tmp_path)


@TEST("ReactiveBackchaining.EnsureWarm")
def test_reactive_backchaining_ensure_warm(bt):
    # This test shows the basic structure of a PPA: a fallback
    # of a postcondition and an action to make that
    #  postcondition true.
    xml_text = """
  <root BTCPP_format="4">
    <BehaviorTree ID="EnsureWarm">
      <ReactiveFallback>
        <IsWarm name="warm"/>
        <ReactiveSequence>
          <IsHoldingJacket name="jacket" />
          <WearJacket name="wear" />
        </ReactiveSequence>
      </ReactiveFallback>
    </BehaviorTree>
  </root>
  """

    # The final condition of the PPA; the thing that make_warm achieves.
    # For this example, we're only warm after WearJacket returns success.
    bt.register(SimpleCondition, "IsWarm", port_name="is_warm")
    bt.register(SimpleCondition, "IsHoldingJacket", port_name="holding_jacket")
    bt.register(AsyncTestAction, "WearJacket", port_name="is_warm")

    tree = bt.load(xml_text)
    observer = TreeObserver(tree)

    # auto& blackboard = tree.subtrees.front()->blackboard;  (the root blackboard)
    tree.set("is_warm", False)
    tree.set("holding_jacket", True)

    # first tick: not warm, have a jacket: start wearing it
    assert tree.tick_exactly_once() == "RUNNING"
    assert not tree.get("is_warm")

    # second tick: not warm (still wearing)
    assert tree.tick_exactly_once() == "RUNNING"
    assert not tree.get("is_warm")

    # third tick: warm (wearing succeeded)
    assert tree.tick_exactly_once() == "SUCCESS"
    assert tree.get("is_warm")

    # fourth tick: still warm (just the condition ticked)
    assert tree.tick_exactly_once() == "SUCCESS"

    assert observer.get_statistics("warm").failure_count == 3
    assert observer.get_statistics("warm").success_count == 1

    assert observer.get_statistics("jacket").transitions_count == 3
    assert observer.get_statistics("jacket").success_count == 3

    assert observer.get_statistics("wear").success_count == 1


@TEST("ReactiveBackchaining.EnsureWarmWithEnsureHoldingHacket")
def test_reactive_backchaining_ensure_warm_with_ensure_holding_hacket(bt):
    # This test backchains on HoldingHacket => EnsureHoldingHacket to iteratively add reactivity and functionality
    # to the tree. The general structure of the PPA remains the same.
    xml_text = """
  <root BTCPP_format="4">
    <BehaviorTree ID="EnsureWarm">
      <ReactiveFallback>
        <IsWarm />
        <ReactiveSequence>
          <SubTree ID="EnsureHoldingJacket" />
          <WearJacket />
        </ReactiveSequence>
      </ReactiveFallback>
    </BehaviorTree>

    <BehaviorTree ID="EnsureHoldingJacket">
      <ReactiveFallback>
        <IsHoldingJacket />
        <ReactiveSequence>
          <IsNearCloset />
          <GrabJacket />
        </ReactiveSequence>
      </ReactiveFallback>
    </BehaviorTree>
  </root>
  """

    bt.register(SimpleCondition, "IsWarm", port_name="is_warm")
    bt.register(SimpleCondition, "IsHoldingJacket", port_name="holding_jacket")
    bt.register(SimpleCondition, "IsNearCloset", port_name="near_closet")
    bt.register(AsyncTestAction, "WearJacket", port_name="is_warm")
    bt.register(AsyncTestAction, "GrabJacket", port_name="holding_jacket")

    bt.register_tree_text(xml_text)
    tree = bt.load(main_tree="EnsureWarm")

    # tree.subtrees[0] is the root blackboard; tree.subtrees[1] is the SubTree's (instance "EnsureHoldingJacket::4")
    sub = "EnsureHoldingJacket::4"
    tree.set("is_warm", False)
    tree.set("holding_jacket", False, sub)
    tree.set("near_closet", True, sub)

    # first tick: not warm, no jacket, start GrabJacket
    assert tree.tick_exactly_once() == "RUNNING"
    assert not tree.get("is_warm")
    assert not tree.get("holding_jacket", sub)
    assert tree.get("near_closet", sub)

    # second tick: still GrabJacket
    assert tree.tick_exactly_once() == "RUNNING"

    # third tick: GrabJacket succeeded, start wearing
    assert tree.tick_exactly_once() == "RUNNING"
    assert not tree.get("is_warm")
    assert tree.get("holding_jacket", sub)

    # fourth tick: still WearingJacket
    assert tree.tick_exactly_once() == "RUNNING"

    # fifth tick: warm (WearingJacket succeeded)
    assert tree.tick_exactly_once() == "SUCCESS"
    assert tree.get("is_warm")

    # sixr tick: still warm (just the condition ticked)
    assert tree.tick_exactly_once() == "SUCCESS"
