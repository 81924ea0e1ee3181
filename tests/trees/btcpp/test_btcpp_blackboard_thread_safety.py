"""BehaviorTree.CPP 4.10 tests/gtest_blackboard_thread_safety.cpp, translated (XML verbatim; see btcpp_harness.py).

Every TEST races C++ threads on ``BT::Blackboard`` methods (for ThreadSanitizer), without XML: nothing to
translate.
"""

from __future__ import annotations

#: TESTs of this file that only use the C++ API, and why they are not translated
SKIPPED: dict[str, str] = {
    "BlackboardThreadSafety.SetAndUnsetRace_Bug2": (
        "C++ data-race test (ThreadSanitizer): concurrent Blackboard::set()/unset() from std::threads, no XML"
    ),
    "BlackboardThreadSafety.SetNewEntryWhileReading_Bug1_Bug8": (
        "C++ data-race test (ThreadSanitizer): Blackboard::set() of new keys while other std::threads read, no XML"
    ),
    "BlackboardThreadSafety.TwoThreadsSetSameNewKey_Bug8": (
        "C++ data-race test (ThreadSanitizer): two std::threads create the same Blackboard key, no XML"
    ),
    "BlackboardThreadSafety.CloneIntoWhileReading_Bug3": (
        "C++ data-race test (ThreadSanitizer): Blackboard::cloneInto() while std::threads read, no XML"
    ),
    "BlackboardThreadSafety.ImportJsonWhileReading_Bug4": (
        "C++ data-race test (ThreadSanitizer): ImportBlackboardFromJSON while std::threads read, no XML"
    ),
    "BlackboardThreadSafety.DebugMessageWhileModifying_Bug5": (
        "C++ data-race test (ThreadSanitizer): Blackboard::debugMessage() while std::threads write, no XML"
    ),
    "BlackboardThreadSafety.GetKeysWhileModifying_Bug6": (
        "C++ data-race test (ThreadSanitizer): Blackboard::getKeys() while std::threads write, no XML"
    ),
}
