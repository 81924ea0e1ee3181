"""BehaviorTree.CPP 4.10 tests/gtest_logger_zmq.cpp: both TESTs are about the C++ BT::PublisherZMQ.

They check that the (Groot 1) ZeroMQ logger's destructor does not crash, after ticking a SetBlackboard tree or
without ticking it; the tree itself is not checked. We have no Groot 1 publisher.
"""

from __future__ import annotations

#: TESTs of this file that only use the C++ API, and why they are not translated
SKIPPED: dict[str, str] = {
    "LoggerZMQ.ZMQLoggerDeletesCleanlyAfterTickingTree": "tests that the C++ BT::PublisherZMQ (Groot 1 logger) is "
    "destroyed without a segfault after the tree ticked; nothing about the tree is asserted",
    "LoggerZMQ.ZMQLoggerDeletesCleanlyAfterNotTickingTree": "tests that the C++ BT::PublisherZMQ (Groot 1 logger) is "
    "destroyed without a segfault when no state change was ever sent; nothing about the tree is asserted",
}
