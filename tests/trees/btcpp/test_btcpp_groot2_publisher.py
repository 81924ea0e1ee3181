"""BehaviorTree.CPP 4.10 tests/gtest_groot2_publisher.cpp: every TEST is about the C++ BT::Groot2Publisher.

Each attaches a Groot2Publisher (a ZeroMQ server with its own threads) to a tree whose only action throws, and
checks that the publisher neither loops for ever nor hangs in its destructor. The tree's part (the tick throws
BT::RuntimeError) is only the trigger; our Groot2 publisher (mission/groot/publisher.py) is tested in
tests/groot/test_*.py.
"""

from __future__ import annotations

_PUBLISHER = (
    "tests the C++ BT::Groot2Publisher (its ZeroMQ threads must not loop for ever or block its destructor after "
    "the tick throws); the tree's throw is only the trigger"
)

#: TESTs of this file that only use the C++ API, and why they are not translated
SKIPPED: dict[str, str] = {
    "Groot2PublisherTest.EnsureNoInfiniteLoopOnThrow": _PUBLISHER + " (EXPECT_EXIT death test, std::async)",
    "Groot2PublisherTest.DestructorCompletesAfterException": _PUBLISHER + " (5 publishers on ports 1700+)",
    "Groot2PublisherTest.DestructorCompletesWithMultipleNodes": _PUBLISHER + " (a Sequence before the throw)",
    "Groot2PublisherTest.RapidCreateDestroy": _PUBLISHER + " (3 publishers created and destroyed in a row)",
}
