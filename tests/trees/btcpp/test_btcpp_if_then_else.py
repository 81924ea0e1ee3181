"""BehaviorTree.CPP 4.10 tests/gtest_if_then_else.cpp, translated (XML verbatim; see btcpp_harness.py)."""

from __future__ import annotations

import pytest
from btcpp_harness import TEST, Harness

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
