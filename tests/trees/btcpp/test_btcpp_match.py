"""BehaviorTree.CPP 4.10 tests/gtest_match.cpp, translated (XML verbatim; see btcpp_harness.py).

Its one TEST checks the C++ helper ``wildcards_match``, without XML: nothing to translate.
"""

from __future__ import annotations

#: TESTs of this file that only use the C++ API, and why they are not translated
SKIPPED: dict[str, str] = {
    "Match.Match": "tests the C++ utility wildcards_match() (utils/wildcards.hpp), no XML",
}
