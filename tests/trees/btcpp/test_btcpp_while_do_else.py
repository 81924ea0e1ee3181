"""BehaviorTree.CPP 4.10 tests/gtest_while_do_else.cpp, translated (XML verbatim; see btcpp_harness.py)."""

from __future__ import annotations

import pytest

from tests.trees.btcpp.btcpp_harness import TEST, Harness

#: TESTs of this file that only use the C++ API, and why they are not translated
SKIPPED: dict[str, str] = {}


@pytest.fixture
def bt(tmp_path):
    """WhileDoElseTest's fixture: RegisterTestTick(factory, "Test", counters) with 4 counters."""
    harness = Harness(tmp_path)
    harness.counters = harness.register_test_tick("Test", 4)
    return harness


@TEST("WhileDoElseTest.ConditionTrue_DoBranch")
def test_condition_true_do_branch(bt):
    # When condition is true, execute the "do" branch
    xml_text = """
    <root BTCPP_format="4">
       <BehaviorTree>
          <WhileDoElse>
            <AlwaysSuccess/>  <!-- condition -->
            <TestA/>          <!-- do -->
            <TestB/>          <!-- else -->
          </WhileDoElse>
       </BehaviorTree>
    </root>"""
    tree = bt.load(xml_text)
    status = tree.tick_while_running()
    assert status == "SUCCESS"
    assert bt.counters[0] == 1  # TestA executed
    assert bt.counters[1] == 0  # TestB not executed


@TEST("WhileDoElseTest.ConditionFalse_ElseBranch")
def test_condition_false_else_branch(bt):
    # When condition is false, execute the "else" branch
    xml_text = """
    <root BTCPP_format="4">
       <BehaviorTree>
          <WhileDoElse>
            <AlwaysFailure/>  <!-- condition -->
            <TestA/>          <!-- do -->
            <TestB/>          <!-- else -->
          </WhileDoElse>
       </BehaviorTree>
    </root>"""
    tree = bt.load(xml_text)
    status = tree.tick_while_running()
    assert status == "SUCCESS"
    assert bt.counters[0] == 0  # TestA not executed
    assert bt.counters[1] == 1  # TestB executed


@TEST("WhileDoElseTest.ConditionFalse_TwoChildren_ReturnsFailure")
def test_condition_false_two_children_returns_failure(bt):
    # With only 2 children and condition false, return FAILURE
    xml_text = """
    <root BTCPP_format="4">
       <BehaviorTree>
          <WhileDoElse>
            <AlwaysFailure/>  <!-- condition -->
            <TestA/>          <!-- do -->
          </WhileDoElse>
       </BehaviorTree>
    </root>"""
    tree = bt.load(xml_text)
    status = tree.tick_while_running()
    assert status == "FAILURE"
    assert bt.counters[0] == 0  # TestA not executed


@TEST("WhileDoElseTest.DoBranchFails")
def test_do_branch_fails(bt):
    # When do-branch fails, WhileDoElse returns FAILURE
    xml_text = """
    <root BTCPP_format="4">
       <BehaviorTree>
          <WhileDoElse>
            <AlwaysSuccess/>  <!-- condition -->
            <AlwaysFailure/>  <!-- do -->
            <TestA/>          <!-- else -->
          </WhileDoElse>
       </BehaviorTree>
    </root>"""
    tree = bt.load(xml_text)
    status = tree.tick_while_running()
    assert status == "FAILURE"
    assert bt.counters[0] == 0  # TestA (else) not executed


@TEST("WhileDoElseTest.ElseBranchFails")
def test_else_branch_fails(bt):
    # When else-branch fails, WhileDoElse returns FAILURE
    xml_text = """
    <root BTCPP_format="4">
       <BehaviorTree>
          <WhileDoElse>
            <AlwaysFailure/>  <!-- condition -->
            <TestA/>          <!-- do -->
            <AlwaysFailure/>  <!-- else -->
          </WhileDoElse>
       </BehaviorTree>
    </root>"""
    tree = bt.load(xml_text)
    status = tree.tick_while_running()
    assert status == "FAILURE"
    assert bt.counters[0] == 0  # TestA (do) not executed


@TEST("WhileDoElseTest.ConditionChanges_HaltsElse")
def test_condition_changes_halts_else(bt):
    # When condition changes from false to true, else branch should be halted
    condition_counter = 0

    def toggle_condition(_node):
        nonlocal condition_counter
        first = condition_counter == 0
        condition_counter += 1
        return "FAILURE" if first else "SUCCESS"

    bt.register_simple_condition("ToggleCondition", toggle_condition)

    xml_text = """
    <root BTCPP_format="4">
       <BehaviorTree>
          <WhileDoElse>
            <ToggleCondition/>
            <TestA/>
            <TestB/>
          </WhileDoElse>
       </BehaviorTree>
    </root>"""
    tree = bt.load(xml_text)

    # First tick - condition false, executes else (TestB)
    status = tree.tick_while_running()
    assert status == "SUCCESS"
    assert bt.counters[0] == 0  # TestA not executed
    assert bt.counters[1] == 1  # TestB executed


@TEST("WhileDoElseTest.ConditionChanges_HaltsDo")
def test_condition_changes_halts_do(bt):
    # When condition changes from true to false, do branch should be halted
    condition_counter = 0

    def toggle_condition2(_node):
        nonlocal condition_counter
        first = condition_counter == 0
        condition_counter += 1
        return "SUCCESS" if first else "FAILURE"

    bt.register_simple_condition("ToggleCondition2", toggle_condition2)

    xml_text = """
    <root BTCPP_format="4">
       <BehaviorTree>
          <WhileDoElse>
            <ToggleCondition2/>
            <TestA/>
            <TestB/>
          </WhileDoElse>
       </BehaviorTree>
    </root>"""
    tree = bt.load(xml_text)

    # First tick - condition true, executes do (TestA)
    status = tree.tick_while_running()
    assert status == "SUCCESS"
    assert bt.counters[0] == 1  # TestA executed
    assert bt.counters[1] == 0  # TestB not executed


@TEST("WhileDoElseTest.HaltBehavior")
def test_halt_behavior(bt):
    # Test that halt resets the node properly
    xml_text = """
    <root BTCPP_format="4">
       <BehaviorTree>
          <WhileDoElse>
            <AlwaysSuccess/>
            <TestA/>
            <TestB/>
          </WhileDoElse>
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


@TEST("WhileDoElseTest.InvalidChildCount_One")
def test_invalid_child_count_one(bt):
    # WhileDoElse with only 1 child should throw
    xml_text = """
    <root BTCPP_format="4">
       <BehaviorTree>
          <WhileDoElse>
            <AlwaysSuccess/>
          </WhileDoElse>
       </BehaviorTree>
    </root>"""
    # BT.CPP creates the tree and throws (LogicError wrapped in NodeExecutionError) on the first tick;
    # our loader refuses the child count when loading
    bt.raises_by_first_tick(xml_text)


@TEST("WhileDoElseTest.InvalidChildCount_Four")
def test_invalid_child_count_four(bt):
    # WhileDoElse with 4 children should throw
    xml_text = """
    <root BTCPP_format="4">
       <BehaviorTree>
          <WhileDoElse>
            <AlwaysSuccess/>
            <TestA/>
            <TestB/>
            <TestC/>
          </WhileDoElse>
       </BehaviorTree>
    </root>"""
    # BT.CPP creates the tree and throws (LogicError wrapped in NodeExecutionError) on the first tick;
    # our loader refuses the child count when loading
    bt.raises_by_first_tick(xml_text)


@TEST("WhileDoElseTest.ConditionRunning")
def test_condition_running(bt):
    # Test behavior when condition returns RUNNING
    first_tick = True

    def running_then_success(_node):
        nonlocal first_tick
        if first_tick:
            first_tick = False
            return "RUNNING"
        return "SUCCESS"

    bt.register_simple_condition("RunningThenSuccess", running_then_success)

    xml_text = """
    <root BTCPP_format="4">
       <BehaviorTree>
          <WhileDoElse>
            <RunningThenSuccess/>
            <TestA/>
            <TestB/>
          </WhileDoElse>
       </BehaviorTree>
    </root>"""
    tree = bt.load(xml_text)

    # First tick - condition returns RUNNING
    status = tree.tick_once()
    assert status == "RUNNING"
    assert bt.counters[0] == 0  # TestA not executed yet
    assert bt.counters[1] == 0  # TestB not executed yet

    # Second tick - condition returns SUCCESS, executes do branch
    status = tree.tick_while_running()
    assert status == "SUCCESS"
    assert bt.counters[0] == 1  # TestA executed
