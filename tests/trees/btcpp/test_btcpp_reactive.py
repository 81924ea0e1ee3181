"""BehaviorTree.CPP 4.10 tests/gtest_reactive.cpp, translated (XML verbatim; see btcpp_harness.py)."""

from __future__ import annotations

from typing import Any

import pytest
from py_trees.behaviour import Behaviour
from py_trees.common import Status

from mission.behaviours.ports import PortsDeclared
from tests.trees.btcpp.btcpp_harness import TEST, Harness, TreeObserver

#: TESTs of this file that only use the C++ API, and why they are not translated
SKIPPED: dict[str, str] = {
    "Reactive.PreTickHooks": "tests TreeNode::setPreTickFunction (a C++ callback replacing a node's tick, installed "
    "with tree.applyVisitor on every AlwaysFailureNode); the tree has no such hook",
}


# ----------------------------------------------------------------------------- BT::TreeObserver
# ----------------------------------------------------------------------------- test nodes
class TrackingAction(Behaviour, PortsDeclared):
    """The TEST's TrackingAction (a StatefulActionNode): counts onStart and onRunning, records onHalted."""

    def __init__(self, name: str, record: dict[str, Any]) -> None:
        super().__init__(name)
        self.record = record

    def update(self) -> Status:  # onStart and onRunning alike
        self.record["tick_count"] += 1
        return Status.RUNNING

    def terminate(self, new_status: Status) -> None:
        if new_status == Status.INVALID:
            self.record["was_halted"] = True


@pytest.fixture
def bt(tmp_path):
    """BT::BehaviorTreeFactory factory;"""
    return Harness(tmp_path)


@TEST("Reactive.RunningChildren")
def test_reactive_running_children(bt):
    reactive_xml_text = """
<root BTCPP_format="4" >
  <BehaviorTree ID="MainTree">
    <ReactiveSequence>
      <Sequence name="first">
        <TestA/>
        <TestB/>
        <TestC/>
      </Sequence>
      <AsyncSequence name="second">
        <TestD/>
        <TestE/>
        <TestF/>
      </AsyncSequence>
    </ReactiveSequence>
  </BehaviorTree>
</root>
"""

    counters = bt.register_test_tick("Test", 6)

    tree = bt.load(reactive_xml_text)

    status = "IDLE"

    count = 0
    while status not in ("SUCCESS", "FAILURE") and count < 100:
        count += 1
        status = tree.tick_exactly_once()

    assert count != 100

    assert status == "SUCCESS"

    assert counters[0] == 3
    assert counters[1] == 3
    assert counters[2] == 3

    assert counters[3] == 1
    assert counters[4] == 1
    assert counters[5] == 1


@TEST("Reactive.Issue587")
def test_reactive_issue587(bt):
    # TestA should be executed only once, because of the variable "test"

    reactive_xml_text = """
<root BTCPP_format="4" >
  <BehaviorTree ID="Example_A">
    <Sequence>
      <Script code="test := false"/>
      <ReactiveSequence>
        <RetryUntilSuccessful name="Retry 1" num_attempts="-1" _skipIf="test ">
          <TestA name="Success 1" _onSuccess="test = true"/>
        </RetryUntilSuccessful>
        <RetryUntilSuccessful name="Retry 2" num_attempts="5">
          <AlwaysFailure name="Failure 2"/>
        </RetryUntilSuccessful>
      </ReactiveSequence>
    </Sequence>
  </BehaviorTree>
</root>
"""

    counters = bt.register_test_tick("Test", 2)

    tree = bt.load(reactive_xml_text)
    tree.tick_while_running()

    assert counters[0] == 1


@TEST("Reactive.TestLogging")
def test_reactive_test_logging(bt):
    reactive_xml_text = """
<root BTCPP_format="4" >
  <BehaviorTree ID="Main">
    <ReactiveSequence>
      <TestA name="testA"/>
      <AlwaysSuccess name="success"/>
      <Sleep msec="100"/>
    </ReactiveSequence>
  </BehaviorTree>
</root>
"""

    counters = bt.register_test_tick("Test", 1)

    tree = bt.load(reactive_xml_text)
    observer = TreeObserver(tree)

    ret = tree.tick_while_running()
    assert ret == "SUCCESS"

    num_ticks = counters[0]
    assert num_ticks >= 5

    assert observer.get_statistics("testA").success_count == num_ticks
    assert observer.get_statistics("success").success_count == num_ticks


@TEST("Reactive.TwoAsyncNodesInReactiveSequence")
def test_reactive_two_async_nodes_in_reactive_sequence(bt):
    reactive_xml_text = """
<root BTCPP_format="4" >
  <BehaviorTree ID="MainTree">
    <ReactiveSequence>
      <AsyncSequence name="first">
        <TestA/>
        <TestB/>
        <TestC/>
      </AsyncSequence>
      <AsyncSequence name="second">
        <TestD/>
        <TestE/>
        <TestF/>
      </AsyncSequence>
    </ReactiveSequence>
  </BehaviorTree>
</root>
"""

    bt.register_test_tick("Test", 6)

    # BT.CPP throws in createTreeFromText: "A ReactiveSequence cannot have more than one async child."
    bt.raises_by_first_tick(reactive_xml_text)


@TEST("Reactive.ReactiveSequence_FirstChildFails")
def test_reactive_reactive_sequence_first_child_fails(bt):
    # When first child fails, ReactiveSequence should return FAILURE immediately
    counters = bt.register_test_tick("Test", 2)

    xml_text = """
<root BTCPP_format="4">
  <BehaviorTree>
    <ReactiveSequence>
      <AlwaysFailure/>
      <TestA/>
    </ReactiveSequence>
  </BehaviorTree>
</root>
"""

    tree = bt.load(xml_text)
    status = tree.tick_while_running()

    assert status == "FAILURE"
    assert counters[0] == 0  # TestA should never be ticked


@TEST("Reactive.ReactiveSequence_HaltOnConditionChange")
def test_reactive_reactive_sequence_halt_on_condition_change(bt):
    # Test that running children are halted when an earlier condition changes
    condition_result = [True]
    record = {"tick_count": 0, "was_halted": False}

    bt.register_simple_condition("DynamicCondition", lambda _node: "SUCCESS" if condition_result[0] else "FAILURE")
    bt.register(TrackingAction, "TrackingAction", record=record)

    xml_text = """
<root BTCPP_format="4">
  <BehaviorTree>
    <ReactiveSequence>
      <DynamicCondition/>
      <TrackingAction/>
    </ReactiveSequence>
  </BehaviorTree>
</root>
"""

    tree = bt.load(xml_text)

    # First tick - condition passes, action starts
    status = tree.tick_once()
    assert status == "RUNNING"
    assert record["tick_count"] >= 1
    assert not record["was_halted"]

    # Tick again while condition is still true
    status = tree.tick_once()
    assert status == "RUNNING"

    # Now change condition to false - child should be halted
    condition_result[0] = False
    status = tree.tick_once()
    assert status == "FAILURE"
    assert record["was_halted"]


@TEST("Reactive.ReactiveFallback_FirstChildSucceeds")
def test_reactive_reactive_fallback_first_child_succeeds(bt):
    # When first child succeeds, ReactiveFallback should return SUCCESS immediately
    counters = bt.register_test_tick("Test", 2)

    xml_text = """
<root BTCPP_format="4">
  <BehaviorTree>
    <ReactiveFallback>
      <AlwaysSuccess/>
      <TestA/>
    </ReactiveFallback>
  </BehaviorTree>
</root>
"""

    tree = bt.load(xml_text)
    status = tree.tick_while_running()

    assert status == "SUCCESS"
    assert counters[0] == 0  # TestA should never be ticked


@TEST("Reactive.ReactiveFallback_AllChildrenFail")
def test_reactive_reactive_fallback_all_children_fail(bt):
    xml_text = """
<root BTCPP_format="4">
  <BehaviorTree>
    <ReactiveFallback>
      <AlwaysFailure/>
      <AlwaysFailure/>
      <AlwaysFailure/>
    </ReactiveFallback>
  </BehaviorTree>
</root>
"""

    tree = bt.load(xml_text)
    status = tree.tick_while_running()

    assert status == "FAILURE"


@TEST("Reactive.ReactiveFallback_SecondChildSucceeds")
def test_reactive_reactive_fallback_second_child_succeeds(bt):
    counters = bt.register_test_tick("Test", 2)

    xml_text = """
<root BTCPP_format="4">
  <BehaviorTree>
    <ReactiveFallback>
      <AlwaysFailure/>
      <TestA/>
    </ReactiveFallback>
  </BehaviorTree>
</root>
"""

    tree = bt.load(xml_text)
    status = tree.tick_while_running()

    assert status == "SUCCESS"
    assert counters[0] == 1  # TestA ticked once and succeeded


@TEST("Reactive.ReactiveSequence_AllChildrenSucceed")
def test_reactive_reactive_sequence_all_children_succeed(bt):
    counters = bt.register_test_tick("Test", 3)

    xml_text = """
<root BTCPP_format="4">
  <BehaviorTree>
    <ReactiveSequence>
      <TestA/>
      <TestB/>
      <TestC/>
    </ReactiveSequence>
  </BehaviorTree>
</root>
"""

    tree = bt.load(xml_text)
    status = tree.tick_while_running()

    assert status == "SUCCESS"
    assert counters[0] == 1
    assert counters[1] == 1
    assert counters[2] == 1


@TEST("Reactive.ReactiveSequence_ReEvaluatesOnEveryTick")
def test_reactive_reactive_sequence_re_evaluates_on_every_tick(bt):
    # Verify that conditions are re-evaluated on every tick in ReactiveSequence
    condition_tick_count = [0]

    def counting_condition(_node):
        condition_tick_count[0] += 1
        return "SUCCESS"

    bt.register_simple_condition("CountingCondition", counting_condition)

    xml_text = """
<root BTCPP_format="4">
  <BehaviorTree>
    <ReactiveSequence>
      <CountingCondition/>
      <Sleep msec="50"/>
    </ReactiveSequence>
  </BehaviorTree>
</root>
"""

    tree = bt.load(xml_text)
    status = tree.tick_while_running()

    assert status == "SUCCESS"
    # Condition should be ticked multiple times (re-evaluated while Sleep is running)
    assert condition_tick_count[0] >= 2
