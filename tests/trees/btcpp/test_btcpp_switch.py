"""BehaviorTree.CPP 4.10 tests/gtest_switch.cpp: every TEST uses the C++ API only (see SKIPPED).

The SwitchTest fixture builds ``BT::SwitchNode<2>`` with a hand-made ``NodeConfig`` (input ports
``variable="{my_var}"``, ``case_1="1"``, ``case_2="42"``) and three ``AsyncActionTest`` children added with
``addChild()``, then calls ``root->executeTick()`` and ``bb->set()`` on its own blackboard. The file's
``xml_text`` (a ``Switch3``) is never loaded by any TEST (and is not well-formed: ``case_2="42 case_3=…``).
"""

from __future__ import annotations

_FIXTURE = (
    "constructs the nodes directly with the C++ API (no XML): BT::SwitchNode<2> built from a NodeConfig, "
    "AsyncActionTest children added with addChild(), ticked with root->executeTick(); the file's xml_text is unused"
)

#: TESTs of this file that only use the C++ API, and why they are not translated
SKIPPED: dict[str, str] = {
    "SwitchTest.DefaultCase": _FIXTURE,
    "SwitchTest.Case1": _FIXTURE,
    "SwitchTest.Case2": _FIXTURE,
    "SwitchTest.CaseNone": _FIXTURE,
    "SwitchTest.CaseSwitchToDefault": _FIXTURE,
    "SwitchTest.CaseSwitchToAction2": _FIXTURE,
    "SwitchTest.ActionFailure": _FIXTURE + "; also action_1.setExpectedResult() while it runs",
    "SwitchStringEquality.RejectsTrailingCharacters": "tests the C++ helper BT::details::CheckStringEquality() "
    "directly (no XML, no tree)",
}
