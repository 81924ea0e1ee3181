"""BehaviorTree.CPP 4.10 tests/gtest_async_action_node.cpp, translated (XML verbatim; see btcpp_harness.py).

Every TEST drives a gmock ``MockedThreadedAction`` (BT::ThreadedAction) built from a bare NodeConfig, without
XML: nothing to translate. (The TEST_P ``NodeStatusFixture.normal_routine`` is not in the list of TESTs.)
"""

from __future__ import annotations

#: TESTs of this file that only use the C++ API, and why they are not translated
SKIPPED: dict[str, str] = {
    "MockedThreadedActionFixture.no_halt": (
        "tests BT::ThreadedAction C++ halt flag (isHaltRequested) on a gmock node built with NodeConfig, no XML"
    ),
    "MockedThreadedActionFixture.halt": (
        "tests that BT::ThreadedAction::halt() blocks on the C++ worker thread (gmock, std::async), no XML"
    ),
    "MockedThreadedActionFixture.exception": (
        "tests that a C++ exception in the BT::ThreadedAction worker thread is re-raised by the caller (gmock), no XML"
    ),
}
