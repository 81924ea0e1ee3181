"""BehaviorTree.CPP's script language and blackboard ports in our trees: what a tree author writes and sees.

How the nodes tick is specified against real BT.CPP by tests/trees/test_conformance.py; these tests are about
the language itself, where the entries live (one store with the mission keys), and the errors at load time.
"""

from __future__ import annotations

import textwrap
from dataclasses import dataclass
from pathlib import Path
from typing import Any, ClassVar

import py_trees
import pytest
from py_trees.common import Status

from mission.behaviours.ports import PortsDeclared, port
from mission.core import blackboard as bbk
from mission.core.errors import TreeError
from mission.core.types import Pose2D
from mission.trees import scopes
from mission.trees.factory import BehaviourFactory, shipped_factory
from mission.trees.loader import load_tree, validate_tree
from mission.trees.script import ScriptError, ScriptSyntaxError, parse


class Entries:
    """A plain environment for scripts: a dict, the mission states as enums."""

    enums: ClassVar[dict[str, int]] = {"EXPLORE": 0, "DOCK": 1, "DONE": 5}

    def __init__(self, **values: Any) -> None:
        self.values = dict(values)

    def lookup(self, name: str) -> Any:
        return self.values[name]

    def assign(self, name: str, value: Any, create: bool) -> None:
        self.values[name] = value


@pytest.mark.parametrize(
    ("source", "result"),
    [
        ("1 + 2 * 3", 7.0),
        ("(1 + 2) * 3", 9.0),
        ("7 / 2", 3.5),
        ("-2 * 3", -6.0),
        ("0x10 | 1", 17.0),
        ("6 & 3", 2.0),
        ("6 ^ 3", 5.0),
        ("~0", -1.0),
        ("'ab' + 'cd'", "abcd"),
        ("'n=' .. 3", "n=3"),
        ("2 > 1 ? 'yes' : 'no'", "yes"),
        ("0 ? 1 : 0 ? 2 : 3", 3),
        ("1 < 2 < 3", True),
        ("3 > 2 > 2", False),
        ("true && !false", True),
        ("false || 1 == 1", True),
        ("0.1 + 0.2 == 0.3", True),
        ("'DONE' == DONE", True),
        ("DOCK == 1", True),
        ("'2.5' > 2", True),
        ("1 / 0", float("inf")),
    ],
)
def test_an_expression_evaluates_as_in_bt_cpp(source, result):
    assert parse(source).run(Entries()) == result


def test_assignments_create_or_update_entries_and_keep_a_numbers_type():
    env = Entries()
    parse("n := 1; n += 2; s := 'a'; s += 'b'; f := 1.5; f = 2").run(env)
    assert env.values == {"n": 3, "s": "ab", "f": 2.0}
    assert type(env.values["n"]) is int  # an integer entry stays an integer, as BT.CPP's Any::copyInto keeps it
    with pytest.raises(ScriptError, match=r"the blackboard entry \[m\] does not exist yet; use \[:=\]"):
        parse("m = 1").run(env)
    with pytest.raises(ScriptError, match=r"\[n\] holds an integer; 2.5 would be truncated"):
        parse("n = 2.5").run(env)
    with pytest.raises(ScriptError, match="variable not found: nope"):
        parse("nope + 1").run(env)


@pytest.mark.parametrize(
    ("source", "column", "message"),
    [
        ("x :=", 5, "unexpected end of script"),
        ("a := 1 b := 2", 8, "unexpected 'b'; separate statements with ';'"),
        ('s := "DONE"', 6, "unexpected character '\"' (strings use single quotes)"),
        ("1 := 2", 3, "unexpected ':=': only a blackboard entry's name can be assigned to"),
        ("(x", 3, "unexpected end of script; expected ')'"),
        ("", 1, "empty script"),
    ],
)
def test_a_syntax_error_says_where_in_the_script(source, column, message):
    with pytest.raises(ScriptSyntaxError) as err:
        parse(source)
    assert (err.value.line, err.value.column) == (1, column)
    assert err.value.message.startswith(message)


def write(tmp_path: Path, body: str, main: str | None = None) -> Path:
    path = tmp_path / "t.xml"
    head = f'<root BTCPP_format="4" main_tree_to_execute="{main}">' if main else '<root BTCPP_format="4">'
    path.write_text(head + "\n" + textwrap.dedent(body).strip("\n") + "\n</root>\n")
    return path


def test_a_script_error_in_a_tree_file_names_file_line_and_column_of_the_mistake(tmp_path):
    path = write(
        tmp_path,
        """
        <BehaviorTree ID="T">
          <Sequence>
            <Script code="ok := 1"/>
            <AlwaysSuccess _skipIf="ok ==== 1"/>
          </Sequence>
        </BehaviorTree>
        """,
    )
    with pytest.raises(TreeError) as err:
        validate_tree(path)
    column = path.read_text().splitlines()[4].index("ok ====") + len("ok ==") + 1
    assert str(err.value).startswith(f"{path.resolve()}:5:{column}: <AlwaysSuccess>: _skipIf: unexpected '=='")


def test_an_entity_in_the_xml_counts_as_the_character_it_stands_for_in_the_column(tmp_path):
    path = write(tmp_path, '<BehaviorTree ID="T"><Script code="a := 1 &amp;&amp; ; b"/></BehaviorTree>')
    with pytest.raises(TreeError) as err:
        validate_tree(path)
    line = path.read_text().splitlines()[1]
    assert str(err.value).startswith(f"{path.resolve()}:2:{line.index('; b') + 1}: <Script>: code: unexpected ';'")


class Reader(py_trees.behaviour.Behaviour, PortsDeclared):
    """Reads a float port (possibly from the blackboard) and writes a pose."""

    @dataclass(frozen=True, kw_only=True)
    class Params:
        speed: float = port(1.0, "how fast")
        where: Pose2D = port(doc="a pose it writes", direction="output")

        def __post_init__(self) -> None:
            if self.speed < 0:
                raise ValueError(f"speed: expected ≥ 0, got {self.speed}")

    def __init__(self, name: str, **ports: Any) -> None:
        super().__init__(name)
        self.params = self.bind_params(ports)
        self.seen: list[float] = []

    def update(self) -> Status:
        self.seen.append(self.params.speed)
        self.set_output("where", Pose2D(self.params.speed, 0.0, 0.0))
        self.feedback_message = f"speed {self.params.speed}"
        return Status.SUCCESS


def reader_factory() -> BehaviourFactory:
    factory = shipped_factory()
    factory.register(Reader)
    return factory


def tick(root: py_trees.behaviour.Behaviour, times: int = 1) -> None:
    tree = py_trees.trees.BehaviourTree(root)
    for _ in range(times):
        tree.tick()


def test_a_port_read_from_the_blackboard_is_the_current_value_at_every_tick(tmp_path):
    path = write(
        tmp_path,
        """
        <BehaviorTree ID="T">
          <Sequence>
            <Script code="v := v + 0.5" _skipIf="false"/>
            <Reader speed="{v}" where="{pose}"/>
          </Sequence>
        </BehaviorTree>
        """,
    )
    root = load_tree(path, reader_factory())
    scopes.write("/tree/v", 1.0)
    tick(root, 2)
    reader = root.children[1]
    assert reader.seen == [1.5, 2.0]
    assert py_trees.blackboard.Blackboard.storage["/tree/pose"] == Pose2D(2.0, 0.0, 0.0)


def test_a_value_the_declaration_refuses_fails_the_node_with_the_reason_and_the_tree_keeps_ticking(tmp_path):
    body = '<BehaviorTree ID="T"><Sequence><Script code="v := -1"/><Reader speed="{v}"/></Sequence></BehaviorTree>'
    path = write(tmp_path, body)
    root = load_tree(path, reader_factory())
    tick(root)
    assert root.status == Status.FAILURE
    assert root.children[1].feedback_message == "speed: expected ≥ 0, got -1.0"


def test_a_port_whose_entry_was_never_written_fails_its_node_and_says_so(tmp_path):
    body = '<BehaviorTree ID="T"><ReactiveFallback><Reader speed="{v}"/><AlwaysSuccess/></ReactiveFallback>'
    body += "</BehaviorTree>"
    path = write(tmp_path, body)
    root = load_tree(path, reader_factory())
    tick(root)
    reader = root.children[0]
    assert reader.status == Status.FAILURE and reader.seen == []  # not ticked: BT.CPP would have thrown
    assert reader.feedback_message == "port speed: blackboard entry {v} was never written"
    assert root.status == Status.SUCCESS  # the failure is an ordinary one: the tree goes on


def test_mission_keys_are_entries_of_the_root_blackboard_under_their_bt_cpp_names(tmp_path):
    path = write(
        tmp_path,
        """
        <BehaviorTree ID="T">
          <Sequence>
            <ScriptCondition code="robot_clock &gt; 10 &amp;&amp; mission_state == EXPLORE"/>
            <Script code="mission_state := 'DOCK'"/>
          </Sequence>
        </BehaviorTree>
        """,
    )
    world = bbk.writer("world")
    bbk.set_(world, bbk.CLOCK, 12.5)
    bbk.set_(world, bbk.STATE, "EXPLORE")
    root = load_tree(path)
    tick(root)
    assert root.status == Status.SUCCESS
    assert bbk.get(world, bbk.STATE) == "DOCK"  # one store: the script wrote /mission/state


def test_a_subtree_has_its_own_blackboard_and_sees_the_callers_only_through_its_ports(tmp_path):
    path = write(
        tmp_path,
        """
        <BehaviorTree ID="Main">
          <Sequence>
            <Script code="x := 'caller x'; v := 'caller v'; mine := 'caller only'"/>
            <SubTree ID="Inner" v="{x}" k="7"/>
            <SubTree ID="Inner" name="auto" _autoremap="true"/>
          </Sequence>
        </BehaviorTree>
        <BehaviorTree ID="Inner">
          <Script code="copy := v .. '!'; seen := @mine; local := 1; _private := 2"/>
        </BehaviorTree>
        """,
        main="Main",
    )
    tick(load_tree(path))
    entries = {k: v for k, v in py_trees.blackboard.Blackboard.storage.items() if k.startswith("/tree/")}
    assert entries == {
        "/tree/x": "caller x",
        "/tree/v": "caller v",
        "/tree/mine": "caller only",
        # the first use: v is the caller's x, k a constant of its own (an int, as BT.CPP stores it)
        "/tree/Inner::3/k": 7,
        "/tree/Inner::3/copy": "caller x!",
        "/tree/Inner::3/seen": "caller only",
        "/tree/Inner::3/local": 1,
        "/tree/Inner::3/_private": 2,
        # the second, autoremapped: every key is the caller's, except _private ones
        "/tree/copy": "caller v!",
        "/tree/seen": "caller only",
        "/tree/local": 1,
        "/tree/auto/_private": 2,
    }


def test_two_ports_of_different_types_on_one_entry_are_a_load_error_naming_both(tmp_path):
    path = write(
        tmp_path,
        '<BehaviorTree ID="T">\n  <Sequence>\n    <Reader where="{p}"/>\n    <Reader speed="{p}"/>\n  </Sequence>\n'
        "</BehaviorTree>",
    )
    with pytest.raises(TreeError) as err:
        validate_tree(path, reader_factory())
    assert str(err.value) == (
        f"{path.resolve()}:5: <Reader>: port speed: blackboard entry {{p}} is float here but Pose2D for port where "
        f"of <Reader> at {path.resolve()}:4; BT.CPP refuses an entry whose type changes"
    )


def test_a_mission_keys_type_is_checked_like_a_ports(tmp_path):
    path = write(tmp_path, '<BehaviorTree ID="T"><Reader where="{robot_clock}"/></BehaviorTree>')
    with pytest.raises(TreeError, match=r"is Pose2D here but float for the mission key /robot/clock"):
        validate_tree(path, reader_factory())
