"""BehaviorTree.CPP 4.10 tests/gtest_name_validation.cpp, translated (XML verbatim; see btcpp_harness.py)."""

from __future__ import annotations

import pytest

from tests.trees.btcpp.btcpp_harness import TEST, Harness

_FORBIDDEN_CHAR = "calls the C++ function BT::findForbiddenChar() on strings; no XML"
_PORT_NAME = "calls the C++ function BT::IsAllowedPortName() on strings; no XML"

#: TESTs of this file that only use the C++ API, and why they are not translated
SKIPPED: dict[str, str] = {
    "NameValidation.ForbiddenCharDetection_ValidNames": _FORBIDDEN_CHAR,
    "NameValidation.ForbiddenCharDetection_Unicode": _FORBIDDEN_CHAR,
    "NameValidation.ForbiddenCharDetection_ForbiddenChars": _FORBIDDEN_CHAR,
    "NameValidation.ForbiddenCharDetection_ControlChars": _FORBIDDEN_CHAR,
    "NameValidation.IsAllowedPortName_Valid": _PORT_NAME,
    "NameValidation.IsAllowedPortName_Invalid": _PORT_NAME,
}


@pytest.fixture
def bt(tmp_path):
    """NameValidationXMLTest's fixture: a BehaviorTreeFactory."""
    return Harness(tmp_path)


@TEST("NameValidationXMLTest.ValidBehaviorTreeID")
def test_valid_behavior_tree_id(bt):
    xml = """
    <root BTCPP_format="4">
      <BehaviorTree ID="MainTree">
        <AlwaysSuccess/>
      </BehaviorTree>
    </root>"""
    bt.load(xml)  # EXPECT_NO_THROW(createTreeFromText)


@TEST("NameValidationXMLTest.ValidBehaviorTreeID_WithUnderscore")
def test_valid_behavior_tree_id_with_underscore(bt):
    xml = """
    <root BTCPP_format="4">
      <BehaviorTree ID="My_Main_Tree">
        <AlwaysSuccess/>
      </BehaviorTree>
    </root>"""
    bt.load(xml)  # EXPECT_NO_THROW(createTreeFromText)


@TEST("NameValidationXMLTest.InvalidBehaviorTreeID_Root")
def test_invalid_behavior_tree_id_root(bt):
    xml = """
    <root BTCPP_format="4">
      <BehaviorTree ID="Root">
        <AlwaysSuccess/>
      </BehaviorTree>
    </root>"""
    # BT.CPP throws RuntimeError from createTreeFromText
    bt.raises_by_first_tick(xml)


@TEST("NameValidationXMLTest.InvalidBehaviorTreeID_root_lowercase")
def test_invalid_behavior_tree_id_root_lowercase(bt):
    xml = """
    <root BTCPP_format="4">
      <BehaviorTree ID="root">
        <AlwaysSuccess/>
      </BehaviorTree>
    </root>"""
    # BT.CPP throws RuntimeError from createTreeFromText
    bt.raises_by_first_tick(xml)


@TEST("NameValidationXMLTest.InvalidBehaviorTreeID_WithSpace")
def test_invalid_behavior_tree_id_with_space(bt):
    xml = """
    <root BTCPP_format="4">
      <BehaviorTree ID="Main Tree">
        <AlwaysSuccess/>
      </BehaviorTree>
    </root>"""
    # BT.CPP throws RuntimeError from createTreeFromText
    bt.raises_by_first_tick(xml)


@TEST("NameValidationXMLTest.InvalidBehaviorTreeID_WithPeriod")
def test_invalid_behavior_tree_id_with_period(bt):
    xml = """
    <root BTCPP_format="4">
      <BehaviorTree ID="Main.Tree">
        <AlwaysSuccess/>
      </BehaviorTree>
    </root>"""
    # BT.CPP throws RuntimeError from createTreeFromText
    bt.raises_by_first_tick(xml)


@TEST("NameValidationXMLTest.ValidInstanceName")
def test_valid_instance_name(bt):
    xml = """
    <root BTCPP_format="4">
      <BehaviorTree ID="MainTree">
        <AlwaysSuccess name="my_success_node"/>
      </BehaviorTree>
    </root>"""
    bt.load(xml)  # EXPECT_NO_THROW(createTreeFromText)


@TEST("NameValidationXMLTest.ValidInstanceName_WithSpace")
def test_valid_instance_name_with_space(bt):
    # Instance names are XML attribute VALUES, so spaces are allowed
    xml = """
    <root BTCPP_format="4">
      <BehaviorTree ID="MainTree">
        <AlwaysSuccess name="my success node"/>
      </BehaviorTree>
    </root>"""
    bt.load(xml)  # EXPECT_NO_THROW(createTreeFromText)


@TEST("NameValidationXMLTest.ValidInstanceName_WithPeriod")
def test_valid_instance_name_with_period(bt):
    # Instance names are XML attribute VALUES, so periods are allowed
    xml = """
    <root BTCPP_format="4">
      <BehaviorTree ID="MainTree">
        <AlwaysSuccess name="node.name"/>
      </BehaviorTree>
    </root>"""
    bt.load(xml)  # EXPECT_NO_THROW(createTreeFromText)


@TEST("NameValidationXMLTest.ValidSubTreeID")
def test_valid_sub_tree_id(bt):
    xml = """
    <root BTCPP_format="4" main_tree_to_execute="MainTree">
      <BehaviorTree ID="MainTree">
        <SubTree ID="SubTree1"/>
      </BehaviorTree>
      <BehaviorTree ID="SubTree1">
        <AlwaysSuccess/>
      </BehaviorTree>
    </root>"""
    bt.load(xml)  # EXPECT_NO_THROW(createTreeFromText)


@TEST("NameValidationXMLTest.InvalidSubTreeID_WithSpace")
def test_invalid_sub_tree_id_with_space(bt):
    xml = """
    <root BTCPP_format="4" main_tree_to_execute="MainTree">
      <BehaviorTree ID="MainTree">
        <SubTree ID="Sub Tree"/>
      </BehaviorTree>
      <BehaviorTree ID="Sub Tree">
        <AlwaysSuccess/>
      </BehaviorTree>
    </root>"""
    # BT.CPP throws RuntimeError from createTreeFromText
    bt.raises_by_first_tick(xml)


@TEST("NameValidationXMLTest.UnicodeTreeID_Chinese")
def test_unicode_tree_id_chinese(bt):
    xml = """
    <root BTCPP_format="4">
      <BehaviorTree ID="检查门">
        <AlwaysSuccess/>
      </BehaviorTree>
    </root>"""
    bt.load(xml)  # EXPECT_NO_THROW(createTreeFromText)


@TEST("NameValidationXMLTest.UnicodeInstanceName_Japanese")
def test_unicode_instance_name_japanese(bt):
    xml = """
    <root BTCPP_format="4">
      <BehaviorTree ID="MainTree">
        <AlwaysSuccess name="成功ノード"/>
      </BehaviorTree>
    </root>"""
    bt.load(xml)  # EXPECT_NO_THROW(createTreeFromText)


@TEST("NameValidationXMLTest.UnicodeTreeID_German")
def test_unicode_tree_id_german(bt):
    xml = """
    <root BTCPP_format="4">
      <BehaviorTree ID="Türöffner">
        <AlwaysSuccess/>
      </BehaviorTree>
    </root>"""
    bt.load(xml)  # EXPECT_NO_THROW(createTreeFromText)


@TEST("NameValidationXMLTest.ValidSubTreePortName")
def test_valid_sub_tree_port_name(bt):
    xml = """
    <root BTCPP_format="4" main_tree_to_execute="MainTree">
      <BehaviorTree ID="MainTree">
        <SubTree ID="MySubTree" input_value="{value}"/>
      </BehaviorTree>
      <BehaviorTree ID="MySubTree">
        <AlwaysSuccess/>
      </BehaviorTree>
      <TreeNodesModel>
        <SubTree ID="MySubTree">
          <input_port name="input_value"/>
        </SubTree>
      </TreeNodesModel>
    </root>"""
    bt.load(xml)  # EXPECT_NO_THROW(createTreeFromText)


@TEST("NameValidationXMLTest.InvalidSubTreePortName_WithSpace")
def test_invalid_sub_tree_port_name_with_space(bt):
    xml = """
    <root BTCPP_format="4" main_tree_to_execute="MainTree">
      <BehaviorTree ID="MainTree">
        <AlwaysSuccess/>
      </BehaviorTree>
      <TreeNodesModel>
        <SubTree ID="MySubTree">
          <input_port name="input value"/>
        </SubTree>
      </TreeNodesModel>
    </root>"""
    # BT.CPP throws RuntimeError from createTreeFromText
    bt.raises_by_first_tick(xml)


@TEST("NameValidationXMLTest.InvalidSubTreePortName_Reserved")
def test_invalid_sub_tree_port_name_reserved(bt):
    xml = """
    <root BTCPP_format="4" main_tree_to_execute="MainTree">
      <BehaviorTree ID="MainTree">
        <AlwaysSuccess/>
      </BehaviorTree>
      <TreeNodesModel>
        <SubTree ID="MySubTree">
          <input_port name="ID"/>
        </SubTree>
      </TreeNodesModel>
    </root>"""
    # BT.CPP throws RuntimeError from createTreeFromText
    bt.raises_by_first_tick(xml)


@TEST("NameValidationXMLTest.InvalidSubTreePortName_StartsWithDigit")
def test_invalid_sub_tree_port_name_starts_with_digit(bt):
    xml = """
    <root BTCPP_format="4" main_tree_to_execute="MainTree">
      <BehaviorTree ID="MainTree">
        <AlwaysSuccess/>
      </BehaviorTree>
      <TreeNodesModel>
        <SubTree ID="MySubTree">
          <input_port name="1port"/>
        </SubTree>
      </TreeNodesModel>
    </root>"""
    # BT.CPP throws RuntimeError from createTreeFromText
    bt.raises_by_first_tick(xml)
