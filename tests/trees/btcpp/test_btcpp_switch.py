"""BehaviorTree.CPP 4.10 tests/gtest_switch.cpp: the SwitchTest TESTs use the C++ API only (see SKIPPED); the
comparison Switch makes (``details::CheckStringEquality``) is our ``same_case``, translated call for call.

The SwitchTest fixture builds ``BT::SwitchNode<2>`` with a hand-made ``NodeConfig`` (input ports
``variable="{my_var}"``, ``case_1="1"``, ``case_2="42"``) and three ``AsyncActionTest`` children added with
``addChild()``, then calls ``root->executeTick()`` and ``bb->set()`` on its own blackboard. The file's
``xml_text`` (a ``Switch3``) is never loaded by any TEST (and is not well-formed: ``case_2="42 case_3=…``).
"""

from __future__ import annotations

from mission.trees.controls import same_case
from tests.trees.btcpp.btcpp_harness import TEST

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
}


@TEST("SwitchStringEquality.RejectsTrailingCharacters")
def test_rejects_trailing_characters():
    check_string_equality = same_case
    # legitimate matches must keep working
    assert check_string_equality("5", "5", {})
    assert check_string_equality("5", "5.0", {})
    assert check_string_equality("42", "42", {})
    assert check_string_equality("-7", "-7", {})

    # a selector with trailing bytes must not match a numeric case
    assert not check_string_equality("5abc", "5", {})
    assert not check_string_equality("42xxxx", "42", {})
    assert not check_string_equality("1.0junk", "1.0", {})
    assert not check_string_equality("5 ", "5", {})
    assert not check_string_equality("none", "1", {})
