"""The tree loader: BehaviorTree.CPP v4 XML → py_trees, with every mistake caught before the first tick.

These tests use small test-only leaves (real py_trees behaviours declaring their ports) registered in a
local factory, so they specify the loader independently of the shipped behaviours
(tests/trees/test_tree_files.py loads the shipped trees with the shipped factory).
"""

from __future__ import annotations

import textwrap
from dataclasses import dataclass
from pathlib import Path
from typing import Any, ClassVar
from xml.etree import ElementTree

import py_trees
import pytest
from py_trees.common import Status

from mission.behaviours.ports import PortsDeclared, port
from mission.core import blackboard as bbk
from mission.core.errors import TreeError
from mission.trees.controls import Parallel
from mission.trees.decorators import RetryUntilSuccessful, Timeout
from mission.trees.factory import BehaviourFactory
from mission.trees.loader import describe_tree, load_tree, resolve_tree_path, shipped_trees, validate_tree
from mission.trees.tree_nodes_model import nodes_model_xml

# --------------------------------------------------------------------------- test-only behaviours
BUILT: list[str] = []  # names of every test leaf constructed (to prove nothing is built on errors)


class Probe(py_trees.behaviour.Behaviour, PortsDeclared):
    """A leaf with one port of every supported type; returns RUNNING."""

    @dataclass(frozen=True, kw_only=True)
    class Params:
        label: str = port("probe", "free text")
        gain: float = port(1.0, "a number")
        count: int = port(3, "a whole number")
        enabled: bool = port(True, "a flag")

    def __init__(self, name: str, **ports: Any) -> None:
        super().__init__(name)
        BUILT.append(name)
        self.params = self.bind_params(ports)

    def update(self) -> Status:
        self.feedback_message = f"{self.params.label} x{self.params.gain}"
        return Status.RUNNING


class Scripted(py_trees.behaviour.Behaviour, PortsDeclared):
    """Returns the statuses spelled in `script` (S/F/R), one per update, repeating the last one."""

    @dataclass(frozen=True, kw_only=True)
    class Params:
        script: str = port("S", "statuses to return: S, F or R per update")
        ticks: int = port(doc="updates so far", direction="output")

    CODES: ClassVar[dict[str, Status]] = {"S": Status.SUCCESS, "F": Status.FAILURE, "R": Status.RUNNING}

    def __init__(self, name: str, **ports: Any) -> None:
        super().__init__(name)
        BUILT.append(name)
        self.params = self.bind_params(ports)
        self.updates = 0
        self.halted = 0

    def update(self) -> Status:
        script = self.params.script
        status = self.CODES[script[min(self.updates, len(script) - 1)]]
        self.updates += 1
        self.set_output("ticks", self.updates)
        self.feedback_message = f"update {self.updates}: {status.name}"
        return status

    def terminate(self, new_status: Status) -> None:
        if new_status == Status.INVALID:
            self.halted += 1


class Ready(py_trees.behaviour.Behaviour, PortsDeclared):
    """A condition without ports."""

    NODE_TYPE = "Condition"

    def __init__(self, name: str) -> None:
        super().__init__(name)
        BUILT.append(name)

    def update(self) -> Status:
        self.feedback_message = "ready"
        return Status.SUCCESS


class NeedsMode(py_trees.behaviour.Behaviour, PortsDeclared):
    """A leaf with a required port."""

    @dataclass(frozen=True, kw_only=True)
    class Params:
        mode: str = port(doc="which mode")

    def __init__(self, name: str, **ports: Any) -> None:
        super().__init__(name)
        BUILT.append(name)
        self.mode = self.bind_params(ports).mode

    def update(self) -> Status:
        self.feedback_message = self.mode
        return Status.SUCCESS


@dataclass
class Wiring:
    """Something the application hands a behaviour (a client, a map service): a registration argument."""

    policy: str = "hybrid"


class WithDeps(py_trees.behaviour.Behaviour, PortsDeclared):
    """A leaf that takes a dependency: an extra constructor argument given when it is registered."""

    def __init__(self, name: str, *, deps: Wiring | None = None) -> None:
        super().__init__(name)
        BUILT.append(name)
        self.deps = deps

    def update(self) -> Status:
        self.feedback_message = "has deps"
        return Status.SUCCESS


class Rejects(py_trees.behaviour.Behaviour, PortsDeclared):
    """A leaf whose declaration checks a value's meaning (beyond its type)."""

    @dataclass(frozen=True, kw_only=True)
    class Params:
        waypoints: str = port("", "x,y;x,y")

        def __post_init__(self) -> None:
            if self.waypoints and "," not in self.waypoints:
                raise ValueError(f"waypoints expects 'x,y;x,y', got {self.waypoints!r}")

    def __init__(self, name: str, **ports: Any) -> None:
        super().__init__(name)
        BUILT.append(name)
        self.params = self.bind_params(ports)

    def update(self) -> Status:
        return Status.SUCCESS


class Gate(py_trees.decorators.Decorator, PortsDeclared):
    """A registered decorator: passes its child's status through unless closed."""

    @dataclass(frozen=True, kw_only=True)
    class Params:
        open: bool = port(True, "pass the child's status through")

    NODE_TYPE = "Decorator"

    def __init__(self, name: str, *, child: py_trees.behaviour.Behaviour, **ports: Any) -> None:
        super().__init__(name=name, child=child)
        self.open = self.bind_params(ports).open

    def update(self) -> Status:
        self.feedback_message = "open" if self.open else "closed"
        return self.decorated.status if self.open else Status.FAILURE


TEST_LEAVES: dict[str, type[PortsDeclared]] = {
    "TestProbe": Probe,
    "TestScripted": Scripted,
    "TestReady": Ready,
    "TestNeedsMode": NeedsMode,
    "TestWithDeps": WithDeps,
    "TestRejects": Rejects,
    "TestGate": Gate,
}


def leaf_factory(deps: Wiring | None = None) -> BehaviourFactory:
    """The test leaves under their Test* tags; `deps` is TestWithDeps's registration argument, when given."""
    factory = BehaviourFactory()
    for tag, cls in TEST_LEAVES.items():
        if cls is WithDeps and deps is not None:
            factory.register(cls, tag, deps=deps)
        else:
            factory.register(cls, tag)
    return factory


FACTORY = leaf_factory()


@pytest.fixture(autouse=True)
def _reset_built():
    BUILT.clear()


def write(directory: Path, name: str, body: str) -> Path:
    """A tree file: `body` (the <root> children) wrapped in a v4 <root>, unless it starts with '<?xml'/'<root'."""
    text = textwrap.dedent(body).strip("\n")
    if not text.lstrip().startswith(("<root", "<?xml")):
        text = '<root BTCPP_format="4">\n' + textwrap.indent(text, "  ") + "\n</root>"
    path = directory / name
    path.write_text(text + "\n")
    return path


def line_of(path: Path, needle: str) -> int:
    """1-based line of the first line in the file containing `needle`."""
    for number, line in enumerate(path.read_text().splitlines(), start=1):
        if needle in line:
            return number
    raise AssertionError(f"{needle!r} not in {path}")


def load(path: Path, factory: BehaviourFactory = FACTORY) -> py_trees.behaviour.Behaviour:
    return load_tree(path, factory)


def tick(root: py_trees.behaviour.Behaviour, times: int = 1) -> Status:
    tree = py_trees.trees.BehaviourTree(root)
    for _ in range(times):
        tree.tick()
    return root.status


# ------------------------------------------------------------------------------- building trees
def test_a_tree_file_becomes_py_trees_with_typed_port_values_and_names(tmp_path):
    path = write(
        tmp_path,
        "t.xml",
        """
        <BehaviorTree ID="Main">
          <Sequence name="steps">
            <TestProbe name="first" label="hello" gain="2.5" count="7" enabled="false"/>
            <TestProbe/>
          </Sequence>
        </BehaviorTree>
        """,
    )
    root = load(path)
    first, second = root.children
    assert isinstance(root, py_trees.composites.Sequence)
    assert root.name == "Main"  # a tree's root is named after its ID so viewers show it
    assert first.name == "first"
    assert first.params == Probe.Params(label="hello", gain=2.5, count=7, enabled=False)
    assert second.name == "TestProbe"
    assert second.params == Probe.Params()  # every port at its declared default
    assert second.params.enabled is True
    assert tick(root) == Status.RUNNING
    assert first.feedback_message == "hello x2.5"


@pytest.mark.parametrize(
    ("tag", "kind", "memory"),
    [
        ("Sequence", py_trees.composites.Sequence, True),
        ("ReactiveSequence", py_trees.composites.Sequence, False),
        ("Fallback", py_trees.composites.Selector, True),
        ("ReactiveFallback", py_trees.composites.Selector, False),
    ],
)
def test_bt_cpp_sequences_and_fallbacks_are_py_trees_composites_with_the_matching_memory(tmp_path, tag, kind, memory):
    path = write(tmp_path, "t.xml", f'<BehaviorTree ID="T"><{tag}><TestReady/><TestReady/></{tag}></BehaviorTree>')
    root = load(path)
    assert isinstance(root, kind)  # viewers (and py_trees' own display) draw them as what they are
    assert root.memory is memory


@pytest.mark.parametrize(
    ("decorator", "child_script", "ticks", "expected"),
    [
        ("<Inverter>", "S", 1, Status.FAILURE),
        ("<Inverter>", "F", 1, Status.SUCCESS),
        ("<ForceSuccess>", "F", 1, Status.SUCCESS),
        ("<ForceSuccess>", "R", 1, Status.RUNNING),
        ("<ForceFailure>", "S", 1, Status.FAILURE),
        # a child that finishes at once is restarted within the same tick (BT.CPP's tickOnce)
        ('<RetryUntilSuccessful num_attempts="3">', "FFS", 1, Status.SUCCESS),
        ('<RetryUntilSuccessful num_attempts="3">', "FFFS", 1, Status.FAILURE),
        ('<RetryUntilSuccessful num_attempts="-1">', "FFFFFS", 1, Status.SUCCESS),
        ('<RetryUntilSuccessful num_attempts="2">', "RFRS", 1, Status.RUNNING),
        ('<RetryUntilSuccessful num_attempts="2">', "RFRS", 2, Status.RUNNING),  # F, then R at once
        ('<RetryUntilSuccessful num_attempts="2">', "RFRS", 3, Status.SUCCESS),
        ('<Repeat num_cycles="3">', "S", 1, Status.SUCCESS),
        ('<Repeat num_cycles="3">', "SF", 1, Status.FAILURE),
        ('<Repeat num_cycles="3">', "SRS", 1, Status.RUNNING),
        ("<KeepRunningUntilFailure>", "SSF", 2, Status.RUNNING),
        ("<KeepRunningUntilFailure>", "SSF", 3, Status.FAILURE),
        ('<RunOnce then_skip="false">', "F", 3, Status.FAILURE),
    ],
)
def test_decorators_behave_like_bt_cpp(tmp_path, decorator, child_script, ticks, expected):
    tag = decorator[1:].split()[0].rstrip(">")
    path = write(
        tmp_path,
        "t.xml",
        f'<BehaviorTree ID="T">{decorator}<TestScripted script="{child_script}"/></{tag}></BehaviorTree>',
    )
    assert tick(load(path), ticks) == expected


def test_retry_until_successful_starts_a_failed_attempt_again_within_the_same_tick(tmp_path):
    path = write(
        tmp_path,
        "t.xml",
        '<BehaviorTree ID="T"><RetryUntilSuccessful num_attempts="3"><TestScripted script="RFS"/>'
        "</RetryUntilSuccessful></BehaviorTree>",
    )
    root = load(path)
    assert isinstance(root, RetryUntilSuccessful)
    leaf = root.decorated
    assert tick(root) == Status.RUNNING
    tree = py_trees.trees.BehaviourTree(root)
    tree.tick()  # the child fails after running: the next attempt starts at once, in this tick
    assert root.status == Status.SUCCESS
    assert leaf.updates == 3
    assert root.feedback_message == "1 of 3"


def test_a_repeat_for_ever_over_a_child_that_succeeds_at_once_hands_control_back_each_tick(tmp_path, caplog):
    path = write(
        tmp_path,
        "t.xml",
        '<BehaviorTree ID="T"><Repeat num_cycles="-1"><TestScripted script="S"/></Repeat></BehaviorTree>',
    )
    root = load(path)
    assert tick(root) == Status.RUNNING  # BT.CPP's tickOnce would never return here
    assert root.decorated.updates == 1001
    assert "woken up 1000 times within one tick" in caplog.text


def test_timeout_counts_msec_on_the_blackboard_clock_and_halts_its_child(tmp_path):
    path = write(
        tmp_path,
        "t.xml",
        '<BehaviorTree ID="T"><Timeout msec="500"><TestScripted script="R"/></Timeout></BehaviorTree>',
    )
    clock = bbk.writer("test clock")
    bbk.set_(clock, bbk.CLOCK, 100.0)
    root = load(path)
    assert isinstance(root, Timeout)
    tree = py_trees.trees.BehaviourTree(root)
    tree.tick()
    bbk.set_(clock, bbk.CLOCK, 100.4)  # sim time, not wall time: no sleeping here
    tree.tick()
    assert root.status == Status.RUNNING
    bbk.set_(clock, bbk.CLOCK, 100.6)
    tree.tick()
    assert root.status == Status.FAILURE
    assert root.feedback_message == "timed out after 0.5 s"
    assert root.decorated.halted == 1
    assert root.decorated.updates == 2  # as in BT.CPP, the timed-out child is halted, not ticked again


def test_timeout_of_zero_msec_means_no_timeout(tmp_path):
    body = '<BehaviorTree ID="T"><Timeout msec="0"><TestScripted script="R"/></Timeout></BehaviorTree>'
    path = write(tmp_path, "t.xml", body)
    clock = bbk.writer("test clock")
    bbk.set_(clock, bbk.CLOCK, 0.0)
    root = load(path)
    tree = py_trees.trees.BehaviourTree(root)
    for t in range(5):
        bbk.set_(clock, bbk.CLOCK, 1000.0 * t)
        tree.tick()
    assert root.status == Status.RUNNING and root.decorated.halted == 0


def test_delay_and_sleep_count_milliseconds_on_the_blackboard_clock(tmp_path):
    path = write(
        tmp_path,
        "t.xml",
        '<BehaviorTree ID="T"><Sequence><Sleep msec="300"/>'
        '<Delay delay_msec="200"><TestScripted name="late" script="S"/></Delay></Sequence></BehaviorTree>',
    )
    clock = bbk.writer("test clock")
    root = load(path)
    sleep, delay = root.children
    tree = py_trees.trees.BehaviourTree(root)
    seen = []
    for t in (10.0, 10.2, 10.3, 10.4, 10.5):  # sim seconds: nothing waits for the wall clock
        bbk.set_(clock, bbk.CLOCK, t)
        tree.tick()
        seen.append((sleep.status, delay.status, root.status))
    assert seen == [
        (Status.RUNNING, Status.INVALID, Status.RUNNING),  # asleep for 0.3 s
        (Status.RUNNING, Status.INVALID, Status.RUNNING),
        (Status.SUCCESS, Status.RUNNING, Status.RUNNING),  # awake at 10.3; the delay starts
        (Status.SUCCESS, Status.RUNNING, Status.RUNNING),
        (Status.SUCCESS, Status.SUCCESS, Status.SUCCESS),  # 0.2 s later the child runs
    ]
    assert delay.decorated.updates == 1


@pytest.mark.parametrize(
    ("attrs", "scripts", "expected"),
    [
        ("", ["S", "S"], Status.SUCCESS),  # default: all must succeed
        ("", ["S", "R"], Status.RUNNING),
        ("", ["R", "F"], Status.FAILURE),  # default failure_count = 1
        ('success_count="1"', ["R", "S"], Status.SUCCESS),
        ('success_count="2" failure_count="2"', ["F", "R", "S"], Status.RUNNING),
        ('success_count="2" failure_count="2"', ["F", "F", "R"], Status.FAILURE),
        ('success_count="3" failure_count="3"', ["F", "R", "S"], Status.FAILURE),  # success impossible
        ('success_count="-2"', ["S", "R", "S"], Status.SUCCESS),  # -2 of 3 = 2 children
    ],
)
def test_parallel_uses_bt_cpp_success_and_failure_thresholds(tmp_path, attrs, scripts, expected):
    children = "".join(f'<TestScripted script="{s}"/>' for s in scripts)
    path = write(tmp_path, "t.xml", f'<BehaviorTree ID="T"><Parallel {attrs}>{children}</Parallel></BehaviorTree>')
    root = load(path)
    assert isinstance(root, Parallel)
    assert isinstance(root, py_trees.composites.Parallel)  # viewers draw it as a parallel
    assert tick(root) == expected


def test_a_parallel_does_not_tick_finished_children_again_and_halts_running_ones_when_it_ends(tmp_path):
    path = write(
        tmp_path,
        "t.xml",
        '<BehaviorTree ID="T"><Parallel success_count="2">'
        '<TestScripted name="done" script="S"/><TestScripted name="slow" script="RS"/>'
        '<TestScripted name="bg" script="R"/>'
        "</Parallel></BehaviorTree>",
    )
    root = load(path)
    done, slow, bg = root.children
    assert tick(root, 2) == Status.SUCCESS
    assert done.updates == 1  # finished in tick 1, not ticked in tick 2
    assert slow.updates == 2
    assert bg.halted == 1


def test_explicit_groot_spelling_action_id_is_the_same_node(tmp_path):
    path = write(
        tmp_path,
        "t.xml",
        '<BehaviorTree ID="T"><Control ID="Sequence"><Action ID="TestProbe" gain="4"/>'
        '<Condition ID="TestReady"/></Control></BehaviorTree>',
    )
    root = load(path)
    assert isinstance(root, py_trees.composites.Sequence)
    assert root.children[0].params.gain == 4.0
    assert isinstance(root.children[1], Ready)


def test_dependencies_are_the_arguments_a_behaviour_was_registered_with_and_nothing_else(tmp_path):
    path = write(
        tmp_path, "t.xml", '<BehaviorTree ID="T"><Sequence><TestWithDeps/><TestWithDeps/></Sequence></BehaviorTree>'
    )
    deps = Wiring(policy="first")
    first, second = load(path, leaf_factory(deps)).children
    assert first.deps is deps and second.deps is deps  # every instance, the same object
    assert load(path, leaf_factory()).children[0].deps is None  # registered without: nothing is injected


def test_a_registered_decorator_class_gets_its_child_and_ports(tmp_path):
    path = write(
        tmp_path, "t.xml", '<BehaviorTree ID="T"><TestGate open="false"><TestReady/></TestGate></BehaviorTree>'
    )
    root = load(path)
    assert isinstance(root, Gate) and isinstance(root.decorated, Ready)
    assert tick(root) == Status.FAILURE


# ---------------------------------------------------------------------------------- SubTrees
def test_a_subtree_is_flattened_and_its_root_named_after_the_tree_id(tmp_path):
    path = write(
        tmp_path,
        "t.xml",
        """
        <root BTCPP_format="4" main_tree_to_execute="Main">
          <BehaviorTree ID="Main">
            <Sequence>
              <SubTree ID="Inner"/>
              <SubTree ID="Inner" name="inner again"/>
            </Sequence>
          </BehaviorTree>
          <BehaviorTree ID="Inner">
            <Fallback name="choose"><TestReady/><TestProbe/></Fallback>
          </BehaviorTree>
        </root>
        """,
    )
    root = load(path)
    first, second = root.children
    assert root.name == "Main"
    assert (first.name, second.name) == ("Inner", "inner again")
    assert isinstance(first, py_trees.composites.Selector)
    assert first.children[0] is not second.children[0]  # every use is its own instance
    assert tick(root) == Status.SUCCESS


def test_includes_are_relative_to_the_including_file_and_a_diamond_is_not_a_cycle(tmp_path):
    (tmp_path / "lib").mkdir()
    write(tmp_path / "lib", "leaf.xml", '<BehaviorTree ID="Leaf"><TestReady/></BehaviorTree>')
    for name in ("A", "B"):
        write(
            tmp_path / "lib",
            f"{name.lower()}.xml",
            f'<include path="leaf.xml"/><BehaviorTree ID="{name}"><SubTree ID="Leaf"/></BehaviorTree>',
        )
    main = write(
        tmp_path,
        "main.xml",
        """
        <include path="lib/a.xml"/>
        <include path="lib/b.xml"/>
        <BehaviorTree ID="Main"><Sequence><SubTree ID="A"/><SubTree ID="B"/></Sequence></BehaviorTree>
        """,
    )
    root = load(main)
    assert [c.name for c in root.children] == ["A", "B"]
    assert tick(root) == Status.SUCCESS


def test_a_users_tree_outside_trees_can_include_a_shipped_subtree_by_name(tmp_path):
    patrol = write(
        tmp_path,
        "patrol.xml",
        """
        <include path="follow.xml"/>
        <BehaviorTree ID="Patrol">
          <Sequence><Explore target="target" waypoints="2,2;6,2"/><SubTree ID="FollowTree"/></Sequence>
        </BehaviorTree>
        """,
    )
    nodes = {(n.tag, Path(n.file).name) for n in describe_tree(patrol).walk()}
    assert ("FollowTarget", "follow.xml") in nodes and ("Explore", "patrol.xml") in nodes
    wrong = write(tmp_path, "wrong.xml", '<include path="folow.xml"/><BehaviorTree ID="W"><Explore/></BehaviorTree>')
    with pytest.raises(TreeError, match=r"wrong\.xml:2: .*included file not found: .*shipped tree: .*follow\.xml"):
        validate_tree(wrong)


# ---------------------------------------------------------------------------------- the errors
A_TREE = (
    '<root BTCPP_format="4">\n  <BehaviorTree ID="T">\n    <Sequence>\n      {node}\n    </Sequence>\n'
    "  </BehaviorTree>\n</root>"
)

ERROR_CASES = {
    # id: (files {name: text}, needle on the offending line of main.xml or the named file, expected message tail)
    "malformed XML": (
        {"main.xml": '<root BTCPP_format="4">\n  <BehaviorTree ID="T">\n    <TestReady>\n  </BehaviorTree>\n</root>'},
        ("main.xml", "</BehaviorTree>"),
        "malformed XML: mismatched tag (column 5); expected a well-formed BehaviorTree.CPP v4 file",
    ),
    "empty file": (
        {"main.xml": ""},
        ("main.xml", ""),
        'empty file; expected <root BTCPP_format="4"> with a <BehaviorTree>',
    ),
    "tree ID that is a node's name": (
        {"main.xml": '<root BTCPP_format="4">\n  <BehaviorTree ID="TestProbe"><TestReady/></BehaviorTree>\n</root>'},
        ("main.xml", "BehaviorTree"),
        "<BehaviorTree ID=\"TestProbe\">: tree ID 'TestProbe' is also the registered action TestProbe, which "
        'BT.CPP 4.6.2+ refuses ("must not use the name of a registered Node"); rename the tree, e.g. '
        'TestProbeTree, and its <SubTree ID="TestProbe"> references',
    ),
    "tree ID that is a built-in's name": (
        {"main.xml": '<root BTCPP_format="4">\n  <BehaviorTree ID="Sleep"><TestReady/></BehaviorTree>\n</root>'},
        ("main.xml", "BehaviorTree"),
        "<BehaviorTree ID=\"Sleep\">: tree ID 'Sleep' is also a BT.CPP built-in Sleep, which BT.CPP 4.6.2+ refuses",
    ),
    "wrong BTCPP_format": (
        {"main.xml": '<root BTCPP_format="3">\n  <BehaviorTree ID="T"><TestReady/></BehaviorTree>\n</root>'},
        ("main.xml", "<root"),
        '<root>: BTCPP_format="3" is not supported; expected "4"',
    ),
    "missing BTCPP_format": (
        {"main.xml": '<root>\n  <BehaviorTree ID="T"><TestReady/></BehaviorTree>\n</root>'},
        ("main.xml", "<root"),
        '<root>: missing BTCPP_format="4"; this loader reads BehaviorTree.CPP v4 files',
    ),
    "unknown tag": (
        {"main.xml": A_TREE.format(node="<TestProbee/>")},
        ("main.xml", "TestProbee"),
        "<TestProbee>: unknown node 'TestProbee' (did you mean TestProbe?); expected a registered behaviour (",
    ),
    "unknown port": (
        {"main.xml": A_TREE.format(node='<TestProbe gian="2"/>')},
        ("main.xml", "gian"),
        "<TestProbe>: unknown port 'gian' (did you mean gain?); TestProbe ports: label, gain, count, enabled",
    ),
    "missing required port": (
        {"main.xml": A_TREE.format(node="<TestNeedsMode/>")},
        ("main.xml", "TestNeedsMode"),
        "<TestNeedsMode>: missing required port mode (str); which mode",
    ),
    "wrong type float": (
        {"main.xml": A_TREE.format(node='<TestProbe gain="far"/>')},
        ("main.xml", "far"),
        "<TestProbe>: port gain expects float, got 'far'",
    ),
    "wrong type int": (
        {"main.xml": A_TREE.format(node='<TestProbe count="1.5"/>')},
        ("main.xml", "1.5"),
        "<TestProbe>: port count expects int, got '1.5'",
    ),
    "wrong type bool": (
        {"main.xml": A_TREE.format(node='<TestProbe enabled="maybe"/>')},
        ("main.xml", "maybe"),
        "<TestProbe>: port enabled expects bool (true/false), got 'maybe'",
    ),
    "blackboard key with a dot": (
        {"main.xml": A_TREE.format(node='<TestProbe label="{goal.x}"/>')},
        ("main.xml", "{goal.x}"),
        "<TestProbe>: port label=\"{{goal.x}}\": '.' cannot be part of a key here; expected a blackboard key",
    ),
    "an entry used with two types": (
        {"main.xml": A_TREE.format(node='<TestProbe gain="{g}"/>\n      <TestProbe count="{g}"/>')},
        ("main.xml", 'count="{g}"'),
        "<TestProbe>: port count: blackboard entry {{g}} is int here but float for port gain of <TestProbe> at ",
    ),
    "unknown subtree": (
        {"main.xml": A_TREE.format(node='<SubTree ID="Missing"/>')},
        ("main.xml", "Missing"),
        "<SubTree ID=\"Missing\">: unknown subtree 'Missing'; trees defined: T",
    ),
    "subtree recursion": (
        {
            "main.xml": '<root BTCPP_format="4" main_tree_to_execute="A">\n'
            '  <BehaviorTree ID="A"><SubTree ID="B"/></BehaviorTree>\n'
            '  <BehaviorTree ID="B">\n    <Sequence><TestReady/><SubTree ID="A"/></Sequence>\n  </BehaviorTree>\n'
            "</root>"
        },
        ("main.xml", '<SubTree ID="A"/>'),
        '<SubTree ID="A">: recursive subtree: A → B → A; a tree cannot contain itself',
    ),
    "subtree model port not remapped": (
        {
            "main.xml": '<root BTCPP_format="4" main_tree_to_execute="A">\n'
            '  <BehaviorTree ID="A">\n    <SubTree ID="B"/>\n  </BehaviorTree>\n'
            '  <BehaviorTree ID="B"><TestProbe label="{who}"/></BehaviorTree>\n'
            '  <TreeNodesModel><SubTree ID="B"><input_port name="who"/></SubTree></TreeNodesModel>\n</root>'
        },
        ("main.xml", '<SubTree ID="B"/>'),
        '<SubTree ID="B">: the <SubTree ID="B"> model ({dir}/main.xml:6) has a mandatory port who, which this '
        'SubTree does not remap; add who="{{key}}" or a value',
    ),
    "output port given a constant": (
        {"main.xml": A_TREE.format(node='<TestScripted ticks="3"/>')},
        ("main.xml", "ticks"),
        '<TestScripted>: port ticks="3" is an output: it takes a blackboard entry to write, such as ticks="{{ticks}}"',
    ),
    "missing include file": (
        {
            "main.xml": '<root BTCPP_format="4">\n  <include path="nowhere.xml"/>\n'
            '  <BehaviorTree ID="T"><TestReady/></BehaviorTree>\n</root>'
        },
        ("main.xml", "nowhere"),
        '<include path="nowhere.xml">: included file not found: {dir}/nowhere.xml '
        "(paths are relative to this file, or name a shipped tree: ",
    ),
    "include cycle": (
        {
            "main.xml": '<root BTCPP_format="4">\n  <include path="other.xml"/>\n'
            '  <BehaviorTree ID="T"><TestReady/></BehaviorTree>\n</root>',
            "other.xml": '<root BTCPP_format="4">\n  <include path="main.xml"/>\n</root>',
        },
        ("other.xml", "main.xml"),
        '<include path="main.xml">: include cycle: {dir}/main.xml → {dir}/other.xml → {dir}/main.xml',
    ),
    "decorator with two children": (
        {"main.xml": A_TREE.format(node="<Inverter><TestReady/><TestReady/></Inverter>")},
        ("main.xml", "Inverter"),
        "<Inverter>: decorator has 2 children; expected exactly 1",
    ),
    "leaf with children": (
        {"main.xml": A_TREE.format(node="<TestProbe><TestReady/></TestProbe>")},
        ("main.xml", "<TestProbe>"),
        "<TestProbe>: action node has 1 child; expected none",
    ),
    "control without children": (
        {"main.xml": A_TREE.format(node="<Fallback/>")},
        ("main.xml", "Fallback"),
        "<Fallback>: control node has no children; expected at least 1",
    ),
    "required control port": (
        {"main.xml": A_TREE.format(node="<Repeat><TestReady/></Repeat>")},
        ("main.xml", "Repeat"),
        "<Repeat>: missing required port num_cycles (int); successful cycles before SUCCESS (-1 = forever)",
    ),
    "retry with zero attempts": (
        {"main.xml": A_TREE.format(node='<RetryUntilSuccessful num_attempts="0"><TestReady/></RetryUntilSuccessful>')},
        ("main.xml", "RetryUntilSuccessful"),
        "<RetryUntilSuccessful>: port num_attempts expects an int ≥ 1 (or -1 for no limit), got 0",
    ),
    "parallel threshold above its children": (
        {"main.xml": A_TREE.format(node='<Parallel success_count="3"><TestReady/><TestReady/></Parallel>')},
        ("main.xml", "Parallel"),
        "<Parallel>: port success_count=3 means 3 of 2 children; expected 1..2 (or -1 for all)",
    ),
    "unknown underscore attribute": (
        {"main.xml": A_TREE.format(node='<TestReady _skipif="done"/>')},
        ("main.xml", "_skipif"),
        "<TestReady>: unknown attribute '_skipif' (did you mean _skipIf?); BT.CPP's are _failureIf, _successIf, ",
    ),
    "two trees without a main": (
        {
            "main.xml": '<root BTCPP_format="4">\n  <BehaviorTree ID="A"><TestReady/></BehaviorTree>\n'
            '  <BehaviorTree ID="B"><TestReady/></BehaviorTree>\n</root>'
        },
        ("main.xml", "<root"),
        '<root>: the file defines 2 trees (A, B); expected exactly one <BehaviorTree ID="..."> '
        'or main_tree_to_execute="ID"',
    ),
    "unknown main tree": (
        {
            "main.xml": '<root BTCPP_format="4" main_tree_to_execute="Mian">\n'
            '  <BehaviorTree ID="Main"><TestReady/></BehaviorTree>\n</root>'
        },
        ("main.xml", "<root"),
        '<root>: main_tree_to_execute="Mian" names no tree; trees defined: Main',
    ),
    "tree defined twice": (
        {
            "main.xml": '<root BTCPP_format="4">\n  <include path="other.xml"/>\n'
            '  <BehaviorTree ID="T"><TestReady/></BehaviorTree>\n</root>',
            "other.xml": '<root BTCPP_format="4">\n  <BehaviorTree ID="T"><TestReady/></BehaviorTree>\n</root>',
        },
        ("main.xml", '<BehaviorTree ID="T">'),
        '<BehaviorTree ID="T">: tree T is already defined at {dir}/other.xml:2',
    ),
    "behaviour tree with two roots": (
        {
            "main.xml": '<root BTCPP_format="4">\n  <BehaviorTree ID="T">\n    <TestReady/><TestReady/>\n'
            "  </BehaviorTree>\n</root>"
        },
        ("main.xml", "<BehaviorTree"),
        '<BehaviorTree ID="T">: has 2 root nodes; expected exactly one',
    ),
    "unexpected element under root": (
        {"main.xml": '<root BTCPP_format="4">\n  <BehaviourTree ID="T"><TestReady/></BehaviourTree>\n</root>'},
        ("main.xml", "BehaviourTree"),
        '<BehaviourTree ID="T">: unexpected element; expected <BehaviorTree>, <include> or <TreeNodesModel>',
    ),
}


@pytest.mark.parametrize("case", list(ERROR_CASES), ids=list(ERROR_CASES))
def test_a_bad_tree_fails_before_anything_is_built_naming_file_line_element_and_what_was_expected(tmp_path, case):
    files, (bad_file, needle), tail = ERROR_CASES[case]
    for name, text in files.items():
        (tmp_path / name).write_text(text + "\n")
    directory = str(tmp_path.resolve())
    bad = tmp_path / bad_file
    expected = f"{bad.resolve()}:{line_of(bad, needle)}: {tail.format(dir=directory)}"

    with pytest.raises(TreeError) as validated:
        validate_tree(tmp_path / "main.xml", FACTORY)
    with pytest.raises(TreeError) as loaded:
        load(tmp_path / "main.xml")

    message = str(loaded.value)
    assert message.startswith(expected), message
    assert "\n" not in message
    assert str(validated.value) == message
    assert BUILT == []  # nothing was constructed, so nothing was ticked


def test_a_bad_node_late_in_the_file_stops_loading_before_the_good_nodes_before_it_are_built(tmp_path):
    path = write(
        tmp_path,
        "t.xml",
        """
        <BehaviorTree ID="T">
          <Sequence>
            <TestProbe name="fine"/>
            <TestReady/>
            <FollowTheLeader/>
          </Sequence>
        </BehaviorTree>
        """,
    )
    with pytest.raises(TreeError, match=rf"t\.xml:{line_of(path, 'FollowTheLeader')}: <FollowTheLeader>: unknown node"):
        load(path)
    assert BUILT == []


def test_every_problem_in_a_file_is_collected_and_the_first_is_the_message(tmp_path):
    path = write(
        tmp_path,
        "t.xml",
        """
        <BehaviorTree ID="T">
          <Sequence>
            <TestProbe gain="far"/>
            <Nope/>
            <TestNeedsMode/>
          </Sequence>
        </BehaviorTree>
        """,
    )
    with pytest.raises(TreeError) as err:
        validate_tree(path, FACTORY)
    problems = err.value.problems
    assert [p.split(": ")[1] for p in problems] == ["<TestProbe>", "<Nope>", "<TestNeedsMode>"]
    assert str(err.value) == problems[0]


def test_errors_in_an_included_file_name_the_included_file(tmp_path):
    write(tmp_path, "lib.xml", '<BehaviorTree ID="Lib">\n  <TestProbe count="many"/>\n</BehaviorTree>')
    main = write(
        tmp_path, "main.xml", '<include path="lib.xml"/>\n<BehaviorTree ID="Main"><SubTree ID="Lib"/></BehaviorTree>'
    )
    with pytest.raises(TreeError) as err:
        load(main)
    assert str(err.value) == f"{(tmp_path / 'lib.xml').resolve()}:3: <TestProbe>: port count expects int, got 'many'"


def test_an_unused_tree_in_the_file_is_checked_too(tmp_path):
    path = write(
        tmp_path,
        "t.xml",
        """
        <root BTCPP_format="4" main_tree_to_execute="Main">
          <BehaviorTree ID="Main"><TestReady/></BehaviorTree>
          <BehaviorTree ID="Spare"><TestProbe gain="x"/></BehaviorTree>
        </root>
        """,
    )
    with pytest.raises(TreeError, match="port gain expects float, got 'x'"):
        validate_tree(path, FACTORY)


def test_a_value_the_declaration_rejects_is_reported_where_it_was_written_before_anything_is_built(tmp_path):
    path = write(tmp_path, "t.xml", '<BehaviorTree ID="T">\n  <TestRejects waypoints="3"/>\n</BehaviorTree>')
    with pytest.raises(TreeError) as validated:
        validate_tree(path, FACTORY)
    with pytest.raises(TreeError) as loaded:
        load(path)
    assert str(validated.value) == str(loaded.value)
    assert str(loaded.value) == f"{path.resolve()}:3: <TestRejects>: waypoints expects 'x,y;x,y', got '3'"
    assert BUILT == []


def test_a_constructor_that_refuses_its_registration_arguments_is_reported_at_the_node(tmp_path):
    factory = BehaviourFactory()
    factory.register(Ready, "TestReady", mode="fast")  # Ready's constructor takes no such argument
    path = write(tmp_path, "t.xml", '<BehaviorTree ID="T">\n  <TestReady/>\n</BehaviorTree>')
    validate_tree(path, factory)  # the file itself is fine
    with pytest.raises(TreeError, match=rf"^{path.resolve()}:3: <TestReady>: .*unexpected keyword argument 'mode'"):
        load(path, factory)


# ------------------------------------------------------------------------------ finding trees
def test_a_tree_is_found_by_path_or_by_shipped_name():
    assert resolve_tree_path("follow") == resolve_tree_path("follow.xml")
    assert resolve_tree_path("follow.xml").parent == Path(__file__).resolve().parents[2] / "trees"
    assert resolve_tree_path("trees/dock.xml") == Path("trees/dock.xml")  # a path as given (cwd = repo)
    assert {"mission.xml", "explore.xml", "dock.xml", "follow.xml", "explore_dock.xml"} <= set(shipped_trees())


def test_an_unknown_tree_name_lists_the_shipped_trees():
    with pytest.raises(TreeError) as err:
        resolve_tree_path("folow.xml")
    assert str(err.value).startswith("folow.xml: tree file not found; expected a path to a BehaviorTree.CPP v4 XML")
    shipped = (
        "dock.xml, dock_robot.xml, explore.xml, explore_dock.xml, follow.xml, follow_object.xml, mission.xml, "
        "undock_robot.xml"
    )
    assert shipped in str(err.value)


# ------------------------------------------------------------------------------- description
def test_describe_tree_gives_kinds_ports_and_lines_without_building_anything(tmp_path):
    path = write(
        tmp_path,
        "t.xml",
        """
        <root BTCPP_format="4" main_tree_to_execute="Main">
          <BehaviorTree ID="Main">
            <ReactiveSequence name="top">
              <Inverter><TestReady/></Inverter>
              <SubTree ID="Inner"/>
            </ReactiveSequence>
          </BehaviorTree>
          <BehaviorTree ID="Inner">
            <TestProbe gain="2"/>
          </BehaviorTree>
        </root>
        """,
    )
    desc = describe_tree(path, FACTORY)
    assert BUILT == []
    rows = [(d.tag, d.name, d.kind, d.line) for d in desc.walk()]
    assert rows == [
        ("BehaviorTree", "Main", "SubTree", 2),
        ("ReactiveSequence", "top", "Control", 3),
        ("Inverter", "Inverter", "Decorator", 4),
        ("TestReady", "TestReady", "Condition", 4),
        ("SubTree", "Inner", "SubTree", 5),
        ("TestProbe", "TestProbe", "Action", 9),
    ]
    probe = desc.children[0].children[1].children[0]
    assert probe.ports == {"gain": 2.0}
    assert probe.effective_ports == {"label": "probe", "gain": 2.0, "count": 3, "enabled": True}
    assert desc.children[0].children[1].subtree == "Inner"
    assert probe.file == str(path.resolve())


# ------------------------------------------------------------------------------ Groot2 model
def test_nodes_model_describes_every_leaf_with_port_types_and_defaults_for_groot2():
    model = ElementTree.fromstring(nodes_model_xml(FACTORY))
    assert model.tag == "TreeNodesModel"
    assert [(n.tag, n.get("ID")) for n in model] == sorted(
        [
            ("Action", "TestNeedsMode"),
            ("Action", "TestProbe"),
            ("Action", "TestRejects"),
            ("Action", "TestScripted"),
            ("Action", "TestWithDeps"),
            ("Condition", "TestReady"),
            ("Decorator", "TestGate"),
        ],
        key=lambda row: row[1],
    )
    probe = model.find("Action[@ID='TestProbe']")
    ports = {p.get("name"): (p.tag, p.get("type"), p.get("default"), p.text) for p in probe}
    assert ports == {
        "label": ("input_port", "std::string", "probe", "free text"),
        "gain": ("input_port", "double", "1.0", "a number"),
        "count": ("input_port", "int", "3", "a whole number"),
        "enabled": ("input_port", "bool", "true", "a flag"),
    }
    mode = model.find("Action[@ID='TestNeedsMode']/input_port")
    assert mode.get("default") is None  # required: no default


def test_a_tree_nodes_model_section_in_a_user_file_is_ignored_by_the_loader(tmp_path):
    other = BehaviourFactory()
    other.register(Probe, "Other")
    path = write(
        tmp_path,
        "t.xml",
        '<BehaviorTree ID="T"><TestReady/></BehaviorTree>\n' + nodes_model_xml(other),
    )
    assert isinstance(load(path), Ready)
