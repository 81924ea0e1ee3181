"""BehaviorTree.CPP 4.10 tests/gtest_basic_types.cpp, translated (XML verbatim; see btcpp_harness.py).

Most TESTs check C++ helpers (toStr, convertFromString, splitString, PortInfo, Result, StringView). The four
that load XML check the loaded tree through C++ functions; here through their counterparts on our tree:

* ``applyRecursiveVisitor(root, fn)``: :func:`apply_recursive_visitor` below, BT.CPP's depth-first pre-order
  walk over the py_trees behaviours the loader built (py_trees' own ``iterate()`` is post-order);
* ``printTreeRecursively(root, stream)``: py_trees' text rendering of the tree (``py_trees.display.ascii_tree``),
  the project having no printer of its own;
* ``buildSerializedStatusSnapshot(root, snapshot)``: the Groot2 STATUS snapshot, one (UID, status) per node
  (mission/groot/uids.py ``uid_tree`` + ``bind``, as the publisher builds it).
"""

from __future__ import annotations

from collections.abc import Callable

import pytest
from py_trees.behaviour import Behaviour

from mission.groot.uids import bind, uid_tree
from tests.trees.btcpp.btcpp_harness import TEST, Harness

_TO_STR = "tests BT::toStr() of C++ values ({}), no XML"
_CONVERT = "tests BT::convertFromString<{}>() (C++ template string conversion), no XML"
_SPLIT = "tests the C++ helper BT::splitString(), no XML"

#: TESTs of this file that only use the C++ API, and why they are not translated
SKIPPED: dict[str, str] = {
    "BehaviorTree.PrintTreeRecursively": "tests the text format of the C++ printer printTreeRecursively() (its "
    "'----------------' delimiter lines); trees here print with py_trees.display and mission viz, in their own format",
    "BasicTypes.ToStr_NodeStatus": _TO_STR.format("NodeStatus"),
    "BasicTypes.ToStr_NodeStatus_Colored": _TO_STR.format("NodeStatus with ANSI colours"),
    "BasicTypes.ToStr_PortDirection": _TO_STR.format("PortDirection"),
    "BasicTypes.ToStr_NodeType": _TO_STR.format("NodeType"),
    "BasicTypes.ToStr_Bool": _TO_STR.format("bool"),
    "BasicTypes.ToStr_String": _TO_STR.format("std::string"),
    "BasicTypes.ConvertFromString_Int": _CONVERT.format("int"),
    "BasicTypes.ConvertFromString_Int64": _CONVERT.format("int64_t"),
    "BasicTypes.ConvertFromString_UInt64": _CONVERT.format("uint64_t"),
    "BasicTypes.ConvertFromString_Double": _CONVERT.format("double"),
    "BasicTypes.DoubleToIntBoundary": (
        "tests BT::Any::cast<int64_t/uint64_t>() of doubles at 2^63 / 2^64 and Blackboard::set on an int64_t "
        "entry (C++ integer types), no XML"
    ),
    "BasicTypes.ConvertFromString_Bool": _CONVERT.format("bool"),
    "BasicTypes.ConvertFromString_String": _CONVERT.format("std::string"),
    "BasicTypes.ConvertFromString_NodeStatus": _CONVERT.format("NodeStatus"),
    "BasicTypes.ConvertFromString_NodeType": _CONVERT.format("NodeType"),
    "BasicTypes.ConvertFromString_PortDirection": _CONVERT.format("PortDirection"),
    "BasicTypes.SplitString_Basic": _SPLIT,
    "BasicTypes.SplitString_Empty": _SPLIT,
    "BasicTypes.SplitString_NoDelimiter": _SPLIT,
    "BasicTypes.SplitString_Whitespace": _SPLIT,
    "BasicTypes.LibraryVersion": "tests the C++ functions LibraryVersionNumber() / LibraryVersionString(), no XML",
    "BehaviorTree.ApplyRecursiveVisitor_NullNode": (
        "tests that applyRecursiveVisitor(nullptr) throws LogicError (a C++ null pointer), no XML"
    ),
    "BasicTypes.PortInfo_Construction": "tests the C++ InputPort<T>/OutputPort<T>/BidirectionalPort<T> helpers, no XML",
    "BasicTypes.PortInfo_DefaultValue": "tests PortInfo::defaultValue() of a C++ InputPort<int>, no XML",
    "BasicTypes.TreeNodeManifest": "tests the fields of a C++ TreeNodeManifest struct, no XML",
    "BasicTypes.Result_Success": "tests the C++ type BT::Result (nonstd::expected), no XML",
    "BasicTypes.Result_Error": "tests the C++ type BT::Result (nonstd::expected) with an error, no XML",
    "BasicTypes.StringView_FromString": "tests the C++ type BT::StringView built from std::string, no XML",
    "BasicTypes.StringView_FromCharPtr": "tests the C++ type BT::StringView built from a const char*, no XML",
}


def apply_recursive_visitor(node: Behaviour, visitor: Callable[[Behaviour], None]) -> None:
    """BT.CPP's ``applyRecursiveVisitor``: the node, then each child's subtree, depth first."""
    visitor(node)
    for child in node.children:
        apply_recursive_visitor(child, visitor)


@TEST("BehaviorTree.ApplyRecursiveVisitor")
def test_apply_recursive_visitor(tmp_path):
    bt = Harness(tmp_path)

    xml_text = """
    <root BTCPP_format="4">
       <BehaviorTree>
          <Sequence>
            <AlwaysSuccess/>
            <AlwaysFailure/>
          </Sequence>
       </BehaviorTree>
    </root>"""

    tree = bt.load(xml_text)

    # Count nodes using visitor
    node_count = 0

    def count(_node: Behaviour) -> None:
        nonlocal node_count
        node_count += 1

    apply_recursive_visitor(tree.root, count)

    # Should have: Sequence + AlwaysSuccess + AlwaysFailure = 3 nodes
    assert node_count == 3


@TEST("BehaviorTree.ApplyRecursiveVisitor_MutableVersion")
@pytest.mark.xfail(
    strict=True,
    reason="trees/loader.py _Builder.build renames a tree's root after the tree (BehaviorTree_0); BT.CPP: 'Sequence'",
)
def test_apply_recursive_visitor_mutable_version(tmp_path):
    bt = Harness(tmp_path)

    xml_text = """
    <root BTCPP_format="4">
       <BehaviorTree>
          <Sequence>
            <AlwaysSuccess/>
          </Sequence>
       </BehaviorTree>
    </root>"""

    tree = bt.load(xml_text)

    # Collect node names
    names: list[str] = []
    apply_recursive_visitor(tree.root, lambda node: names.append(node.name))

    assert len(names) == 2
    assert names[0] == "Sequence"
    assert names[1] == "AlwaysSuccess"


@TEST("BehaviorTree.BuildSerializedStatusSnapshot")
def test_build_serialized_status_snapshot(tmp_path):
    bt = Harness(tmp_path)

    xml_text = """
    <root BTCPP_format="4">
       <BehaviorTree>
          <Sequence>
            <AlwaysSuccess/>
            <AlwaysSuccess/>
          </Sequence>
       </BehaviorTree>
    </root>"""

    tree = bt.load(xml_text)

    # Tick once to set some statuses
    tree.tick_once()

    path = tmp_path / "snapshot.xml"  # the same text, numbered as the Groot2 publisher numbers the loaded file
    path.write_text(xml_text)
    snapshot = {uid: behaviour.status for uid, behaviour in bind(uid_tree(path), tree.root).items()}

    # Should have entries for each node
    assert len(snapshot) == 3  # Sequence + 2 AlwaysSuccess
