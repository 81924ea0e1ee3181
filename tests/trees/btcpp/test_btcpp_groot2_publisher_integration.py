"""BehaviorTree.CPP 4.10 tests/gtest_groot2_publisher_integration.cpp: every TEST is about the C++ Groot2Publisher.

They talk to a BT::Groot2Publisher over ZeroMQ (groot2_test_utils.hpp's client): hooks (HOOK_INSERT / HOOKS_DUMP /
HOOK_REMOVE replacing a node's status), malformed requests, and the BLACKBOARD dump of C++ blackboards (an external
root blackboard given to createTree, a subtree's blackboard replaced by hand). Our publisher (mission/groot/) has
no hooks and one blackboard store; it is tested in tests/groot/test_*.py.
"""

from __future__ import annotations

_HOOKS = "tests the C++ Groot2Publisher's hooks (HOOK_INSERT/HOOKS_DUMP/HOOK_REMOVE over ZeroMQ)"
_SERVER = "tests that the C++ Groot2Publisher's server thread survives a bad request (EXPECT_EXIT death test)"
_DUMP = (
    "tests the C++ Groot2Publisher's BLACKBOARD reply for C++ blackboards (BT::Blackboard::create with an external "
    "root passed to createTree)"
)

#: TESTs of this file that only use the C++ API, and why they are not translated
SKIPPED: dict[str, str] = {
    "Groot2PublisherIntegration.PostHookRunsAfterNodeAndCanBeRemoved": _HOOKS
    + ": a POST hook replaces the node's status, then is removed",
    "Groot2PublisherIntegration.MalformedRequestDoesNotTerminateServer": _SERVER + " (HOOK_INSERT with '{')",
    "Groot2PublisherIntegration.IncompleteHookRequestDoesNotTerminateServer": _SERVER
    + " (HOOK_INSERT without uid/position)",
    "Groot2PublisherIntegration.BlackboardDump_NoRootWithoutExternalBlackboard": _DUMP + ": no ROOT entry",
    "Groot2PublisherIntegration.BlackboardDump_ExportsExternalRootBlackboard": _DUMP + ": ROOT exported",
    "Groot2PublisherIntegration.BlackboardDump_DeduplicatesSharedExternalRoot": _DUMP + ": one ROOT for 3 subtrees",
    "Groot2PublisherIntegration.BlackboardDump_RejectsReservedRootNameCollision": _DUMP
    + ": a tree named ROOT is an error reply",
    "Groot2PublisherIntegration.BlackboardDump_RejectsConflictingExternalRoots": _DUMP
    + ": a subtree blackboard replaced by hand with another external root is an error reply",
}
