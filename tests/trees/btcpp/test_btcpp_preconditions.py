"""BehaviorTree.CPP 4.10 tests/gtest_preconditions.cpp, translated (XML verbatim; see btcpp_harness.py)."""

from __future__ import annotations

import pytest
from py_trees.behaviour import Behaviour
from py_trees.common import Status

from mission.behaviours.ports import PortsDeclared
from tests.trees.btcpp.btcpp_harness import TEST, Harness, port

#: TESTs of this file that only use the C++ API, and why they are not translated
SKIPPED: dict[str, str] = {}


class KeepRunning(Behaviour, PortsDeclared):
    """The C++ file's KeepRunning (a StatefulActionNode): RUNNING on start and on every tick after."""

    def __init__(self, name: str) -> None:
        super().__init__(name)
        self.halted = 0

    def update(self) -> Status:
        return Status.RUNNING

    def terminate(self, new_status: Status) -> None:
        if new_status == Status.INVALID:
            self.halted += 1  # "Node halted"


class CoroTestNode(Behaviour, PortsDeclared):
    """The C++ file's CoroTestNode (a CoroActionNode): RUNNING for 10 ticks, then SUCCESS; counts its ticks."""

    def __init__(self, name: str) -> None:
        super().__init__(name)
        self.times_ticked = 0
        self._i = 0

    def initialise(self) -> None:
        self._i = 0

    def update(self) -> Status:
        if self._i < 10:
            self._i += 1
            self.times_ticked += 1
            return Status.RUNNING
        return Status.SUCCESS


@pytest.fixture
def bt(tmp_path):
    """BehaviorTreeFactory factory;"""
    return Harness(tmp_path)


@TEST("PreconditionsDecorator.Integers")
def test_preconditions_decorator_integers(bt):
    counters = bt.register_test_tick("Test", 3)

    xml_text = """

    <root BTCPP_format="4" >
        <BehaviorTree ID="MainTree">
            <Sequence>
                <Script code = "A:=1; B:=1; C:=3" />
                <Precondition if="A==B" else="FAILURE">
                    <TestA/>
                </Precondition>
                <Precondition if="A==C" else="SUCCESS">
                    <TestB/>
                </Precondition>
                <Precondition if="A!=C" else="FAILURE">
                    <TestC/>
                </Precondition>
            </Sequence>
        </BehaviorTree>
    </root>"""

    tree = bt.load(xml_text)
    status = tree.tick_while_running()
    assert status == "SUCCESS"
    assert counters[0] == 1
    assert counters[1] == 0
    assert counters[2] == 1


@TEST("PreconditionsDecorator.DoubleEquals")
def test_preconditions_decorator_double_equals(bt):
    counters = bt.register_test_tick("Test", 3)

    xml_text = """

    <root BTCPP_format="4" >
        <BehaviorTree ID="MainTree">
            <Sequence>
                <Script code = " A:=1.1; B:=(1.0+0.1); C:= 2.0 " />

                <Precondition if="A==B" else="FAILURE">
                    <TestA/>
                </Precondition>

                <Precondition if="A==C" else="SUCCESS">
                    <TestB/>
                </Precondition>

                <Precondition if="A!=C" else="FAILURE">
                    <TestC/>
                </Precondition>
            </Sequence>
        </BehaviorTree>
    </root>"""

    tree = bt.load(xml_text)
    status = tree.tick_while_running()
    assert status == "SUCCESS"
    assert counters[0] == 1
    assert counters[1] == 0
    assert counters[2] == 1


@TEST("PreconditionsDecorator.StringEquals")
def test_preconditions_decorator_string_equals(bt):
    counters = bt.register_test_tick("Test", 2)

    xml_text = """

    <root BTCPP_format="4" >
        <BehaviorTree ID="MainTree">
            <Sequence>
                <Script code = "A:='hello'" />
                <Script code = "B:='world'" />
                <Script code = "C:='world'" />

                <Precondition if=" A==B " else="SUCCESS">
                    <TestA/>
                </Precondition>
                <Precondition if=" B==C " else="FAILURE">
                    <TestB/>
                </Precondition>
            </Sequence>
        </BehaviorTree>
    </root>"""

    tree = bt.load(xml_text)
    status = tree.tick_while_running()
    assert status == "SUCCESS"
    assert counters[0] == 0
    assert counters[1] == 1


@TEST("PreconditionsDecorator.ChecksConditionOnce")
def test_preconditions_decorator_checks_condition_once(bt):
    bt.register(KeepRunning, "KeepRunning")

    xml_text = """

    <root BTCPP_format="4" >
        <BehaviorTree ID="MainTree">
            <Sequence>
                <Script code = "A:=0" />
                <Script code = "B:=0" />
                <Precondition if=" A==0 " else="FAILURE">
                    <KeepRunning _while="B==0" />
                </Precondition>
            </Sequence>
        </BehaviorTree>
    </root>"""

    tree = bt.load(xml_text)

    assert tree.tick_once() == "RUNNING"
    # While the child is still running, attempt to fail the precondition.
    tree.set("A", 1)
    assert tree.tick_once() == "RUNNING"
    # Finish running the tree, the else condition should not be hit.
    tree.set("B", 1)
    assert tree.tick_once() == "SUCCESS"


@TEST("PreconditionsDecorator.CanRunChildrenMultipleTimes")
def test_preconditions_decorator_can_run_children_multiple_times(bt):
    bt.register(KeepRunning, "KeepRunning")
    counters = bt.register_test_tick("Test", 1)

    xml_text = """

    <root BTCPP_format="4" >
        <BehaviorTree ID="MainTree">
            <Sequence>
                <Script code = "A:=0" />
                <Script code = "B:=0" />
                <Script code = "C:=1" />
                <Repeat num_cycles="3">
                    <Sequence>
                        <Precondition if=" A==0 " else="SUCCESS">
                            <TestA/>
                        </Precondition>
                        <KeepRunning _while="C==0" />
                        <KeepRunning _while="B==0" />
                    </Sequence>
                </Repeat>
            </Sequence>
        </BehaviorTree>
    </root>"""

    tree = bt.load(xml_text)

    assert tree.tick_once() == "RUNNING"
    assert counters[0] == 1  # Precondition hit once;

    # In the second repeat, fail the precondition
    tree.set("A", 1)
    tree.set("B", 1)
    tree.set("C", 0)
    assert tree.tick_once() == "RUNNING"
    assert counters[0] == 1  # Precondition still only hit once.

    # Finally in the last repeat, hit the condition again.
    tree.set("A", 0)
    tree.set("C", 1)
    assert tree.tick_once() == "SUCCESS"
    assert counters[0] == 2  # Precondition hit twice now.


@TEST("Preconditions.Basic")
def test_preconditions_basic(bt):
    counters = bt.register_test_tick("Test", 4)

    xml_text = """

    <root BTCPP_format="4" >
        <BehaviorTree ID="MainTree">
            <Sequence>
                <Script code = "A:=1" />
                <TestA _successIf= "A==1"/>
                <TestB _successIf= "A==2"/>
                <Fallback>
                    <TestC _failureIf= "A==1"/>
                    <TestD _failureIf= "A!=1"/>
                </Fallback>
            </Sequence>
        </BehaviorTree>
    </root>"""

    tree = bt.load(xml_text)
    status = tree.tick_while_running()
    assert status == "SUCCESS"
    assert counters[0] == 0  # skipped
    assert counters[1] == 1  # executed
    assert counters[2] == 0  # skipped
    assert counters[3] == 1  # executed


@TEST("Preconditions.Issue533")
def test_preconditions_issue533(bt):
    counters = bt.register_test_tick("Test", 3)

    xml_text = """

    <root BTCPP_format="4" >
        <BehaviorTree ID="MainTree">
            <Sequence>
                <TestA _skipIf="A!=1" />
                <TestB _skipIf="A!=2" _onSuccess="A=1"/>
                <TestC _skipIf="A!=3" _onSuccess="A=2"/>
            </Sequence>
        </BehaviorTree>
    </root>"""

    tree = bt.load(xml_text)
    tree.set("A", 3)  # tree.subtrees.front()->blackboard->set("A", 3);

    tree.tick_once()
    assert counters[0] == 0
    assert counters[1] == 0
    assert counters[2] == 1

    tree.tick_once()
    assert counters[0] == 0
    assert counters[1] == 1
    assert counters[2] == 1

    tree.tick_once()
    assert counters[0] == 1
    assert counters[1] == 1
    assert counters[2] == 1


@TEST("Preconditions.Issue585")
def test_preconditions_issue585(bt):
    bt.register(CoroTestNode, "CoroTest")

    xml_text = """

    <root BTCPP_format="4" >
        <BehaviorTree ID="MainTree">
            <Sequence>
                <Script    code="A:=1" />
                <CoroTest _skipIf="A==1" />
            </Sequence>
        </BehaviorTree>
    </root>"""

    tree = bt.load(xml_text)
    tree.tick_while_running()

    (coro,) = [n for n in tree.nodes() if isinstance(n, CoroTestNode)]
    assert coro.times_ticked == 0


@TEST("Preconditions.Issue615_NoSkipWhenRunning_A")
def test_preconditions_issue615_no_skip_when_running_a(bt):
    xml_text = """
  <root BTCPP_format="4">
  <BehaviorTree>
    <KeepRunningUntilFailure _skipIf="check == true">
      <AlwaysSuccess/>
    </KeepRunningUntilFailure>
  </BehaviorTree>
  </root> """

    tree = bt.load(xml_text)

    tree.set("check", False)
    assert tree.tick_once() == "RUNNING"

    # the precondition should NOT be called, because
    # KeepRunningUntilFailure is in RUNNING state
    tree.set("check", True)
    assert tree.tick_once() == "RUNNING"


@TEST("Preconditions.Issue615_NoSkipWhenRunning_B")
def test_preconditions_issue615_no_skip_when_running_b(bt):
    xml_text = """
  <root BTCPP_format="4">
  <BehaviorTree>
    <KeepRunning _skipIf="check==false"/>
  </BehaviorTree>
  </root>
  """

    bt.register(KeepRunning, "KeepRunning")
    tree = bt.load(xml_text)

    tree.set("check", False)
    assert tree.tick_once() == "SKIPPED"

    # Should not be skipped anymore
    tree.set("check", True)
    assert tree.tick_once() == "RUNNING"

    # skipIf should be ignored, because KeepRunning is RUNNING and not IDLE
    tree.set("check", False)
    assert tree.tick_once() == "RUNNING"


@TEST("Preconditions.Remapping")
def test_preconditions_remapping(bt):
    xml_text = """
  <root BTCPP_format="4">

    <BehaviorTree ID="Main">
      <Sequence>
        <SimpleOutput  output="{param}" />
        <Script  code="value:=true" />

        <SubTree ID="Sub1" param="{param}"/>
        <SubTree ID="Sub1" param="{value}"/>
        <SubTree ID="Sub1" param="true"/>
        <TestA/>
      </Sequence>
    </BehaviorTree>

    <BehaviorTree ID="Sub1">
      <Sequence>
        <SubTree ID="Sub2" _skipIf="param != true" />
      </Sequence>
    </BehaviorTree>

    <BehaviorTree ID="Sub2">
      <TestB/>
    </BehaviorTree>
  </root>
  """

    def simple_output(node):  # SimpleOutput::tick
        node.set_output("output", True)
        return "SUCCESS"

    bt.register_simple_action("SimpleOutput", simple_output, [("output", bool, port(direction="output"))])
    counters = bt.register_test_tick("Test", 2)

    bt.register_tree_text(xml_text)
    tree = bt.load(main_tree="Main")

    status = tree.tick_while_running()

    assert status == "SUCCESS"
    assert counters[0] == 1
    assert counters[1] == 3


@TEST("Preconditions.WhileCallsOnHalt")
def test_preconditions_while_calls_on_halt(bt):
    xml_text = """
  <root BTCPP_format="4">

    <BehaviorTree ID="Main">
      <Sequence>
        <KeepRunning _while="A==1" _onHalted="B=69" />
      </Sequence>
    </BehaviorTree>
  </root>
  """

    bt.register(KeepRunning, "KeepRunning")
    bt.register_tree_text(xml_text)
    tree = bt.load(main_tree="Main")

    tree.set("A", 1)
    tree.set("B", 0)
    status = tree.tick_once()

    assert status == "RUNNING"
    assert tree.get("B") == 0

    # trigger halt
    tree.set("A", 0)
    status = tree.tick_once()

    assert status == "SKIPPED"
    assert tree.get("B") == 69


@TEST("Preconditions.SkippedSequence")
def test_preconditions_skipped_sequence(bt):
    xml_text = """
    <root BTCPP_format="4" >
        <BehaviorTree ID="MainTree">
            <Sequence>
                <AlwaysSuccess _skipIf="skip"/>
            </Sequence>
        </BehaviorTree>
    </root>"""

    tree = bt.load(xml_text)

    tree.set("skip", True)
    status = tree.tick_while_running()
    assert status == "SKIPPED"

    tree.set("skip", False)
    status = tree.tick_while_running()
    assert status == "SUCCESS"

    tree.set("skip", True)
    status = tree.tick_while_running()
    assert status == "SKIPPED"

    tree.set("skip", False)
    status = tree.tick_while_running()
    assert status == "SUCCESS"
