"""BehaviorTree.CPP 4.10 tests/gtest_groot2_publisher_thread_safety.cpp: every TEST is about the C++ Groot2Publisher.

They are ThreadSanitizer reproducers for BT::Groot2Publisher's threads and locks (heartbeat delay, recording
transitions, destruction during status callbacks, hook lock order, a blocked breakpoint); the tree is a lone
AlwaysSuccess. Our publisher (mission/groot/publisher.py) has no hooks or breakpoints; it is tested in
tests/groot/test_*.py.
"""

from __future__ import annotations

_TSAN = "a ThreadSanitizer reproducer for the C++ Groot2Publisher's threads and locks"

#: TESTs of this file that only use the C++ API, and why they are not translated
SKIPPED: dict[str, str] = {
    "Groot2PublisherThreadSafety.UpdateHeartbeatDelayWhileHeartbeatThreadIsRunning": _TSAN
    + ": setMaxHeartbeatDelay while its heartbeat thread runs",
    "Groot2PublisherThreadSafety.RecordTransitionsWhileTreeIsTicking": _TSAN
    + ": TOGGLE_RECORDING/GET_TRANSITIONS while another thread ticks and halts",
    "Groot2PublisherThreadSafety.DestroyWhileStatusCallbacksAreRunning": _TSAN
    + ": the publisher destroyed while another thread ticks",
    "Groot2PublisherThreadSafety.DisableThenRemoveOneShotHookUsesConsistentLockOrder": _TSAN
    + ": hook insert/disable/one-shot removal lock order (REPLACE hook makes the root FAILURE once)",
    "Groot2PublisherThreadSafety.DestroyWhileBreakpointCallbackIsBlocked": _TSAN
    + ": the publisher destroyed while a BREAKPOINT hook blocks the tick",
}
