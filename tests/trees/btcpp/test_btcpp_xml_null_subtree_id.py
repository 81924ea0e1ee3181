"""BehaviorTree.CPP 4.10 tests/gtest_xml_null_subtree_id.cpp, translated (XML verbatim; see btcpp_harness.py)."""

from __future__ import annotations

from tests.trees.btcpp.btcpp_harness import TEST, Harness

#: TESTs of this file that only use the C++ API, and why they are not translated
SKIPPED: dict[str, str] = {}


# BUG-7: If a <SubTree> element inside <TreeNodesModel> is missing the
# "ID" attribute, Attribute("ID") returns nullptr, which is used as a
# key in std::unordered_map — undefined behavior (null pointer dereference).
# After the fix, this should throw a descriptive RuntimeError.
@TEST("XMLParserTest.SubTreeModelMissingID_Bug7")
def test_sub_tree_model_missing_id_bug7(tmp_path):
    xml_text = """
  <root BTCPP_format="4">
    <BehaviorTree ID="MainTree">
      <AlwaysSuccess />
    </BehaviorTree>
    <TreeNodesModel>
      <SubTree>
        <input_port name="some_port"/>
      </SubTree>
    </TreeNodesModel>
  </root>
  """
    bt = Harness(tmp_path)
    # BT.CPP throws RuntimeError from registerBehaviorTreeFromText already; our loader refuses the file when it
    # loads it
    bt.register_tree_text(xml_text)
    bt.raises_by_first_tick(main_tree="MainTree")
