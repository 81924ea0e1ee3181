"""BehaviorTree.CPP 4.10 tests/gtest_loop.cpp, translated (XML verbatim; see btcpp_harness.py).

BT.CPP's blackboard queues are ``std::shared_ptr<std::deque<T>>`` and ``std::vector<T>``; here they are a
``collections.deque`` (the shared queue the Loop pops) and a list.
"""

from __future__ import annotations

from collections import deque

from tests.trees.btcpp.btcpp_harness import TEST, Harness, port

_CONVERT = "tests the C++ template BT::convertFromString<SharedQueue<{}>>() directly (no XML, no tree)"

#: TESTs of this file that only use the C++ API, and why they are not translated
SKIPPED: dict[str, str] = {
    "LoopNode.ConvertFromString_Int": _CONVERT.format("int"),
    "LoopNode.ConvertFromString_Double": _CONVERT.format("double"),
    "LoopNode.ConvertFromString_Bool": _CONVERT.format("bool"),
    "LoopNode.ConvertFromString_String": _CONVERT.format("std::string"),
}


def register_record(bt: Harness, tag: str, kind: type) -> list:
    """``registerSimpleAction(tag, …, {InputPort<kind>("value")})``: records every value it reads, SUCCESS."""
    received_values: list = []

    def record(node):
        received_values.append(node.input("value"))
        return "SUCCESS"

    bt.register_simple_action(tag, record, [("value", kind, port())])
    return received_values


def register_count_ticks(bt: Harness) -> list[int]:
    """``registerSimpleAction("CountTicks", …)``: counts its ticks in [tick_count], SUCCESS."""
    tick_count = [0]

    def count_ticks(_node):
        tick_count[0] += 1
        return "SUCCESS"

    bt.register_simple_action("CountTicks", count_ticks)
    return tick_count


# ============ LoopNode with static queue (string parsed) ============


@TEST("LoopNode.StaticIntQueue")
def test_static_int_queue(tmp_path):
    bt = Harness(tmp_path)
    received_values = register_record(bt, "RecordIntValue", int)

    xml_text = """
    <root BTCPP_format="4">
       <BehaviorTree>
          <LoopInt queue="1;2;3;4;5" value="{val}">
            <RecordIntValue value="{val}"/>
          </LoopInt>
       </BehaviorTree>
    </root>"""
    tree = bt.load(xml_text)
    status = tree.tick_while_running()

    assert status == "SUCCESS"
    assert len(received_values) == 5
    assert received_values[0] == 1
    assert received_values[1] == 2
    assert received_values[2] == 3
    assert received_values[3] == 4
    assert received_values[4] == 5


@TEST("LoopNode.StaticDoubleQueue")
def test_static_double_queue(tmp_path):
    bt = Harness(tmp_path)
    received_values = register_record(bt, "RecordDoubleValue", float)

    xml_text = """
    <root BTCPP_format="4">
       <BehaviorTree>
          <LoopDouble queue="1.5;2.5;3.5" value="{val}">
            <RecordDoubleValue value="{val}"/>
          </LoopDouble>
       </BehaviorTree>
    </root>"""
    tree = bt.load(xml_text)
    status = tree.tick_while_running()

    assert status == "SUCCESS"
    assert len(received_values) == 3
    assert received_values[0] == 1.5  # EXPECT_DOUBLE_EQ
    assert received_values[1] == 2.5  # EXPECT_DOUBLE_EQ
    assert received_values[2] == 3.5  # EXPECT_DOUBLE_EQ


@TEST("LoopNode.StaticStringQueue")
def test_static_string_queue(tmp_path):
    bt = Harness(tmp_path)
    received_values = register_record(bt, "RecordStringValue", str)

    xml_text = """
    <root BTCPP_format="4">
       <BehaviorTree>
          <LoopString queue="hello;world;test" value="{val}">
            <RecordStringValue value="{val}"/>
          </LoopString>
       </BehaviorTree>
    </root>"""
    tree = bt.load(xml_text)
    status = tree.tick_while_running()

    assert status == "SUCCESS"
    assert len(received_values) == 3
    assert received_values[0] == "hello"
    assert received_values[1] == "world"
    assert received_values[2] == "test"


# ============ LoopNode with empty queue ============


@TEST("LoopNode.EmptyQueue_ReturnsSuccess")
def test_empty_queue_returns_success(tmp_path):
    bt = Harness(tmp_path)
    tick_count = register_count_ticks(bt)

    xml_text = """
    <root BTCPP_format="4">
       <BehaviorTree>
          <LoopInt queue="" if_empty="SUCCESS" value="{val}">
            <CountTicks/>
          </LoopInt>
       </BehaviorTree>
    </root>"""
    tree = bt.load(xml_text)
    status = tree.tick_while_running()

    assert status == "SUCCESS"
    assert tick_count[0] == 0  # Child should never be ticked


@TEST("LoopNode.EmptyQueue_ReturnsFailure")
def test_empty_queue_returns_failure(tmp_path):
    bt = Harness(tmp_path)
    tick_count = register_count_ticks(bt)

    xml_text = """
    <root BTCPP_format="4">
       <BehaviorTree>
          <LoopInt queue="" if_empty="FAILURE" value="{val}">
            <CountTicks/>
          </LoopInt>
       </BehaviorTree>
    </root>"""
    tree = bt.load(xml_text)
    status = tree.tick_while_running()

    assert status == "FAILURE"
    assert tick_count[0] == 0


@TEST("LoopNode.EmptyQueue_ReturnsSkipped")
def test_empty_queue_returns_skipped(tmp_path):
    bt = Harness(tmp_path)
    tick_count = register_count_ticks(bt)

    xml_text = """
    <root BTCPP_format="4">
       <BehaviorTree>
          <LoopInt queue="" if_empty="SKIPPED" value="{val}">
            <CountTicks/>
          </LoopInt>
       </BehaviorTree>
    </root>"""
    tree = bt.load(xml_text)
    status = tree.tick_while_running()

    assert status == "SKIPPED"
    assert tick_count[0] == 0


# ============ LoopNode with child failure ============


@TEST("LoopNode.ChildFailure_StopsLoop")
def test_child_failure_stops_loop(tmp_path):
    bt = Harness(tmp_path)

    tick_count = 0

    def fail_on_third(_node):
        nonlocal tick_count
        tick_count += 1
        if tick_count == 3:
            return "FAILURE"
        return "SUCCESS"

    bt.register_simple_action("FailOnThird", fail_on_third)

    xml_text = """
    <root BTCPP_format="4">
       <BehaviorTree>
          <LoopInt queue="1;2;3;4;5" value="{val}">
            <FailOnThird/>
          </LoopInt>
       </BehaviorTree>
    </root>"""
    tree = bt.load(xml_text)
    status = tree.tick_while_running()

    assert status == "FAILURE"
    assert tick_count == 3  # Loop should stop at third iteration


# ============ LoopNode with dynamic queue from blackboard ============


@TEST("LoopNode.DynamicQueueFromBlackboard")
def test_dynamic_queue_from_blackboard(tmp_path):
    bt = Harness(tmp_path)
    received_values = register_record(bt, "RecordIntValue", int)

    xml_text = """
    <root BTCPP_format="4">
       <BehaviorTree>
          <LoopInt queue="{my_queue}" value="{val}">
            <RecordIntValue value="{val}"/>
          </LoopInt>
       </BehaviorTree>
    </root>"""
    tree = bt.load(xml_text)

    # Set up queue in blackboard
    queue = deque()
    queue.append(10)
    queue.append(20)
    queue.append(30)
    tree.set("my_queue", queue)

    status = tree.tick_while_running()

    assert status == "SUCCESS"
    assert len(received_values) == 3
    assert received_values[0] == 10
    assert received_values[1] == 20
    assert received_values[2] == 30


# ============ LoopNode with vector input (Issue #969) ============


@TEST("LoopNode.VectorInput_Issue969")
def test_vector_input_issue969(tmp_path):
    bt = Harness(tmp_path)
    received_values = register_record(bt, "RecordIntValue", int)

    xml_text = """
    <root BTCPP_format="4">
       <BehaviorTree>
          <LoopInt queue="{my_vector}" value="{val}">
            <RecordIntValue value="{val}"/>
          </LoopInt>
       </BehaviorTree>
    </root>"""
    tree = bt.load(xml_text)

    # Set up vector in blackboard (should be converted to deque)
    vec = [100, 200, 300]
    tree.set("my_vector", vec)

    status = tree.tick_while_running()

    assert status == "SUCCESS"
    assert len(received_values) == 3
    assert received_values[0] == 100
    assert received_values[1] == 200
    assert received_values[2] == 300


# ============ LoopNode with bool queue ============


@TEST("LoopNode.BoolQueue")
def test_bool_queue(tmp_path):
    bt = Harness(tmp_path)
    received_values = register_record(bt, "RecordBoolValue", bool)

    xml_text = """
    <root BTCPP_format="4">
       <BehaviorTree>
          <LoopBool queue="true;false;true" value="{val}">
            <RecordBoolValue value="{val}"/>
          </LoopBool>
       </BehaviorTree>
    </root>"""
    tree = bt.load(xml_text)
    status = tree.tick_while_running()

    assert status == "SUCCESS"
    assert len(received_values) == 3
    assert received_values[0]
    assert not received_values[1]
    assert received_values[2]


# ============ LoopNode restart behavior ============


@TEST("LoopNode.RestartAfterCompletion")
def test_restart_after_completion(tmp_path):
    bt = Harness(tmp_path)
    tick_count = register_count_ticks(bt)

    xml_text = """
    <root BTCPP_format="4">
       <BehaviorTree>
          <LoopInt queue="1;2;3" value="{val}">
            <CountTicks/>
          </LoopInt>
       </BehaviorTree>
    </root>"""
    tree = bt.load(xml_text)

    # First execution
    status = tree.tick_while_running()
    assert status == "SUCCESS"
    assert tick_count[0] == 3

    # Reset and execute again
    tree.halt()
    tick_count[0] = 0
    status = tree.tick_while_running()
    assert status == "SUCCESS"
    assert tick_count[0] == 3  # Should iterate over queue again


@TEST("LoopNode.RestartAfterCompletion_VectorFromBlackboard")
def test_restart_after_completion_vector_from_blackboard(tmp_path):
    bt = Harness(tmp_path)
    tick_count = register_count_ticks(bt)

    xml_text = """
    <root BTCPP_format="4">
       <BehaviorTree>
          <LoopInt queue="{my_vector}" value="{val}">
            <CountTicks/>
          </LoopInt>
       </BehaviorTree>
    </root>"""
    tree = bt.load(xml_text)
    tree.set("my_vector", [1, 2, 3])

    # First execution
    status = tree.tick_while_running()
    assert status == "SUCCESS"
    assert tick_count[0] == 3

    # Reset and execute again
    tree.halt()
    tick_count[0] = 0
    tree.set("my_vector", [1, 2, 3])
    status = tree.tick_while_running()
    assert status == "SUCCESS"
    assert tick_count[0] == 3  # Should iterate over vector again
