"""BehaviorTree.CPP 4.10 tests/gtest_skipping.cpp, translated (XML verbatim; see btcpp_harness.py)."""

from __future__ import annotations

import time

import pytest

from tests.trees.btcpp.btcpp_harness import TEST, Harness

#: TESTs of this file that only use the C++ API, and why they are not translated
SKIPPED: dict[str, str] = {}


@pytest.fixture
def bt(tmp_path):
    """BehaviorTreeFactory factory;"""
    return Harness(tmp_path)


@TEST("SkippingLogic.Sequence")
def test_skipping_logic_sequence(bt):
    counters = bt.register_test_tick("Test", 2)

    xml_text = """

    <root BTCPP_format="4" >
        <BehaviorTree ID="MainTree">
            <Sequence>
                <Script code = "A:=1"/>
                <TestA _successIf="A==2" _failureIf="A!=1" _skipIf="A==1"/>
                <TestB/>
            </Sequence>
        </BehaviorTree>
    </root>"""

    tree = bt.load(xml_text)
    status = tree.tick_while_running()
    assert status == "SUCCESS"
    assert counters[0] == 0
    assert counters[1] == 1


@TEST("SkippingLogic.SkipAll")
def test_skipping_logic_skip_all(bt):
    counters = bt.register_test_tick("Test", 3)

    xml_text = """

    <root BTCPP_format="4" >
        <BehaviorTree ID="MainTree">
            <Sequence>
                <TestA _skipIf="A==1"/>
                <TestB _skipIf="A<2"/>
                <TestC _skipIf="A>0"/>
            </Sequence>
        </BehaviorTree>
    </root>"""

    tree = bt.load(xml_text)
    tree.set("A", 1)

    status = tree.tick_while_running()
    assert counters[0] == 0
    assert counters[1] == 0
    assert counters[2] == 0
    assert status == "SKIPPED"


@TEST("SkippingLogic.SkipSubtree")
def test_skipping_logic_skip_subtree(bt):
    counters = bt.register_test_tick("Test", 3)

    xml_text = """

    <root BTCPP_format="4" >
        <BehaviorTree ID="main">
            <Sequence>
                <TestA/>
                <Script code=" data:=true "/>
                <SubTree ID="sub" _skipIf="data"/>
            </Sequence>
        </BehaviorTree>

        <BehaviorTree ID="sub">
            <TestB/>
        </BehaviorTree>
    </root>"""

    bt.register_tree_text(xml_text)
    tree = bt.load(main_tree="main")

    tree.set("A", 1)

    status = tree.tick_while_running()
    assert counters[0] == 1
    assert counters[1] == 0
    assert status == "SUCCESS"


@TEST("SkippingLogic.ReactiveSingleChild")
def test_skipping_logic_reactive_single_child(bt):
    xml_text = """
    <root BTCPP_format="4">
      <BehaviorTree ID="Untitled">
        <ReactiveSequence>
          <AlwaysSuccess _skipIf="flag"/>
        </ReactiveSequence>
      </BehaviorTree>
    </root>
 """

    # auto root_blackboard = BT::Blackboard::create(); root_blackboard->set<bool>("flag", true);
    # createTreeFromText(xml_text, root_blackboard): the tree's root blackboard holds flag=true before any tick
    tree = bt.load(xml_text)
    tree.set("flag", True)

    tree.tick_while_running()  # must not throw


@TEST("SkippingLogic.SkippingReactiveSequence")
def test_skipping_logic_skipping_reactive_sequence(bt):
    counters = bt.register_test_tick("Test", 2)

    xml_text_noskip = """
    <root BTCPP_format="4" >
       <BehaviorTree>
          <ReactiveSequence>
            <Script code=" value:=50 "/>
            <TestA _skipIf="value < 25"/>
            <AsyncActionTest/>
          </ReactiveSequence>
       </BehaviorTree>
    </root>"""

    xml_text_skip = """
    <root BTCPP_format="4" >
       <BehaviorTree>
          <ReactiveSequence>
            <Script code=" value:=10 "/>
            <TestB _skipIf="value < 25"/>
            <AsyncActionTest/>
          </ReactiveSequence>
       </BehaviorTree>
    </root>"""

    # AsyncActionTest (tests/include/action_test_node.h): RUNNING for 100 ms (its default deadline), then SUCCESS
    bt.register_test_nodes("AsyncActionTest", time_s=0.1)

    expected_test_a_ticks = 0

    for xml_text in (xml_text_noskip, xml_text_skip):
        tree = bt.load(xml_text)

        for _repeat in range(3):
            status = "IDLE"
            ticks = 0  # not in the C++ TEST: fail rather than loop for ever
            while status not in ("SUCCESS", "FAILURE"):
                ticks += 1
                assert ticks < 1000, f"still {status} after {ticks} ticks"
                status = tree.tick_once()

                if xml_text is xml_text_noskip:
                    expected_test_a_ticks += 1

                time.sleep(0.015)  # tree.sleep(std::chrono::milliseconds{ 15 });
            assert status == "SUCCESS"
    # counters[0] contains the number of times TestA was ticked
    assert counters[0] == expected_test_a_ticks

    # counters[1] contains the number of times TestB was ticked
    assert counters[1] == 0


@TEST("SkippingLogic.WhileSkip")
def test_skipping_logic_while_skip(bt):
    counters = bt.register_test_tick("Test", 2)

    xml_text_noskip = """
    <root BTCPP_format="4" >
       <BehaviorTree>
          <Sequence>
            <Script code=" doit:=true "/>
            <Sequence>
              <TestA _while="doit"/>
            </Sequence>
          </Sequence>
       </BehaviorTree>
    </root>"""

    xml_text_skip = """
    <root BTCPP_format="4" >
       <BehaviorTree>
          <Sequence>
            <Script code=" doit:=false "/>
            <Sequence>
              <TestB _while="doit"/>
            </Sequence>
          </Sequence>
       </BehaviorTree>
    </root>"""

    for xml_text in (xml_text_noskip, xml_text_skip):
        tree = bt.load(xml_text)
        status = tree.tick_while_running()
        assert status == "SUCCESS"
    # counters[0] contains the number of times TestA was ticked
    assert counters[0] == 1

    # counters[1] contains the number of times TestB was ticked
    assert counters[1] == 0
