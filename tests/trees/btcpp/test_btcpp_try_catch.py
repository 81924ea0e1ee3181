"""BehaviorTree.CPP 4.10 tests/gtest_try_catch.cpp, translated (XML verbatim; see btcpp_harness.py)."""

from __future__ import annotations

import pytest

from mission.core.errors import TreeError
from tests.trees.btcpp.btcpp_harness import TEST, Harness

#: TESTs of this file that only use the C++ API, and why they are not translated
SKIPPED: dict[str, str] = {}


@pytest.fixture
def bt(tmp_path):
    """TryCatchTest's fixture: RegisterTestTick(factory, "Test", counters) with 4 counters."""
    harness = Harness(tmp_path)
    harness.counters = harness.register_test_tick("Test", 4)
    return harness


@TEST("TryCatchTest.AllTryChildrenSucceed")
def test_all_try_children_succeed(bt):
    xml_text = """
    <root BTCPP_format="4">
       <BehaviorTree>
          <TryCatch>
            <TestA/>
            <TestB/>
            <TestC/>  <!-- catch -->
          </TryCatch>
       </BehaviorTree>
    </root>"""
    tree = bt.load(xml_text)
    status = tree.tick_while_running()
    assert status == "SUCCESS"
    assert bt.counters[0] == 1  # TestA executed
    assert bt.counters[1] == 1  # TestB executed
    assert bt.counters[2] == 0  # TestC (catch) NOT executed


@TEST("TryCatchTest.FirstChildFails_CatchExecuted")
def test_first_child_fails_catch_executed(bt):
    xml_text = """
    <root BTCPP_format="4">
       <BehaviorTree>
          <TryCatch>
            <AlwaysFailure/>
            <TestA/>
            <TestB/>  <!-- catch -->
          </TryCatch>
       </BehaviorTree>
    </root>"""
    tree = bt.load(xml_text)
    status = tree.tick_while_running()
    assert status == "FAILURE"
    assert bt.counters[0] == 0  # TestA NOT executed (after failed child)
    assert bt.counters[1] == 1  # TestB (catch) executed


@TEST("TryCatchTest.SecondChildFails_CatchExecuted")
def test_second_child_fails_catch_executed(bt):
    xml_text = """
    <root BTCPP_format="4">
       <BehaviorTree>
          <TryCatch>
            <TestA/>
            <AlwaysFailure/>
            <TestB/>  <!-- catch -->
          </TryCatch>
       </BehaviorTree>
    </root>"""
    tree = bt.load(xml_text)
    status = tree.tick_while_running()
    assert status == "FAILURE"
    assert bt.counters[0] == 1  # TestA executed (before failure)
    assert bt.counters[1] == 1  # TestB (catch) executed


@TEST("TryCatchTest.CatchReturnsFailure_NodeStillReturnsFAILURE")
def test_catch_returns_failure_node_still_returns_failure(bt):
    xml_text = """
    <root BTCPP_format="4">
       <BehaviorTree>
          <TryCatch>
            <AlwaysFailure/>  <!-- try fails -->
            <AlwaysFailure/>  <!-- catch also fails -->
          </TryCatch>
       </BehaviorTree>
    </root>"""
    tree = bt.load(xml_text)
    status = tree.tick_while_running()
    assert status == "FAILURE"


@TEST("TryCatchTest.CatchReturnsSuccess_NodeStillReturnsFAILURE")
def test_catch_returns_success_node_still_returns_failure(bt):
    xml_text = """
    <root BTCPP_format="4">
       <BehaviorTree>
          <TryCatch>
            <AlwaysFailure/>  <!-- try fails -->
            <AlwaysSuccess/>  <!-- catch succeeds -->
          </TryCatch>
       </BehaviorTree>
    </root>"""
    tree = bt.load(xml_text)
    status = tree.tick_while_running()
    # Even if catch succeeds, TryCatch returns FAILURE
    assert status == "FAILURE"


@TEST("TryCatchTest.TryChildRunning")
def test_try_child_running(bt):
    tick_count = 0

    def running_then_success(_node):
        nonlocal tick_count
        tick_count += 1
        if tick_count == 1:
            return "RUNNING"
        return "SUCCESS"

    bt.register_simple_condition("RunningThenSuccess", running_then_success)

    xml_text = """
    <root BTCPP_format="4">
       <BehaviorTree>
          <TryCatch>
            <RunningThenSuccess/>
            <TestA/>  <!-- catch -->
          </TryCatch>
       </BehaviorTree>
    </root>"""
    tree = bt.load(xml_text)

    status = tree.tick_once()
    assert status == "RUNNING"

    status = tree.tick_while_running()
    assert status == "SUCCESS"
    assert bt.counters[0] == 0  # Catch NOT executed


@TEST("TryCatchTest.CatchChildRunning")
def test_catch_child_running(bt):
    catch_tick_count = 0

    def running_then_failure(_node):
        nonlocal catch_tick_count
        catch_tick_count += 1
        if catch_tick_count == 1:
            return "RUNNING"
        return "FAILURE"

    bt.register_simple_condition("RunningThenFailure", running_then_failure)

    xml_text = """
    <root BTCPP_format="4">
       <BehaviorTree>
          <TryCatch>
            <AlwaysFailure/>       <!-- try fails -->
            <RunningThenFailure/>  <!-- catch: RUNNING first, then FAILURE -->
          </TryCatch>
       </BehaviorTree>
    </root>"""
    tree = bt.load(xml_text)

    # First tick: try fails, catch starts and returns RUNNING
    status = tree.tick_once()
    assert status == "RUNNING"

    # Second tick: catch returns FAILURE, TryCatch returns FAILURE
    status = tree.tick_while_running()
    assert status == "FAILURE"


@TEST("TryCatchTest.MinimumTwoChildren_ParseTimeValidation")
def test_minimum_two_children_parse_time_validation(bt):
    xml_text = """
    <root BTCPP_format="4">
       <BehaviorTree>
          <TryCatch>
            <AlwaysSuccess/>
          </TryCatch>
       </BehaviorTree>
    </root>"""
    # Error should be caught at parse time, not tick time (BT.CPP: BT::RuntimeError from createTreeFromText)
    with pytest.raises(TreeError):
        bt.load(xml_text)


@TEST("TryCatchTest.ReExecuteAfterSuccess")
def test_re_execute_after_success(bt):
    xml_text = """
    <root BTCPP_format="4">
       <BehaviorTree>
          <TryCatch>
            <TestA/>
            <TestB/>  <!-- catch -->
          </TryCatch>
       </BehaviorTree>
    </root>"""
    tree = bt.load(xml_text)

    status = tree.tick_while_running()
    assert status == "SUCCESS"
    assert bt.counters[0] == 1

    tree.halt()
    status = tree.tick_while_running()
    assert status == "SUCCESS"
    assert bt.counters[0] == 2  # TestA executed again
    assert bt.counters[1] == 0  # Catch still never executed


@TEST("TryCatchTest.ReExecuteAfterFailure")
def test_re_execute_after_failure(bt):
    try_tick_count = 0

    def fail_then_succeed(_node):
        nonlocal try_tick_count
        try_tick_count += 1
        if try_tick_count == 1:
            return "FAILURE"
        return "SUCCESS"

    bt.register_simple_action("FailThenSucceed", fail_then_succeed)

    xml_text = """
    <root BTCPP_format="4">
       <BehaviorTree>
          <TryCatch>
            <FailThenSucceed/>
            <TestA/>  <!-- catch -->
          </TryCatch>
       </BehaviorTree>
    </root>"""
    tree = bt.load(xml_text)

    # First execution: try fails, catch runs
    status = tree.tick_while_running()
    assert status == "FAILURE"
    assert bt.counters[0] == 1  # Catch executed

    # Second execution: try succeeds
    tree.halt()
    status = tree.tick_while_running()
    assert status == "SUCCESS"
    assert bt.counters[0] == 1  # Catch not executed again


def register_catch_and_running(bt):
    """CountCatch (counts, SUCCESS) and AlwaysRunning (a condition that counts and stays RUNNING), as the
    CatchOnHalt TESTs register them; returns [catch_count, try_ticks]."""
    counts = [0, 0]

    def count_catch(_node):
        counts[0] += 1
        return "SUCCESS"

    def always_running(_node):
        counts[1] += 1
        return "RUNNING"

    bt.register_simple_action("CountCatch", count_catch)
    bt.register_simple_condition("AlwaysRunning", always_running)
    return counts


@TEST("TryCatchTest.CatchOnHalt_Disabled")
def test_catch_on_halt_disabled(bt):
    counts = register_catch_and_running(bt)

    xml_text = """
    <root BTCPP_format="4">
       <BehaviorTree>
          <TryCatch>
            <AlwaysRunning/>
            <CountCatch/>  <!-- catch -->
          </TryCatch>
       </BehaviorTree>
    </root>"""
    tree = bt.load(xml_text)

    status = tree.tick_once()
    assert status == "RUNNING"

    # Halt while try-block is RUNNING; catch_on_halt defaults to false
    tree.halt()
    assert counts[0] == 0  # Catch NOT executed on halt


@TEST("TryCatchTest.CatchOnHalt_Enabled")
def test_catch_on_halt_enabled(bt):
    counts = register_catch_and_running(bt)

    xml_text = """
    <root BTCPP_format="4">
       <BehaviorTree>
          <TryCatch catch_on_halt="true">
            <AlwaysRunning/>
            <CountCatch/>  <!-- catch -->
          </TryCatch>
       </BehaviorTree>
    </root>"""
    tree = bt.load(xml_text)

    status = tree.tick_once()
    assert status == "RUNNING"

    # Halt while try-block is RUNNING; catch_on_halt is true
    tree.halt()
    assert counts[0] == 1  # Catch executed on halt


@TEST("TryCatchTest.CatchOnHalt_NotTriggeredWhenAlreadyInCatch")
def test_catch_on_halt_not_triggered_when_already_in_catch(bt):
    catch_ticks = 0

    def running_catch(_node):
        nonlocal catch_ticks
        catch_ticks += 1
        return "RUNNING"

    bt.register_simple_condition("RunningCatch", running_catch)

    xml_text = """
    <root BTCPP_format="4">
       <BehaviorTree>
          <TryCatch catch_on_halt="true">
            <AlwaysFailure/>  <!-- try fails immediately -->
            <RunningCatch/>   <!-- catch returns RUNNING -->
          </TryCatch>
       </BehaviorTree>
    </root>"""
    tree = bt.load(xml_text)

    # First tick: try fails, enters catch, catch returns RUNNING
    status = tree.tick_once()
    assert status == "RUNNING"
    assert catch_ticks == 1

    # Halt while in catch mode: should NOT re-trigger catch
    tree.halt()
    assert catch_ticks == 1  # Catch NOT ticked again


@TEST("TryCatchTest.AsyncCatchCompletesInsideSequence")
def test_async_catch_completes_inside_sequence(bt):
    # The catch child returns RUNNING for 5 ticks, then SUCCESS.
    # Verify that the Sequence keeps ticking TryCatch, which keeps
    # ticking the catch child until it completes.
    k_running_ticks = 5
    catch_ticks = 0

    def async_cleanup(_node):
        nonlocal catch_ticks
        catch_ticks += 1
        if catch_ticks <= k_running_ticks:
            return "RUNNING"
        return "SUCCESS"

    bt.register_simple_condition("AsyncCleanup", async_cleanup)

    xml_text = """
    <root BTCPP_format="4">
       <BehaviorTree>
          <Sequence>
            <TryCatch>
              <AlwaysFailure/>    <!-- try: fails immediately -->
              <AsyncCleanup/>     <!-- catch: RUNNING for 5 ticks, then SUCCESS -->
            </TryCatch>
            <TestA/>              <!-- should NOT execute: TryCatch returns FAILURE -->
          </Sequence>
       </BehaviorTree>
    </root>"""
    tree = bt.load(xml_text)

    # Tick-by-tick: the tree should stay RUNNING while catch is async
    for i in range(k_running_ticks):
        status = tree.tick_once()
        assert status == "RUNNING", f"Expected RUNNING on tick {i + 1}"
        assert catch_ticks == i + 1

    # Next tick: catch completes → TryCatch returns FAILURE → Sequence returns FAILURE
    status = tree.tick_once()
    assert status == "FAILURE"

    # Catch child was ticked exactly kRunningTicks + 1 times (5 RUNNING + 1 SUCCESS)
    assert catch_ticks == k_running_ticks + 1

    # TestA was never reached because TryCatch returned FAILURE
    assert bt.counters[0] == 0


@TEST("TryCatchTest.SingleTryChild_Success")
def test_single_try_child_success(bt):
    xml_text = """
    <root BTCPP_format="4">
       <BehaviorTree>
          <TryCatch>
            <TestA/>   <!-- single try child -->
            <TestB/>   <!-- catch -->
          </TryCatch>
       </BehaviorTree>
    </root>"""
    tree = bt.load(xml_text)
    status = tree.tick_while_running()
    assert status == "SUCCESS"
    assert bt.counters[0] == 1
    assert bt.counters[1] == 0


@TEST("TryCatchTest.ManyTryChildren_ThirdFails")
def test_many_try_children_third_fails(bt):
    xml_text = """
    <root BTCPP_format="4">
       <BehaviorTree>
          <TryCatch>
            <TestA/>
            <TestB/>
            <AlwaysFailure/>
            <TestC/>  <!-- catch -->
          </TryCatch>
       </BehaviorTree>
    </root>"""
    tree = bt.load(xml_text)
    status = tree.tick_while_running()
    assert status == "FAILURE"
    assert bt.counters[0] == 1  # TestA executed
    assert bt.counters[1] == 1  # TestB executed
    assert bt.counters[2] == 1  # TestC (catch) executed
