"""BehaviorTree.CPP 4.10 tests/gtest_interface.cpp, translated (XML verbatim; see btcpp_harness.py)."""

from __future__ import annotations

from py_trees.behaviour import Behaviour
from py_trees.common import Status

from mission.behaviours.ports import PortsDeclared
from tests.trees.btcpp.btcpp_harness import TEST, Harness

#: TESTs of this file that only use the C++ API, and why they are not translated
SKIPPED: dict[str, str] = {}


class IMotor:
    """The interface."""

    def do_move(self) -> None:
        raise NotImplementedError


class LinearMotor(IMotor):
    """The implementation."""

    def __init__(self) -> None:
        self.moves = 0

    def do_move(self) -> None:
        self.moves += 1  # std::cout << ">> doMove"


xml_text = """
<root BTCPP_format="4">
    <BehaviorTree ID="MainTree">
        <Sequence name="root_sequence">
            <PathFollow/>
        </Sequence>
    </BehaviorTree>
</root>
"""


class PathFollow(Behaviour, PortsDeclared):
    """A node using the interface (a StatefulActionNode): onStart moves and is RUNNING, onRunning moves and
    succeeds."""

    def __init__(self, name: str, motor: IMotor) -> None:
        super().__init__(name)
        self.motor = motor
        self.started = False

    def initialise(self) -> None:
        self.started = False

    def update(self) -> Status:
        self.motor.do_move()
        if not self.started:  # onStart
            self.started = True
            return Status.RUNNING
        return Status.SUCCESS  # onRunning


@TEST("Factory.VirtualInterface_Issue_945")
def test_virtual_interface_issue_945(tmp_path):
    motor = LinearMotor()
    bt = Harness(tmp_path)
    bt.register(PathFollow, "PathFollow", motor=motor)  # registerNodeType<PathFollow>("PathFollow", std::ref(motor))

    tree = bt.load(xml_text)
    tree.tick_while_running()  # BT.CPP's TEST asserts nothing: creating and ticking must not throw
