"""BehaviorTree.CPP 4.10 tests/gtest_coroutines.cpp, translated (XML verbatim; see btcpp_harness.py).

Every TEST builds ``BT::CoroActionNode`` subclasses (boost coroutines, setStatusRunningAndYield) with the C++
API, without XML: nothing to translate.
"""

from __future__ import annotations

#: TESTs of this file that only use the C++ API, and why they are not translated
SKIPPED: dict[str, str] = {
    "CoroTest.do_action": (
        "tests a C++ BT::CoroActionNode (coroutine yield) built from NodeConfig and ticked directly, no XML"
    ),
    "CoroTest.do_action_timeout": (
        "tests a C++ BT::CoroActionNode under a TimeoutNode assembled with setChild, no XML"
    ),
    "CoroTest.sequence_child": (
        "tests C++ BT::CoroActionNodes in a SequenceNode/TimeoutNode assembled with addChild/setChild, no XML"
    ),
    "CoroTest.OtherThreadHalt": ("tests halting a C++ BT::CoroActionNode from another std::async thread, no XML"),
}
