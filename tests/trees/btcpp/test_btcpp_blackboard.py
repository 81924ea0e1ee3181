"""BehaviorTree.CPP 4.10 tests/gtest_blackboard.cpp, translated (XML verbatim; see btcpp_harness.py)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import pytest

from mission.behaviours.ports import Port
from mission.core.errors import TreeError
from tests.trees.btcpp.btcpp_harness import TEST, Harness, SimpleAction, Tree, port

#: TESTs of this file that only use the C++ API, and why they are not translated
SKIPPED: dict[str, str] = {
    "BlackboardTest.GetInputsFromBlackboard": "constructs BB_TestNode directly with a C++ NodeConfig and "
    "assignDefaultRemapping, no XML",
    "BlackboardTest.BasicRemapping": "constructs BB_TestNode directly with a C++ NodeConfig (input_ports/output_ports "
    "filled by hand), no XML",
    "BlackboardTest.GetInputsFromText": "constructs BB_TestNode directly with a C++ NodeConfig (a node without a "
    "blackboard, '{=}' written into output_ports by hand), no XML",
    "BlackboardTest.MoveVsCopy": "tests C++ copy/move semantics of a value stored in the blackboard "
    "(shared_ptr use_count of RefCountClass)",
    "BlackboardTest.CheckTypeSafety": "only checks C++ type traits (std::is_constructible<BT::StringView, …>)",
    "BlackboardTest.AnyPtrLocked": "tests Blackboard::getAnyLocked on a raw long* from two C++ threads, no XML",
    "BlackboardTest.SetStringView": "tests Blackboard::set with a C++ BT::StringView (std::string_view) value, no XML",
    "BlackboardTest.NullOutputRemapping": "constructs BB_TestNode directly with a C++ NodeConfig whose output "
    "remapping is an empty string, no XML",
    "BlackboardTest.BlackboardBackup": "tests the C++ BlackboardBackup()/BlackboardRestore() functions and "
    "Blackboard::getKeys() of every subtree's blackboard",
    "BlackboardTest.TimestampedInterface": "tests the C++ Blackboard::getStamped() API (sequence id and "
    "steady_clock stamp), no XML",
    "BlackboardTest.SetBlackboard_Upd_Ts_SeqId": "reads the entry's stamp and sequence_id through the C++ "
    "Blackboard::getEntry() API (entries here carry no timestamp) after setting C++ Point values",
    "BlackboardTest.SetBlackboard_WithPortRemapping": "needs a C++ type as port type (Point, written 'x;y', "
    "with convertFromString<Point>; Pose2D is 'x;y;yaw') and checks entry->value.type() == typeid(Point)",
    "BlackboardTest.DebugMessageShowsRemappedEntries_Issue408": "tests the stdout of the C++ "
    "Blackboard::debugMessage() with addSubtreeRemapping(), no XML",
}


# ----------------------------------------------------------------------------- test nodes
def bb_test_node(node: SimpleAction) -> str:
    """BB_TestNode::tick: out_port = 2 * in_port (an unreadable in_port fails the node before this tick)."""
    value = node.input("in_port") * 2
    if not node.set_output("out_port", value):
        raise RuntimeError("BB_TestNode failed output")
    return "SUCCESS"


BB_TEST_NODE_PORTS = [("in_port", int, port()), ("out_port", int, port(direction="output"))]


def say_something(node: SimpleAction) -> str:
    """DummyNodes::SaySomething::tick."""
    print("Robot says:", node.input("message"))
    return "SUCCESS"


SAY_SOMETHING_PORTS = [("message", str, port())]


def comparison_node(node: SimpleAction) -> str:
    """ComparisonNode::tick (a ConditionNode)."""
    first, second, op = node.input("first"), node.input("second"), node.input("operator")
    if (
        (op == "==" and first == second)
        or (op == "!=" and first != second)
        or (op == "<=" and first <= second)
        or (op == ">=" and first >= second)
        or (op == "<" and first < second)
        or (op == ">" and first > second)
    ):
        return "SUCCESS"
    return "FAILURE"


@dataclass
class Point:
    """The C++ ``struct Point { double x; double y; }`` of this file (set into the blackboard by the test)."""

    x: float
    y: float


def get_as(tree: Tree, key: str, kind: type) -> Any:
    """``tree.rootBlackboard()->get<T>(key)``: the entry as `kind`, text converted (convertFromString)."""
    return Port(kind).coerce(tree.get(key))


@pytest.fixture
def bt(tmp_path):
    return Harness(tmp_path)


# ----------------------------------------------------------------------------- the TESTs
@TEST("BlackboardTest.SetOutputFromText")
def test_set_output_from_text(bt):
    xml_text = """

     <root BTCPP_format="4" >
         <BehaviorTree ID="MainTree">
            <Sequence>
                <BB_TestNode in_port="11" out_port="{my_port}"/>
                <Script code="my_port=-43" />
            </Sequence>
         </BehaviorTree>
     </root>
    """
    bt.register_simple_action("BB_TestNode", bb_test_node, BB_TEST_NODE_PORTS)
    tree = bt.load(xml_text)
    # BT.CPP asserts only that nothing throws; an error here fails the node instead (docs/btcpp.md "Differences")
    assert tree.tick_while_running() == "SUCCESS"


@TEST("BlackboardTest.WithFactory")
def test_with_factory(bt):
    bt.register_simple_action("BB_TestNode", bb_test_node, BB_TEST_NODE_PORTS)
    xml_text = """

    <root BTCPP_format="4" >
        <BehaviorTree ID="MainTree">
            <Sequence>
                <BB_TestNode in_port="11"
                             out_port="{my_input_port}"/>

                <BB_TestNode in_port="{my_input_port}"
                             out_port="{my_input_port}" />

                <BB_TestNode in_port="{my_input_port}"
                             out_port="{my_output_port}" />
            </Sequence>
        </BehaviorTree>
    </root>"""
    tree = bt.load(xml_text)
    status = tree.tick_while_running()
    assert status == "SUCCESS"
    assert get_as(tree, "my_input_port", int) == 44
    assert get_as(tree, "my_output_port", int) == 88


@TEST("BlackboardTest.TypoInPortName")
def test_typo_in_port_name(bt):
    bt.register_simple_action("BB_TestNode", bb_test_node, BB_TEST_NODE_PORTS)
    xml_text = """

    <root BTCPP_format="4" >
        <BehaviorTree ID="MainTree">
             <BB_TestNode inpuuuut_port="{value}" />
        </BehaviorTree>
    </root>"""
    with pytest.raises(TreeError):  # BT.CPP: createTreeFromText throws RuntimeError
        bt.load(xml_text)


@TEST("ParserTest.Issue605_whitespaces")
def test_issue605_whitespaces(bt):
    xml_text = """
  <root BTCPP_format="4" >
    <BehaviorTree ID="MySubtree">
      <Script code=" sub_value:=false " />
    </BehaviorTree>

    <BehaviorTree ID="MainTree">
      <Sequence>
        <Script code=" my_value:=true " />
        <SubTree ID="MySubtree" sub_value="{my_value}  "/>
      </Sequence>
    </BehaviorTree>
  </root> """
    bt.register_tree_text(xml_text)
    tree = bt.load(main_tree="MainTree")
    status = tree.tick_while_running()
    assert status == "SUCCESS"
    assert get_as(tree, "my_value", bool) is False


@TEST("BlackboardTest.IssueSetBlackboard")
def test_issue_set_blackboard(bt):
    xml_text = """
  <root BTCPP_format="4" >
    <BehaviorTree ID="MySubtree">
      <ComparisonNode first="{value}" second="42" operator="==" />
    </BehaviorTree>

    <BehaviorTree ID="MainTree">
      <Sequence>
        <SetBlackboard value="42" output_key="value" />
        <SubTree ID="MySubtree" value="{value}  "/>
      </Sequence>
    </BehaviorTree>
  </root> """
    bt.register_simple_condition(
        "ComparisonNode", comparison_node, [("first", int, port()), ("second", int, port()), ("operator", str, port())]
    )
    bt.register_tree_text(xml_text)
    tree = bt.load(main_tree="MainTree")
    status = tree.tick_while_running()
    assert status == "SUCCESS"
    assert get_as(tree, "value", int) == 42


@TEST("BlackboardTest.SetBlackboard_Issue725")
def test_set_blackboard_issue725(bt):
    xml_text = """
  <root BTCPP_format="4">
    <BehaviorTree ID="MainTree">
      <SetBlackboard value="{first_point}" output_key="other_point" />
    </BehaviorTree>
  </root> """
    bt.register_simple_action("SaySomething", say_something, SAY_SOMETHING_PORTS)
    bt.register_tree_text(xml_text)
    tree = bt.load(main_tree="MainTree")

    point = Point(2, 7)
    tree.set("first_point", point)  # the main tree's blackboard is the root one
    status = tree.tick_once()
    other_point = tree.get("other_point")
    assert status == "SUCCESS"
    assert other_point.x == point.x
    assert other_point.y == point.y


@TEST("BlackboardTest.RootBlackboard")
def test_root_blackboard(bt):
    xml_text = """
  <root BTCPP_format="4" >
    <BehaviorTree ID="SubA">
      <Sequence>
        <SubTree ID="SubB" />
        <Script code=" @var3:=3 " />
      </Sequence>
    </BehaviorTree>

    <BehaviorTree ID="SubB">
      <Sequence>
        <SaySomething message="{@msg}" />
        <Script code=" @var4:=4 " />
      </Sequence>
    </BehaviorTree>

    <BehaviorTree ID="Sub_Issue823">
      <BB_TestNode in_port="2" out_port="{@var5}" />
    </BehaviorTree>

    <BehaviorTree ID="MainTree">
      <Sequence>
        <Script code=" msg:='hello' " />
        <SubTree ID="SubA" />

        <Script code="@var5:=0" />
        <SubTree ID="Sub_Issue823" />

        <Script code=" var1:=1 " />
        <Script code=" @var2:=2 " />
      </Sequence>
    </BehaviorTree>
  </root> """
    bt.register_simple_action("SaySomething", say_something, SAY_SOMETHING_PORTS)
    bt.register_simple_action("BB_TestNode", bb_test_node, BB_TEST_NODE_PORTS)
    bt.register_tree_text(xml_text)
    tree = bt.load(main_tree="MainTree")

    status = tree.tick_while_running()
    assert status == "SUCCESS"
    assert get_as(tree, "var1", int) == 1
    assert get_as(tree, "var2", int) == 2
    assert get_as(tree, "var3", int) == 3
    assert get_as(tree, "var4", int) == 4
    assert get_as(tree, "var5", int) == 4


@pytest.mark.xfail(
    strict=True,
    reason="an inout port's default must be a value of its type: '{=}' (BT.CPP's default blackboard remapping) is "
    "refused for an int port (behaviours/ports.py declared_ports); and trees/loader.py _Compiler.ports connects a "
    "'{key}' default as an input only, so set_output of an inout port left out of the XML writes nothing",
)
@TEST("BlackboardTest.GetLockedPortContentWithDefault_Issue942")
def test_get_locked_port_content_with_default_issue942(bt):
    # XML does NOT specify the "value" port — relies on default "{=}"
    xml_txt = """
    <root BTCPP_format="4" >
      <BehaviorTree ID="Main">
        <ActionWithLockedPort/>
      </BehaviorTree>
    </root>"""

    def action_with_locked_port(node: SimpleAction) -> str:
        # getLockedPortContent("value") then assign(42): the entry the port is connected to, written
        node.locked_valid = node.set_output("value", 42)
        return "SUCCESS" if node.locked_valid else "FAILURE"

    bt.register_simple_action(
        "ActionWithLockedPort",
        action_with_locked_port,
        [("value", int, port("{=}", "A value with default BB remap", direction="inout"))],
    )
    tree = bt.load(xml_txt)
    status = tree.tick_while_running()
    assert status == "SUCCESS"
    for node in tree.nodes("ActionWithLockedPort"):
        assert getattr(node, "locked_valid", False)
    # The value should be accessible from the blackboard
    assert get_as(tree, "value", int) == 42
