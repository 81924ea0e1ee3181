"""BehaviorTree.CPP 4.10 tests/gtest_postconditions.cpp, translated (XML verbatim; see btcpp_harness.py)."""

from __future__ import annotations

import pytest

from tests.trees.btcpp.btcpp_harness import TEST, Harness

#: TESTs of this file that only use the C++ API, and why they are not translated
SKIPPED: dict[str, str] = {}


@pytest.fixture
def bt(tmp_path):
    """BehaviorTreeFactory factory;"""
    return Harness(tmp_path)


@TEST("PostConditions.BasicTest")
def test_post_conditions_basic_test(bt):
    xml_text = """

    <root BTCPP_format="4" >
        <BehaviorTree ID="MainTree">
            <Sequence>
                <Script code = "A:=1; B:=1; C:=1; D:=1" />

                <AlwaysSuccess _onSuccess="B=42"/>

                <ForceSuccess>
                    <AlwaysSuccess _failureIf="A!=0" _onFailure="C=42"/>
                </ForceSuccess>

                <ForceSuccess>
                    <AlwaysFailure _onFailure="D=42"/>
                </ForceSuccess>
            </Sequence>
        </BehaviorTree>
    </root>"""

    tree = bt.load(xml_text)
    status = tree.tick_while_running()
    assert status == "SUCCESS"

    assert tree.get("B") == 42
    assert tree.get("C") == 42
    assert tree.get("D") == 42


@TEST("PostConditions.Issue539")
def test_post_conditions_issue539(bt):
    xml_text = """
    <root BTCPP_format="4" >
      <BehaviorTree ID="MainTree">
        <Sequence>
          <Script code = "x:=0; y:=0" />
          <RetryUntilSuccessful num_attempts="5">
            <AlwaysFailure _onFailure="x  += 1"  _post="y  += 1" />
          </RetryUntilSuccessful>
        </Sequence>
      </BehaviorTree>
    </root>"""

    tree = bt.load(xml_text)
    status = tree.tick_while_running()
    assert status == "FAILURE"

    assert tree.get("x") == 5
    assert tree.get("y") == 5


@TEST("PostConditions.Issue601")
def test_post_conditions_issue601(bt):
    xml_text = """
  <root BTCPP_format="4" >
    <BehaviorTree ID="test_tree">
      <Sequence>
        <Script code="test := 'start'"/>
          <Parallel failure_count="1"
                    success_count="-1">
            <Sleep msec="1000"
                   _onHalted="test = 'halted'"
                   _post="test = 'post'"/>
            <AlwaysFailure/>
          </Parallel>
      </Sequence>
    </BehaviorTree>
  </root>"""

    tree = bt.load(xml_text)
    tree.tick_while_running()

    assert tree.get("test") == "halted"
