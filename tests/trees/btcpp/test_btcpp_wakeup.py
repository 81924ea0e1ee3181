"""BehaviorTree.CPP 4.10 tests/gtest_wakeup.cpp: its one TEST uses the C++ API only (see SKIPPED)."""

from __future__ import annotations

#: TESTs of this file that only use the C++ API, and why they are not translated
SKIPPED: dict[str, str] = {
    "WakeUp.BasicTest": "tests BT.CPP's threading API: a BT::ThreadedAction (tick() on its own thread) whose "
    "completion emits the wake-up signal that cuts Tree::sleep(200 ms) short; the project has no threaded "
    "nodes and no Tree.sleep (the runner ticks the tree on its clock), so there is nothing to wake",
}
