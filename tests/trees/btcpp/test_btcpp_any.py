"""BehaviorTree.CPP 4.10 tests/gtest_any.cpp, translated (XML verbatim; see btcpp_harness.py).

Every TEST exercises the C++ type-erased ``BT::Any`` (no XML): nothing to translate.
"""

from __future__ import annotations

#: TESTs of this file that only use the C++ API, and why they are not translated
SKIPPED: dict[str, str] = {
    "Any.Empty": "tests the C++ API of BT::Any (empty() of default-constructed / assigned Any), no XML",
    "Any.IsType": "tests BT::Any::isType<T>() across C++ types (bool, int, double, std::string, …), no XML",
    "Any.Cast": "tests BT::Any::cast<T>() / tryCast<T>() conversions between C++ types, no XML",
}
