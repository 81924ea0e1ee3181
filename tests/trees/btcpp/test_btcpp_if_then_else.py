"""BehaviorTree.CPP 4.10 tests/gtest_if_then_else.cpp, translated (XML verbatim; see btcpp_harness.py)."""

from __future__ import annotations

import pytest

from tests.trees.btcpp.btcpp_harness import TEST, Harness

#: TESTs of this file that only use the C++ API, and why they are not translated
SKIPPED: dict[str, str] = {}


@pytest.fixture
def bt(tmp_path):
    """IfThenElseTest's fixture: RegisterTestTick(factory, "Test", counters) with 4 counters."""
    harness = Harness(tmp_path)
    harness.counters = harness.register_test_tick("Test", 4)
    return harness


@TEST("IfThenElseTest.ConditionTrue_ThenBranch")
def test_condition_true_then_branch(bt):
    # When condition is true, execute the "then" branch
    xml_text = """
    <root BTCPP_format="4">
       <BehaviorTree>
          <IfThenElse>
            <AlwaysSuccess/>  <!-- condition -->
            <TestA/>          <!-- then -->
            <TestB/>          <!-- else -->
          </IfThenElse>
       </BehaviorTree>
    </root>"""
    tree = bt.load(xml_text)
    status = tree.tick_while_running()
    assert status == "SUCCESS"
    assert bt.counters[0] == 1  # TestA executed
    assert bt.counters[1] == 0  # TestB not executed


@TEST("IfThenElseTest.ConditionFalse_ElseBranch")
def test_condition_false_else_branch(bt):
    # When condition is false, execute the "else" branch
    xml_text = """
    <root BTCPP_format="4">
       <BehaviorTree>
          <IfThenElse>
            <AlwaysFailure/>  <!-- condition -->
            <TestA/>          <!-- then -->
            <TestB/>          <!-- else -->
          </IfThenElse>
       </BehaviorTree>
    </root>"""
    tree = bt.load(xml_text)
    status = tree.tick_while_running()
    assert status == "SUCCESS"
    assert bt.counters[0] == 0  # TestA not executed
    assert bt.counters[1] == 1  # TestB executed


@TEST("IfThenElseTest.ConditionFalse_TwoChildren_ReturnsFailure")
def test_condition_false_two_children_returns_failure(bt):
    # With only 2 children and condition false, return FAILURE
    xml_text = """
    <root BTCPP_format="4">
       <BehaviorTree>
          <IfThenElse>
            <AlwaysFailure/>  <!-- condition -->
            <TestA/>          <!-- then -->
          </IfThenElse>
       </BehaviorTree>
    </root>"""
    tree = bt.load(xml_text)
    status = tree.tick_while_running()
    assert status == "FAILURE"
    assert bt.counters[0] == 0  # TestA not executed


@TEST("IfThenElseTest.ThenBranchFails")
def test_then_branch_fails(bt):
    # When then-branch fails, IfThenElse returns FAILURE
    xml_text = """
    <root BTCPP_format="4">
       <BehaviorTree>
          <IfThenElse>
            <AlwaysSuccess/>  <!-- condition -->
            <AlwaysFailure/>  <!-- then -->
            <TestA/>          <!-- else -->
          </IfThenElse>
       </BehaviorTree>
    </root>"""
    tree = bt.load(xml_text)
    status = tree.tick_while_running()
    assert status == "FAILURE"
    assert bt.counters[0] == 0  # TestA (else) not executed


@TEST("IfThenElseTest.ElseBranchFails")
def test_else_branch_fails(bt):
    # When else-branch fails, IfThenElse returns FAILURE
    xml_text = """
    <root BTCPP_format="4">
       <BehaviorTree>
          <IfThenElse>
            <AlwaysFailure/>  <!-- condition -->
            <TestA/>          <!-- then -->
            <AlwaysFailure/>  <!-- else -->
          </IfThenElse>
       </BehaviorTree>
    </root>"""
    tree = bt.load(xml_text)
    status = tree.tick_while_running()
    assert status == "FAILURE"
    assert bt.counters[0] == 0  # TestA (then) not executed


@TEST("IfThenElseTest.ConditionRunning")
def test_condition_running(bt):
    # Test condition that returns RUNNING first, then SUCCESS
    condition_ticks = 0

    def running_then_success(_node):
        nonlocal condition_ticks
        condition_ticks += 1
        if condition_ticks == 1:
            return "RUNNING"
        return "SUCCESS"

    bt.register_simple_condition("RunningThenSuccess", running_then_success)

    xml_text = """
    <root BTCPP_format="4">
       <BehaviorTree>
          <IfThenElse>
            <RunningThenSuccess/>
            <TestA/>
            <TestB/>
          </IfThenElse>
       </BehaviorTree>
    </root>"""
    tree = bt.load(xml_text)

    # First tick - condition returns RUNNING
    status = tree.tick_once()
    assert status == "RUNNING"
    assert bt.counters[0] == 0  # TestA not executed yet

    # Second tick - condition returns SUCCESS, then-branch executes
    status = tree.tick_while_running()
    assert status == "SUCCESS"
    assert bt.counters[0] == 1  # TestA executed


@TEST("IfThenElseTest.HaltBehavior")
def test_halt_behavior(bt):
    # Test that halt resets the node properly
    xml_text = """
    <root BTCPP_format="4">
       <BehaviorTree>
          <IfThenElse>
            <AlwaysSuccess/>
            <TestA/>
            <TestB/>
          </IfThenElse>
       </BehaviorTree>
    </root>"""
    tree = bt.load(xml_text)

    # First execution
    status = tree.tick_while_running()
    assert status == "SUCCESS"
    assert bt.counters[0] == 1

    # Halt and re-execute
    tree.halt()
    status = tree.tick_while_running()
    assert status == "SUCCESS"
    assert bt.counters[0] == 2  # TestA executed again


@TEST("IfThenElseTest.InvalidChildCount_One")
def test_invalid_child_count_one(bt):
    # IfThenElse with only 1 child should throw
    xml_text = """
    <root BTCPP_format="4">
       <BehaviorTree>
          <IfThenElse>
            <AlwaysSuccess/>
          </IfThenElse>
       </BehaviorTree>
    </root>"""
    # BT.CPP creates the tree and throws (LogicError wrapped in NodeExecutionError) on the first tick;
    # our loader refuses the child count when loading
    bt.raises_by_first_tick(xml_text)


@TEST("IfThenElseTest.InvalidChildCount_Four")
def test_invalid_child_count_four(bt):
    # IfThenElse with 4 children should throw
    xml_text = """
    <root BTCPP_format="4">
       <BehaviorTree>
          <IfThenElse>
            <AlwaysSuccess/>
            <TestA/>
            <TestB/>
            <TestC/>
          </IfThenElse>
       </BehaviorTree>
    </root>"""
    # BT.CPP creates the tree and throws (LogicError wrapped in NodeExecutionError) on the first tick;
    # our loader refuses the child count when loading
    bt.raises_by_first_tick(xml_text)
