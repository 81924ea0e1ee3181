"""BehaviorTree.CPP 4.10 tests/gtest_parallel.cpp, translated (XML verbatim; see btcpp_harness.py)."""

from __future__ import annotations

import time

import pytest

from tests.trees.btcpp.btcpp_harness import TEST, Harness, TestNode, TreeObserver

_NO_XML = (
    "builds the tree with the C++ API (ParallelNode, AsyncActionTest, ConditionTestNode added with addChild, "
    "thresholds set with setSuccessThreshold/setFailureThreshold), no XML"
)

#: TESTs of this file that only use the C++ API, and why they are not translated
SKIPPED: dict[str, str] = {
    "SimpleParallelTest.ConditionsTrue": _NO_XML,
    "SimpleParallelTest.Threshold_3": _NO_XML,
    "SimpleParallelTest.Threshold_neg2": _NO_XML,
    "SimpleParallelTest.Threshold_neg1": _NO_XML,
    "SimpleParallelTest.Threshold_thresholdFneg1": _NO_XML,
    "SimpleParallelTest.Threshold_2": _NO_XML,
    "ComplexParallelTest.ConditionsTrue": _NO_XML,
    "ComplexParallelTest.ConditionsLeftFalse": _NO_XML,
    "ComplexParallelTest.ConditionRightFalse": _NO_XML,
    "ComplexParallelTest.ConditionRightFalse_thresholdF_2": _NO_XML,
    "ComplexParallelTest.ConditionRightFalseAction1Done": _NO_XML,
}


class ConfiguredTestNode(TestNode):
    """BT::TestNode registered with a TestNodeConfig: RUNNING for `async_delay` seconds, then `return_status`."""

    __test__ = False

    def __init__(self, name: str, registry: dict[str, TestNode], *, time_s: float, return_status: str) -> None:
        super().__init__(name, registry, time_s=time_s)
        self.expected = return_status


# ----------------------------------------------------------------------------- BT::TreeObserver
@pytest.fixture
def bt(tmp_path):
    """BehaviorTreeFactory factory;"""
    return Harness(tmp_path)


@TEST("Parallel.FailingParallel")
def test_parallel_failing_parallel(bt):
    xml_text = """
<root BTCPP_format="4">
  <BehaviorTree ID="MainTree">
    <Parallel name="parallel" success_count="1" failure_count="3">
      <GoodTest name="first"/>
      <BadTest name="second"/>
      <SlowTest name="third"/>
    </Parallel>
  </BehaviorTree>
</root>  """

    bt.register(ConfiguredTestNode, "GoodTest", registry=bt.test_nodes, time_s=0.200, return_status="SUCCESS")
    bt.register(ConfiguredTestNode, "BadTest", registry=bt.test_nodes, time_s=0.100, return_status="FAILURE")
    bt.register(ConfiguredTestNode, "SlowTest", registry=bt.test_nodes, time_s=0.300, return_status="SUCCESS")

    tree = bt.load(xml_text)
    observer = TreeObserver(tree)

    state = tree.tick_while_running()
    # since at least one succeeded.
    assert state == "SUCCESS"
    assert observer.get_statistics("first").success_count == 1
    assert observer.get_statistics("second").failure_count == 1
    assert observer.get_statistics("third").failure_count == 0


@TEST("Parallel.ParallelAll")
def test_parallel_parallel_all(bt):
    bt.register(ConfiguredTestNode, "GoodTest", registry=bt.test_nodes, time_s=0.300, return_status="SUCCESS")
    bt.register(ConfiguredTestNode, "BadTest", registry=bt.test_nodes, time_s=0.100, return_status="FAILURE")

    xml_text = """
<root BTCPP_format="4">
  <BehaviorTree ID="MainTree">
    <ParallelAll max_failures="1">
      <BadTest name="first"/>
      <GoodTest name="second"/>
      <GoodTest name="third"/>
    </ParallelAll>
  </BehaviorTree>
</root>  """
    tree = bt.load(xml_text)
    observer = TreeObserver(tree)

    state = tree.tick_while_running()
    assert state == "FAILURE"
    assert observer.get_statistics("first").failure_count == 1
    assert observer.get_statistics("second").success_count == 1
    assert observer.get_statistics("third").success_count == 1

    xml_text = """
<root BTCPP_format="4">
  <BehaviorTree ID="MainTree">
    <ParallelAll max_failures="2">
      <BadTest name="first"/>
      <GoodTest name="second"/>
      <GoodTest name="third"/>
    </ParallelAll>
  </BehaviorTree>
</root>  """
    tree = bt.load(xml_text)
    observer = TreeObserver(tree)

    state = tree.tick_while_running()
    assert state == "SUCCESS"
    assert observer.get_statistics("first").failure_count == 1
    assert observer.get_statistics("second").success_count == 1
    assert observer.get_statistics("third").success_count == 1


@TEST("Parallel.Issue593")
def test_parallel_issue593(bt):
    xml_text = """
<root BTCPP_format="4">
  <BehaviorTree ID="TestTree">
    <Sequence>
      <Script code="test := true"/>
      <Parallel failure_count="1" success_count="-1">
        <TestA _skipIf="test == true"/>
        <Sleep msec="100"/>
      </Parallel>
    </Sequence>
  </BehaviorTree>
</root>
"""

    counters = bt.register_test_tick("Test", 1)

    tree = bt.load(xml_text)
    tree.tick_while_running()

    assert counters[0] == 0


@TEST("Parallel.PauseWithRetry")
def test_parallel_pause_with_retry(bt):
    xml_text = """
<root BTCPP_format="4">
  <BehaviorTree ID="TestTree">
    <Parallel>
      <Sequence>
        <Sleep msec="150"/>
        <Script code="paused := false"/>
        <Sleep msec="150"/>
      </Sequence>

      <Sequence>
        <Script code="paused := true; done := false"/>
        <RetryUntilSuccessful _while="paused" num_attempts="-1" _onHalted="done = true">
          <AlwaysFailure/>
        </RetryUntilSuccessful>
      </Sequence>
    </Parallel>
  </BehaviorTree>
</root>
"""

    tree = bt.load(xml_text)
    t1 = time.monotonic()
    done_time = 0.0
    done_detected = False

    status = tree.tick_exactly_once()

    def to_msec(seconds: float) -> int:
        return int(seconds * 1000)

    while status not in ("SUCCESS", "FAILURE"):
        time.sleep(0.001)

        if not done_detected and tree.get("done"):
            done_detected = True
            done_time = time.monotonic()
        status = tree.tick_exactly_once()
    t2 = time.monotonic()

    assert status == "SUCCESS"

    # tolerate an error in time measurement within this margin
    # CI runners (especially Windows) can overshoot Sleep by 50ms+ under load
    margin_msec = 80

    # the second branch with the RetryUntilSuccessful should take about 150 ms
    assert to_msec(done_time - t1) - 150 <= margin_msec
    # the whole process should take about 300 milliseconds
    assert to_msec(t2 - t1) - 300 <= margin_msec * 2


@TEST("Parallel.Issue819_SequenceVsReactiveSequence")
def test_parallel_issue819_sequence_vs_reactive_sequence(tmp_path):
    # Test 1: Regular Sequence - condition NOT re-evaluated
    xml_text = """
<root BTCPP_format="4">
  <BehaviorTree ID="TestTree">
    <Parallel success_count="2" failure_count="1">
      <Sequence>
        <TestCondition name="cond1"/>
        <Sleep msec="200"/>
      </Sequence>
      <Sequence>
        <TestCondition name="cond2"/>
        <Sleep msec="200"/>
      </Sequence>
    </Parallel>
  </BehaviorTree>
</root>
"""
    factory = Harness(tmp_path)
    tick_counts = [0, 0]

    def test_condition(node):
        # Register conditions that count their ticks
        name = node.name
        if name == "cond1":
            tick_counts[0] += 1
        elif name == "cond2":
            tick_counts[1] += 1
        return "SUCCESS"

    factory.register_simple_condition("TestCondition", test_condition)

    tree = factory.load(xml_text)

    # First tick: both conditions evaluated
    status = tree.tick_exactly_once()
    assert status == "RUNNING"
    assert tick_counts[0] == 1  # cond1 ticked once
    assert tick_counts[1] == 1  # cond2 ticked once

    # Second tick: conditions should NOT be re-evaluated (Sequence behavior)
    time.sleep(0.050)
    status = tree.tick_exactly_once()
    assert status == "RUNNING"
    # Conditions are NOT re-ticked because Sequence remembers current_child_idx_
    assert tick_counts[0] == 1  # Still 1 - NOT re-evaluated
    assert tick_counts[1] == 1  # Still 1 - NOT re-evaluated

    # Test 2: ReactiveSequence - condition IS re-evaluated every tick
    xml_text = """
<root BTCPP_format="4">
  <BehaviorTree ID="TestTree">
    <Parallel success_count="2" failure_count="1">
      <ReactiveSequence>
        <TestCondition name="cond1"/>
        <Sleep msec="200"/>
      </ReactiveSequence>
      <ReactiveSequence>
        <TestCondition name="cond2"/>
        <Sleep msec="200"/>
      </ReactiveSequence>
    </Parallel>
  </BehaviorTree>
</root>
"""
    (tmp_path / "second").mkdir()
    factory = Harness(tmp_path / "second")
    tick_counts = [0, 0]

    def test_condition_2(node):
        name = node.name
        if name == "cond1":
            tick_counts[0] += 1
        elif name == "cond2":
            tick_counts[1] += 1
        return "SUCCESS"

    factory.register_simple_condition("TestCondition", test_condition_2)

    tree = factory.load(xml_text)

    # First tick
    status = tree.tick_exactly_once()
    assert status == "RUNNING"
    assert tick_counts[0] == 1
    assert tick_counts[1] == 1

    # Second tick: conditions SHOULD be re-evaluated (ReactiveSequence behavior)
    time.sleep(0.050)
    status = tree.tick_exactly_once()
    assert status == "RUNNING"
    # Conditions ARE re-ticked because ReactiveSequence always starts from index 0
    assert tick_counts[0] == 2  # Re-evaluated!
    assert tick_counts[1] == 2  # Re-evaluated!
