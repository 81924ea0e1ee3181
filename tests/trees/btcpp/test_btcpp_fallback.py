"""BehaviorTree.CPP 4.10 tests/gtest_fallback.cpp, translated (XML verbatim; see btcpp_harness.py).

Every fixture of this file builds its tree with the C++ API (FallbackNode / ReactiveFallback with
ConditionTestNode and AsyncActionTest children; addChild, root.executeTick()), without XML: nothing to translate.
"""

from __future__ import annotations

_SIMPLE = "the fixture builds Fallback(ConditionTestNode, AsyncActionTest) with the C++ API (addChild), no XML"
_REACTIVE = (
    "the fixture builds ReactiveFallback(ConditionTestNode x2, AsyncActionTest) with the C++ API (addChild), no XML"
)
_COMPLEX = (
    "the fixture builds Fallback(Fallback(ConditionTestNode x2), Fallback(AsyncActionTest x2)) with the C++ API "
    "(addChild), no XML"
)

#: TESTs of this file that only use the C++ API, and why they are not translated
SKIPPED: dict[str, str] = {
    "SimpleFallbackTest.ConditionTrue": _SIMPLE,
    "SimpleFallbackTest.ConditionChangeWhileRunning": _SIMPLE,
    "ReactiveFallbackTest.Condition1ToTrue": _REACTIVE,
    "ReactiveFallbackTest.Condition2ToTrue": _REACTIVE,
    "SimpleFallbackWithMemoryTest.ConditionFalse": _SIMPLE,
    "SimpleFallbackWithMemoryTest.ConditionTurnToTrue": _SIMPLE,
    "ComplexFallbackWithMemoryTest.ConditionsTrue": _COMPLEX,
    "ComplexFallbackWithMemoryTest.Condition1False": _COMPLEX,
    "ComplexFallbackWithMemoryTest.ConditionsFalse": _COMPLEX,
    "ComplexFallbackWithMemoryTest.Conditions1ToTrue": _COMPLEX,
    "ComplexFallbackWithMemoryTest.Conditions2ToTrue": _COMPLEX,
    "ComplexFallbackWithMemoryTest.Action1Failed": _COMPLEX,
}
