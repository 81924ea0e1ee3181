"""BehaviorTree.CPP 4.10 tests/gtest_sequence.cpp, translated (XML verbatim; see btcpp_harness.py).

All fixtures of this file build their trees with the C++ API (SequenceNode, ReactiveSequence,
SequenceWithMemory with ConditionTestNode / AsyncActionTest / SyncActionTest children; addChild,
root.executeTick()), without XML; only SequenceWithMemoryTest.Issue_636 loads XML.
"""

from __future__ import annotations

from tests.trees.btcpp.btcpp_harness import TEST, Harness

_SIMPLE = "the fixture builds Sequence(ConditionTestNode, AsyncActionTest) with the C++ API (addChild), no XML"
_COMPLEX = (
    "the fixture builds ReactiveSequence(Sequence(ConditionTestNode x2), AsyncActionTest) with the C++ API "
    "(addChild), no XML"
)
_MEMORY = (
    "the fixture builds SequenceWithMemory(ConditionTestNode, AsyncActionTest) with the C++ API (addChild), no XML"
)
_COMPLEX_MEMORY = (
    "the fixture builds SequenceWithMemory(SequenceWithMemory(ConditionTestNode x2), "
    "SequenceWithMemory(AsyncActionTest x2)) with the C++ API (addChild), no XML"
)

#: TESTs of this file that only use the C++ API, and why they are not translated
SKIPPED: dict[str, str] = {
    "SimpleSequenceTest.ConditionTrue": _SIMPLE,
    "SimpleSequenceTest.ConditionTurnToFalse": _SIMPLE,
    "ComplexSequenceTest.ComplexSequenceConditionsTrue": _COMPLEX,
    "SequenceTripleActionTest.TripleAction": (
        "the fixture builds Sequence(ConditionTestNode, AsyncActionTest, SyncActionTest, AsyncActionTest) with "
        "the C++ API (addChild), no XML"
    ),
    "ComplexSequence2ActionsTest.ConditionsTrue": (
        "the fixture builds Sequence(Sequence(ConditionTestNode, AsyncActionTest) x2) with the C++ API "
        "(addChild), no XML"
    ),
    "ComplexSequenceTest.ComplexSequenceConditions1ToFalse": _COMPLEX,
    "ComplexSequenceTest.ComplexSequenceConditions2ToFalse": _COMPLEX,
    "SimpleSequenceWithMemoryTest.ConditionTrue": _MEMORY,
    "SimpleSequenceWithMemoryTest.ConditionTurnToFalse": _MEMORY,
    "ComplexSequenceWithMemoryTest.ConditionsTrue": _COMPLEX_MEMORY,
    "ComplexSequenceWithMemoryTest.Conditions1ToFalse": _COMPLEX_MEMORY,
}


@TEST("SequenceWithMemoryTest.Issue_636")
def test_issue_636(tmp_path):
    xml_text = """

<root BTCPP_format="4" main_tree_to_execute="MainTree" >

    <BehaviorTree ID="MainTree">
        <SequenceWithMemory>
            <Script code = " var := 0 " />
            <TestA/>
            <ScriptCondition code = "var+=1; var >= 5" />
            <TestB/>
            <TestC/>
        </SequenceWithMemory>
    </BehaviorTree>
</root> """

    bt = Harness(tmp_path)

    counters = bt.register_test_tick("Test", 3)

    tree = bt.load(xml_text)

    res = tree.tick_once()
    tick_count = 1

    while res != "SUCCESS":
        res = tree.tick_once()
        tick_count += 1

    assert counters[0] == 1
    assert counters[1] == 1
    assert counters[2] == 1

    assert tick_count == 5
