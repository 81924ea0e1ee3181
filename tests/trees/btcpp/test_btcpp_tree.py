"""BehaviorTree.CPP 4.10 tests/gtest_tree.cpp, translated (XML verbatim; see btcpp_harness.py).

The fixture BehaviorTreeTest builds its tree with the C++ API (SequenceNode, FallbackNode, ConditionTestNode,
AsyncActionTest; addChild), without XML: nothing to translate.
"""

from __future__ import annotations

#: TESTs of this file that only use the C++ API, and why they are not translated
SKIPPED: dict[str, str] = {
    "BehaviorTreeTest.Condition1ToFalseCondition2True": (
        "the fixture builds Sequence(Fallback(ConditionTestNode x2), AsyncActionTest) with the C++ API "
        "(addChild, root.executeTick()), no XML"
    ),
    "BehaviorTreeTest.Condition2ToFalseCondition1True": (
        "the fixture builds Sequence(Fallback(ConditionTestNode x2), AsyncActionTest) with the C++ API "
        "(addChild, root.executeTick()), no XML"
    ),
    "BehaviorTreeTest.PrintWithStream": (
        "tests BT::printTreeRecursively() C++ output (std::ostream) on a tree built with addChild, no XML"
    ),
}
