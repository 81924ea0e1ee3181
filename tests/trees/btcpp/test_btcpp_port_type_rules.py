"""BehaviorTree.CPP 4.10 tests/gtest_port_type_rules.cpp, translated (XML verbatim; see btcpp_harness.py).

Our port types are str, int, float, bool and Pose2D: the TESTs of generic ports (``InputPort<>()``,
AnyTypeAllowed), ``BT::Any`` ports, the custom ``TestPoint`` (``"x;y"``) and ``std::vector<double>`` ports, and of
the C++ ``Blackboard``/``TypeInfo`` API are C++ only (see SKIPPED).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Any

import pytest

from mission.behaviours.ports import Port
from mission.core.errors import TreeError
from tests.trees.btcpp.btcpp_harness import TEST, Harness, SimpleAction, Tree, port

_GENERIC = (
    "NodeWithGenericPorts declares untyped ports (InputPort<>() / OutputPort<>(), AnyTypeAllowed); a port here "
    "has one of the types str, int, float, bool, Pose2D"
)
_TEST_POINT = (
    "needs a C++ type as port type (TestPoint, written 'x;y' with convertFromString<TestPoint>; Pose2D is 'x;y;yaw')"
)
_VECTOR = "needs a C++ type as port type (std::vector<double> from a ';'-separated string)"
_BB_API = "tests the C++ Blackboard API directly (no XML): "
_BT_ANY = "needs a BT::Any port type (InputPort<BT::Any> / OutputPort<BT::Any>), which takes values of any type"

#: TESTs of this file that only use the C++ API, and why they are not translated
SKIPPED: dict[str, str] = {
    "PortTypeRules.SameType_CustomTypeToCustomType": _TEST_POINT,
    "PortTypeRules.GenericPort_AcceptsInt": _GENERIC,
    "PortTypeRules.GenericPort_AcceptsString": _GENERIC,
    "PortTypeRules.GenericOutput_ToTypedInput": _GENERIC,
    "PortTypeRules.StringToCustomType_ViaConvertFromString": _TEST_POINT,
    "PortTypeRules.StringToVector_ViaConvertFromString": _VECTOR,
    "PortTypeRules.SubtreeStringInput_ToTypedPort": _VECTOR + ", through a SubTree port",
    "PortTypeRules.BlackboardSetString_CreatesGenericEntry": _BB_API + "bb->set(std::string) then "
    "entryInfo()->isStronglyTyped()",
    "PortTypeRules.BlackboardSetInt_CreatesStronglyTypedEntry": _BB_API + "bb->set(int) then entryInfo()->type() "
    "== typeid(int)",
    "PortTypeRules.StringEntry_CanBecomeTyped": _BB_API + "entryInfo()->isStronglyTyped() before and after "
    "bb->set(int) over a string",
    "PortTypeRules.TypeLock_CannotChangeAfterTypedWrite": _BB_API + "bb->set(std::string) / bb->set(double) over an "
    "int entry must throw",
    "PortTypeRules.TypeLock_CustomTypeChange_Fails": _TEST_POINT + "; a TestPoint output then an int input",
    "PortTypeRules.SafeCast_IntToUint8_InRange": _BB_API + "bb->set<uint8_t> then bb->set(int) (C++ integer widths)",
    "PortTypeRules.SafeCast_IntToUint8_Overflow": _BB_API + "bb->set<uint8_t> then bb->set(int(300)) throws "
    "LogicError (C++ integer widths)",
    "PortTypeRules.SafeCast_IntToUint8_Negative": _BB_API + "bb->set<uint8_t> then bb->set(int(-1)) throws "
    "LogicError (C++ integer widths)",
    "PortTypeRules.SafeCast_DifferentIntTypes_NotAllowed": _BB_API + "bb->set<int64_t> then bb->set(int) throws "
    "(C++ integer widths)",
    "PortTypeRules.BTAny_WrapperDoesNotBypassTypeCheck": _BB_API + "bb->set(BT::Any(42)) then "
    'bb->set(BT::Any("hello")) throws',
    "PortTypeRules.BTAny_EntryType_AllowsDifferentTypes": _BB_API + "createEntry(TypeInfo::Create<BT::Any>()) "
    "then sets of BT::Any values",
    "PortTypeRules.BTAny_Port_AcceptsDifferentTypes": _BT_ANY,
    "PortTypeRules.BTAny_InputPort_ReadsAsString": _BT_ANY + " (an InputPort<BT::Any> read with getInput<std::string>)",
    "PortTypeRules.IsStronglyTyped_TypeInfo": "tests the C++ TypeInfo::isStronglyTyped() API, no XML",
    "PortTypeRules.GenericPortDeclaration_DefaultsToAnyTypeAllowed": "tests the C++ InputPort<>() declaration "
    "(PortInfo::type() == typeid(AnyTypeAllowed)), no XML",
    "PortTypeRules.GenericToTyped_ChainThroughBlackboard": _GENERIC,
    "PortTypeRules.MixedTypesWithGenericIntermediate": _GENERIC,
    "PortTypeRules.CustomTypeStringLiteral_ValidFormat": _TEST_POINT,
    "PortTypeRules.CustomTypeStringLiteral_InvalidFormat": _TEST_POINT,
}


# ----------------------------------------------------------------------------- test nodes
def _typed_node(kind: type, factor: Any = None) -> tuple[Any, list[tuple[str, type, Any]]]:
    """NodeWithIntPorts (output = 2 * input) / NodeWithStringPorts / NodeWithDoublePorts (output = input): an input
    that cannot be read makes the node fail (getInput fails → FAILURE; ours fails before the tick)."""

    def tick(node: SimpleAction) -> str:
        value = node.input("input")
        node.set_output("output", value * factor if factor is not None else value)
        return "SUCCESS"

    return tick, [("input", kind, port()), ("output", kind, port(direction="output"))]


def register_int(bt: Harness) -> None:
    bt.register_simple_action("NodeWithIntPorts", *_typed_node(int, 2))


def register_string(bt: Harness) -> None:
    bt.register_simple_action("NodeWithStringPorts", *_typed_node(str))


def register_double(bt: Harness) -> None:
    bt.register_simple_action("NodeWithDoublePorts", *_typed_node(float))


def get_as(tree: Tree, key: str, kind: type) -> Any:
    """``tree.rootBlackboard()->get<T>(key)``: the entry as `kind`, text converted (convertFromString)."""
    return Port(kind).coerce(tree.get(key))


def assert_double_eq(actual: float, expected: float) -> None:
    """ASSERT_DOUBLE_EQ: equal within 4 ULPs."""
    assert math.isclose(actual, expected, rel_tol=4 * 2.0**-52, abs_tol=0.0), f"{actual} != {expected}"


@dataclass
class TestPoint:
    """The C++ ``struct TestPoint { double x; double y; }``, set into the blackboard by the test."""

    __test__ = False  # not a pytest class
    x: float = 0.0
    y: float = 0.0


@pytest.fixture
def bt(tmp_path):
    return Harness(tmp_path)


# ----------------------------------------------------------------------------- Rule 1: same type
@TEST("PortTypeRules.SameType_IntToInt")
def test_same_type_int_to_int(bt):
    register_int(bt)
    xml = """
    <root BTCPP_format="4">
      <BehaviorTree>
        <Sequence>
          <NodeWithIntPorts input="21" output="{value}"/>
          <NodeWithIntPorts input="{value}" output="{result}"/>
        </Sequence>
      </BehaviorTree>
    </root>
  """
    tree = bt.load(xml)
    status = tree.tick_while_running()
    assert status == "SUCCESS"
    assert get_as(tree, "result", int) == 84  # 21 * 2 * 2


@TEST("PortTypeRules.SameType_StringToString")
def test_same_type_string_to_string(bt):
    register_string(bt)
    xml = """
    <root BTCPP_format="4">
      <BehaviorTree>
        <Sequence>
          <NodeWithStringPorts input="hello" output="{value}"/>
          <NodeWithStringPorts input="{value}" output="{result}"/>
        </Sequence>
      </BehaviorTree>
    </root>
  """
    tree = bt.load(xml)
    status = tree.tick_while_running()
    assert status == "SUCCESS"
    assert get_as(tree, "result", str) == "hello"


# ----------------------------------------------------------------------------- Rule 3: string as universal donor
@TEST("PortTypeRules.StringToInt_ViaConvertFromString")
def test_string_to_int_via_convert_from_string(bt):
    register_int(bt)
    # SetBlackboard creates a string entry, but NodeWithIntPorts expects int
    xml = """
    <root BTCPP_format="4">
      <BehaviorTree>
        <Sequence>
          <SetBlackboard value="42" output_key="value"/>
          <NodeWithIntPorts input="{value}" output="{result}"/>
        </Sequence>
      </BehaviorTree>
    </root>
  """
    tree = bt.load(xml)
    status = tree.tick_while_running()
    assert status == "SUCCESS"
    assert get_as(tree, "result", int) == 84  # 42 * 2


@TEST("PortTypeRules.StringToDouble_ViaConvertFromString")
def test_string_to_double_via_convert_from_string(bt):
    register_double(bt)
    xml = """
    <root BTCPP_format="4">
      <BehaviorTree>
        <Sequence>
          <SetBlackboard value="3.14" output_key="value"/>
          <NodeWithDoublePorts input="{value}" output="{result}"/>
        </Sequence>
      </BehaviorTree>
    </root>
  """
    tree = bt.load(xml)
    status = tree.tick_while_running()
    assert status == "SUCCESS"
    assert_double_eq(get_as(tree, "result", float), 3.14)


# ----------------------------------------------------------------------------- Rule 5: type lock
@TEST("PortTypeRules.TypeLock_XMLTreeCreation_TypeMismatch")
def test_type_lock_xml_tree_creation_type_mismatch(bt):
    register_int(bt)
    register_string(bt)
    # First node creates int entry, second expects string - should fail
    xml = """
    <root BTCPP_format="4">
      <BehaviorTree>
        <Sequence>
          <NodeWithIntPorts input="42" output="{value}"/>
          <NodeWithStringPorts input="{value}" output="{result}"/>
        </Sequence>
      </BehaviorTree>
    </root>
  """
    with pytest.raises(TreeError):  # BT.CPP: createTreeFromText throws RuntimeError
        bt.load(xml)


@TEST("PortTypeRules.TypeLock_IntToDouble_Fails")
def test_type_lock_int_to_double_fails(bt):
    register_int(bt)
    register_double(bt)
    # int output to double input - type mismatch
    xml = """
    <root BTCPP_format="4">
      <BehaviorTree>
        <Sequence>
          <NodeWithIntPorts input="42" output="{value}"/>
          <NodeWithDoublePorts input="{value}" output="{result}"/>
        </Sequence>
      </BehaviorTree>
    </root>
  """
    with pytest.raises(TreeError):  # BT.CPP: createTreeFromText throws RuntimeError
        bt.load(xml)


@pytest.mark.xfail(
    strict=True,
    reason="SetBlackboard copies any entry over any other (trees/actions.py SetBlackboard.bt_tick: a '{key}' value is "
    "written as is); BT.CPP refuses to change the type of an entry holding a TestPoint to std::string",
)
@TEST("PortTypeRules.TypeLock_RuntimeTypeChange_Fails")
def test_type_lock_runtime_type_change_fails(bt):
    # NodeWithTestPointPorts and NodeWithStringPorts are registered in C++ but not used by the XML; the TestPoint
    # is set into the blackboard by the test (a Python TestPoint here)
    register_string(bt)
    xml = """
    <root BTCPP_format="4">
      <BehaviorTree>
        <Sequence>
          <SetBlackboard value="{point_value}" output_key="other_point"/>
          <Sleep msec="5"/>
          <SetBlackboard value="{string_value}" output_key="other_point"/>
        </Sequence>
      </BehaviorTree>
    </root>
  """
    tree = bt.load(xml)
    tree.set("point_value", TestPoint(2, 7))
    tree.set("string_value", "Hello!")

    # First tick succeeds (creates entry as TestPoint)
    tree.tick_exactly_once()
    time.sleep(0.005)
    # Second tick fails (tries to change TestPoint to string): BT.CPP throws; an error here may also fail the
    # node instead (docs/btcpp.md "Differences")
    try:
        status = tree.tick_while_running()
    except Exception:
        return
    assert status == "FAILURE", "expected an error: the entry other_point holds a TestPoint, not a string"


# ----------------------------------------------------------------------------- edge cases
@TEST("PortTypeRules.StringLiteralValidation_InvalidFormat")
def test_string_literal_validation_invalid_format(bt):
    register_int(bt)
    # "not_a_number" cannot be converted to int
    xml = """
    <root BTCPP_format="4">
      <BehaviorTree>
        <NodeWithIntPorts input="not_a_number" output="{result}"/>
      </BehaviorTree>
    </root>
  """
    with pytest.raises(TreeError):  # BT.CPP: createTreeFromText throws LogicError
        bt.load(xml)


@TEST("PortTypeRules.StringLiteralValidation_ValidFormat")
def test_string_literal_validation_valid_format(bt):
    register_int(bt)
    # "42" can be converted to int
    xml = """
    <root BTCPP_format="4">
      <BehaviorTree>
        <NodeWithIntPorts input="42" output="{result}"/>
      </BehaviorTree>
    </root>
  """
    bt.load(xml)  # ASSERT_NO_THROW


@TEST("PortTypeRules.StringToDifferentTypes")
def test_string_to_different_types(bt):
    register_string(bt)
    register_int(bt)
    register_double(bt)
    # Missing second coordinate
    xml = """
    <root BTCPP_format="4">
      <BehaviorTree>
        <Sequence>
          <NodeWithStringPorts input="42" output="{value}"/>
          <NodeWithIntPorts input="{value}" output="{test_int}"/>
          <NodeWithDoublePorts input="{value}" output="{test_double}"/>
        </Sequence>
      </BehaviorTree>
    </root>
  """
    tree = bt.load(xml)
    tree.tick_while_running()
    assert get_as(tree, "test_int", int) == 84
    assert_double_eq(get_as(tree, "test_double", float), 42.0)


# ----------------------------------------------------------------------------- reserved port names
@TEST("PortTypeRules.ReservedPortName_ThrowsOnRegistration")
def test_reserved_port_name_throws_on_registration(bt):
    # Should throw because "name" is a reserved port name (BT.CPP: RuntimeError from registerNodeType)
    with pytest.raises(Exception):  # noqa: B017 - BT.CPP's EXPECT_THROW(…, RuntimeError)
        bt.register_simple_action("IllegalPortNameNode", lambda _node: "SUCCESS", [("name", str, port())])
