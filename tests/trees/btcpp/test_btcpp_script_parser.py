"""BehaviorTree.CPP 4.10 tests/script_parser_test.cpp, translated: one pytest case per assertion.

The TESTs that only run scripts are parametrized functions marked ``@SCRIPT``: each case is one
``EXPECT_*`` / ``ASSERT_*`` of the TEST, in order. The assertions of a TEST share one environment in C++
(``x:= 3`` in one line is read by the next ones), so a case replays every statement before its own (their
outcomes are their own cases; an error there does not stop the replay) and then checks its assertion.

The engine is our real one, trees/script.py (``parse(text).run(env)``, BT.CPP's ``parseStatements`` and
``evaluate``). The environment is the one the loader gives a node of the main tree (trees/loader.py
``_Builder.env``): ``scopes.ScriptEnv`` over the root ``scopes.Scope``, so every name is a real entry of
the store our trees use (``/tree/<name>`` in py_trees' blackboard). BT.CPP's TESTs build a fresh root
``Blackboard::create()``; here the ``/tree`` entries are cleared before and after each case, so the root
scope starts empty too, and ``getKeys()`` is the list of ``/tree/…`` entries. The enums are BT.CPP's
``Environment::enums`` (empty unless the TEST inserts some). ``createEntry`` of a typed port (an entry that
exists but was never written) is the loader's ``declared`` set.

BT.CPP's ``Any::cast<T>()`` is :func:`cast` below (our values are Python's bool / int / float / str).
The TESTs that load XML trees are ``@TEST`` tree TESTs; CompareWithNegativeNumber_Issue832 does both: its
script assertions are ``@SCRIPT`` cases and its tree (the last assertion) is a ``@TEST``.
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import py_trees
import pytest
from py_trees.behaviour import Behaviour
from py_trees.common import Status

from mission.behaviours.ports import PortsDeclared
from mission.trees import scopes
from mission.trees.script import Script, ScriptError, ScriptSyntaxError, parse
from tests.trees.btcpp.btcpp_harness import SCRIPT, TEST, Harness, port

#: TESTs of this file that only use the C++ API, and why they are not translated
SKIPPED: dict[str, str] = {}


# ----------------------------------------------------------------------------- BT.CPP's API, in our terms
def cast(value: Any, kind: type) -> Any:
    """``BT::Any::cast<T>()``: a number to another number type (an integer type refuses a fractional value,
    as BT.CPP's convertNumber does), a string to a string; anything else is an error."""
    if value is None:
        raise TypeError("Any::cast of an empty Any")
    if kind is str:
        if not isinstance(value, str):
            raise TypeError(f"cast<std::string> of {value!r}")
        return value
    if isinstance(value, str):
        return kind(float(value)) if kind is float else int(value)  # convertFromString<T>
    if kind is int:
        if isinstance(value, float) and not value.is_integer():
            raise TypeError(f"cast<int> of {value!r} loses precision")
        return int(value)
    return float(value)


@dataclass
class Expected:
    """``BT::Expected<Any>``: a value or an error message."""

    value: Any = None
    error: str | None = None

    def has_value(self) -> bool:
        return self.error is None


@dataclass
class Env:
    """``BT::Ast::Environment``: ``vars`` (the root blackboard, our store) and ``enums``."""

    enums: dict[str, int] = field(default_factory=dict)
    declared: set[str] = field(default_factory=set)
    result: Any = None  # what the TEST keeps in a local variable (``auto result = …``)
    saved: dict[str, Any] = field(default_factory=dict)

    @property
    def script_env(self) -> scopes.ScriptEnv:
        return scopes.ScriptEnv(scopes.Scope(), self.enums, self.declared)

    def get_result(self, text: str) -> Any:
        """The file's ``GetScriptResult``: parse, evaluate each statement, the last one's value (errors raise)."""
        return parse(text).run(self.script_env)

    def parse_and_execute(self, text: str) -> Expected:
        """``BT::ParseScriptAndExecute(env, text)``."""
        try:
            script: Script = parse(text)
        except ScriptSyntaxError as err:
            return Expected(error=str(err))
        try:
            return Expected(script.run(self.script_env))
        except ScriptError as err:
            return Expected(error=str(err))

    def get(self, key: str, kind: type) -> Any:
        """``vars->get<T>(key)``."""
        return cast(scopes.read(scopes.Scope().entry_path(key)), kind)

    def keys(self) -> list[str]:
        """``vars->getKeys()``: the root blackboard's entries."""
        prefix = scopes.NAMESPACE + "/"
        return [p for p in py_trees.blackboard.Blackboard.storage if p.startswith(prefix)]

    def create_entry(self, key: str) -> None:
        """``vars->createEntry(key, PortInfo(INOUT, typeid(uint8_t)))``: it exists, never written."""
        self.declared.add(scopes.Scope().entry_path(key))


def validate_script(text: str) -> bool:
    """``BT::ValidateScript(text)`` as a bool: the script parses (and is not empty)."""
    try:
        parse(text)
    except ScriptSyntaxError:
        return False
    return True


# ----------------------------------------------------------------------------- steps of a TEST
@dataclass
class Step:
    """One line of a TEST: an assertion (`what` says what it checks) or a statement (`what` None)."""

    what: str | None
    run: Callable[[Env], None]


def do(fn: Callable[[Env], Any]) -> Step:
    """A statement without an assertion (``GetResult("v1:= true; v2:= false");``)."""

    def run(env: Env) -> None:
        fn(env)

    return Step(None, run)


def expect(what: str, check: Callable[[Env], bool]) -> Step:
    def run(env: Env) -> None:
        assert check(env), what

    return Step(what, run)


def expect_throw(text: str) -> Step:
    """``EXPECT_ANY_THROW(GetResult(text))``."""

    def run(env: Env) -> None:
        with pytest.raises(Exception):  # noqa: B017  (EXPECT_ANY_THROW)
            env.get_result(text)

    return Step(f"{text!r} throws", run)


def result_eq(text: str, kind: type, expected: Any, shown: str | None = None) -> Step:
    """``EXPECT_EQ(GetResult(text).cast<kind>(), expected)``."""
    return expect(f"{text!r} is {shown or repr(expected)}", lambda env: cast(env.get_result(text), kind) == expected)


def result_ne(text: str, kind: type, other: Any) -> Step:
    """``EXPECT_NE(GetResult(text).cast<kind>(), other)``."""
    return expect(f"{text!r} is not {other!r}", lambda env: cast(env.get_result(text), kind) != other)


def parsed_eq(text: str, kind: type, expected: Any) -> Step:
    """``EXPECT_EQ(Parse(text).value().cast<kind>(), expected)`` (ParseScriptAndExecute)."""
    return expect(f"{text!r} is {expected!r}", lambda env: cast(env.parse_and_execute(text).value, kind) == expected)


def var_eq(key: str, kind: type, expected: Any) -> Step:
    """``EXPECT_EQ(variables->get<kind>(key), expected)``."""
    return expect(f"entry {key} is {expected!r}", lambda env: env.get(key, kind) == expected)


def keys_eq(n: int) -> Step:
    """``EXPECT_EQ(variables->getKeys().size(), n)``."""
    return expect(f"{n} entries", lambda env: len(env.keys()) == n)


def parse_step(text: str) -> Step:
    """``result = Parse(text);``."""
    return do(lambda env: setattr(env, "result", env.parse_and_execute(text)))


def has_value(text: str) -> Step:
    """``EXPECT_TRUE(result.has_value())``."""
    return expect(f"{text!r} has a value", lambda env: env.result.has_value())


def value_eq(text: str, kind: type, expected: Any) -> Step:
    """``EXPECT_EQ(result.value().cast<kind>(), expected)``."""
    return expect(f"{text!r} is {expected!r}", lambda env: cast(env.result.value, kind) == expected)


def validate(text: str, valid: bool) -> Step:
    """``EXPECT_TRUE/FALSE(BT::ValidateScript(text))``."""
    return expect(f"{text!r} is {'valid' if valid else 'invalid'}", lambda env: validate_script(text) == valid)


def cases(steps: list[Step]) -> pytest.MarkDecorator:
    """One case per assertion, numbered in the TEST's order, with what it checks as its id."""
    indices = [i for i, s in enumerate(steps) if s.what is not None]
    ids = [f"{n + 1:02d} {steps[i].what}" for n, i in enumerate(indices)]
    return pytest.mark.parametrize("step", indices, ids=ids)


@pytest.fixture
def env():
    """A fresh ``BT::Ast::Environment env = { BT::Blackboard::create(), {} }``."""
    scopes.clear_tree_entries()
    yield Env()
    scopes.clear_tree_entries()


def check(steps: list[Step], step: int, env: Env) -> None:
    """Replay the TEST up to assertion `step` (earlier outcomes are their own cases), then check it."""
    for earlier in steps[:step]:
        with contextlib.suppress(Exception, pytest.fail.Exception):  # gtest goes on after a failed EXPECT
            earlier.run(env)
    steps[step].run(env)


# ----------------------------------------------------------------------------- ParserTest.AnyTypes
def _any_type(text: str, kind: type, expected: Any) -> list[Step]:
    return [parse_step(text), has_value(text), value_eq(text, kind, expected)]


ANY_TYPES: list[Step] = [
    *_any_type("628", int, 628),
    *_any_type("-628", int, -628),
    *_any_type("0x100", int, 256),
    *_any_type("0X100", int, 256),
    *_any_type("3.14", float, 3.14),
    *_any_type("-3.14", float, -3.14),
    *_any_type("3.14e2", float, 314),
    *_any_type("3.14e-2", float, 0.0314),
    *_any_type("3e2", float, 300),
    *_any_type("3e-2", float, 0.03),
    *_any_type("'hello world '", str, "hello world "),
    *_any_type("true", int, 1),
    *_any_type("false", int, 0),
]


@SCRIPT("ParserTest.AnyTypes")
@cases(ANY_TYPES)
def test_any_types(env, step):
    check(ANY_TYPES, step, env)


ANY_TYPES_FAILING: list[Step] = [
    validate("0X100g", False),
    validate("0X100.", False),
    validate("3foo", False),
    validate("65.", False),
    validate("65.43foo", False),
    # "foo" is a valid identifier (parses as ExprName), only fails at
    # evaluation when the variable doesn't exist.
    expect("'foo' (no such entry) has no value", lambda env: not env.parse_and_execute("foo").has_value()),
]


@SCRIPT("ParserTest.AnyTypes_Failing")
@cases(ANY_TYPES_FAILING)
def test_any_types_failing(env, step):
    check(ANY_TYPES_FAILING, step, env)


# ----------------------------------------------------------------------------- ParserTest.Equations
EQUATIONS: list[Step] = [
    result_eq("x:= 3; y:=5; x+y", float, 8.0),
    keys_eq(2),
    var_eq("x", float, 3.0),
    var_eq("y", float, 5.0),
    result_eq("x+=1", float, 4.0),
    var_eq("x", float, 4.0),
    result_eq("x += 1", float, 5.0),
    var_eq("x", float, 5.0),
    result_eq("x-=1", float, 4.0),
    var_eq("x", float, 4.0),
    result_eq("x -= 1", float, 3.0),
    var_eq("x", float, 3.0),
    result_eq("x*=2", float, 6.0),
    var_eq("x", float, 6.0),
    result_eq("-x", float, -6.0),
    result_eq("x/=2", float, 3.0),
    var_eq("x", float, 3.0),
    result_eq("y", float, 5.0),
    result_eq("y/2", float, 2.5),
    result_eq("y*2", float, 10.0),
    result_eq("y-x", float, 2.0),
    result_eq("y & x", float, (5 & 3)),
    result_eq("y | x", float, (5 | 3)),
    result_eq("y ^ x", float, (5 ^ 3)),
    expect_throw("y ^ 5.1"),
    # test string variables
    result_eq("A:='hello'; B:=' '; C:='world'; A+B+C", str, "hello world"),
    keys_eq(5),
    var_eq("A", str, "hello"),
    var_eq("B", str, " "),
    var_eq("C", str, "world"),
    # check that whitespaces are handled correctly
    expect(
        "whitespace in strings: a result",
        lambda env: env.get_result("A= '   right'; B= ' center '; C= 'left    '  ") is not None,
    ),
    keys_eq(5),
    var_eq("A", str, "   right"),
    var_eq("B", str, " center "),
    var_eq("C", str, "left    "),
    # can't change the type, once created
    expect_throw("x=A"),
    expect_throw("x='msg'"),
    expect_throw("A=1.0"),
    # Invalid assignments
    expect_throw(" 'hello' = 'world' "),
    expect_throw(" 'hello' = 2.0 "),
    expect_throw(" 3.0 = 2.0 "),
    do(lambda env: env.saved.update(prev_size=len(env.keys()))),
    expect_throw("new_var=69"),
    expect("no new entry after 'new_var=69'", lambda env: len(env.keys()) == env.saved["prev_size"]),
    # check comparisons
    result_eq("x < y", int, 1),
    result_eq("y > x", int, 1),
    result_eq("y != x", int, 1),
    result_eq("y == x", int, 0),
    result_eq(" 'hello' == 'hello'", int, 1),
    result_eq(" 'hello' != 'world'", int, 1),
    result_eq(" 'hello' < 'world'", int, 1),
    result_eq(" 'hello' > 'world'", int, 0),
    result_ne("x > y", int, 1),
    result_ne("y < x", int, 1),
    result_ne("y == x", int, 1),
    result_eq("y == x ? 'T' : 'F'", str, "F"),
    result_eq("y != x ? 'T' : 'F'", str, "T"),
    result_eq("y == x", int, 0),
    result_eq("y == 5", int, 1),
    result_eq("x == 3", int, 1),
    result_eq(" true ", int, 1),
    result_eq(" 'true' ", str, "true"),
    do(lambda env: env.get_result("v1:= true; v2:= false")),
    var_eq("v1", int, 1),
    var_eq("v2", int, 0),
    result_eq(" v2 = true ", int, 1),
    result_eq(" v2 = !false ", int, 1),
    result_eq(" v2 = !v2 ", int, 0),
    result_eq("v1 && v2", int, 0),
    result_eq("v1 || v2", int, 1),
    result_eq("(y == x) && (x == 3)", int, 0),
    result_eq("(y == x) || (x == 3)", int, 1),
    result_eq(" y == x  &&  x == 3 ", int, 0),
    result_eq(" y == x  ||  x == 3 ", int, 1),
    # we expect string to be casted to number
    result_eq(" par1:='3'; par2:=3; par1==par2", int, 1),
    result_eq(" par1:='3'; par2:=4; par1!=par2", int, 1),
]


@SCRIPT("ParserTest.Equations")
@cases(EQUATIONS)
def test_equations(env, step):
    check(EQUATIONS, step, env)


NOT_INITIALIZED_COMPARISON: list[Step] = [
    do(lambda env: env.create_entry("x")),  # createEntry("x", PortInfo(INOUT, typeid(uint8_t)))
    expect_throw("x < 0"),
    expect_throw("x == 0"),
    expect_throw("x > 0"),
    expect_throw("x + 1"),
    expect_throw("x += 1"),
]


@SCRIPT("ParserTest.NotInitializedComparison")
@cases(NOT_INITIALIZED_COMPARISON)
def test_not_initialized_comparison(env, step):
    check(NOT_INITIALIZED_COMPARISON, step, env)


RED, BLUE, GREEN = 1, 3, 5  # enum Color

ENUMS_BASIC: list[Step] = [
    do(lambda env: env.enums.update(RED=RED, BLUE=BLUE, GREEN=GREEN)),
    do(lambda env: env.get_result("A:=RED")),
    do(lambda env: env.get_result("B:=RED")),
    do(lambda env: env.get_result("C:=BLUE")),
    result_eq("A==B", int, 1),
    result_eq("A!=C", int, 1),
    result_eq("A", int, RED, "RED"),  # cast<Color>
    result_eq("B", int, RED, "RED"),
    result_eq("C", int, BLUE, "BLUE"),
]


@SCRIPT("ParserTest.EnumsBasic")
@cases(ENUMS_BASIC)
def test_enums_basic(env, step):
    check(ENUMS_BASIC, step, env)


# ----------------------------------------------------------------------------- tree TESTs
@TEST("ParserTest.EnumsXML")
def test_enums_xml(tmp_path):
    bt = Harness(tmp_path)

    xml_text = """

    <root BTCPP_format="4" >
        <BehaviorTree ID="MainTree">
            <Script code = "A:=THE_ANSWER; color1:=RED; color2:=BLUE; color3:=GREEN" />
        </BehaviorTree>
    </root>"""

    bt.factory.register_enum("THE_ANSWER", 42)
    for name, value in {"RED": RED, "BLUE": BLUE, "GREEN": GREEN}.items():  # registerScriptingEnums<Color>()
        bt.factory.register_enum(name, value)

    tree = bt.load(xml_text)
    status = tree.tick_while_running()
    assert status == "SUCCESS"

    assert tree.get("A") == 42
    assert tree.get("color1") == RED
    assert tree.get("color2") == BLUE
    assert tree.get("color3") == GREEN


BATT, CONTROLLER = 1, 2  # enum DeviceType


class SaySomething(Behaviour, PortsDeclared):
    """sample_nodes/dummy_nodes.h SaySomething: prints its message, succeeds."""

    @dataclass(frozen=True, kw_only=True)
    class Params:
        message: str = port(doc="what to say")

    def __init__(self, name: str, **ports: Any) -> None:
        super().__init__(name)
        self.params = self.bind_params(ports)

    def update(self) -> Status:
        print(f"Robot says: {self.params.message}")
        return Status.SUCCESS


def check_level(node) -> str:
    """The file's checkLevel: below 25 % a battery is low."""
    percent = node.input("percentage")
    dev_type = node.input("deviceType")
    if dev_type == BATT:
        node.set_output("isLowBattery", percent < 25)
    return "SUCCESS"


@TEST("ParserTest.Enums_Issue_523")
def test_enums_issue_523(tmp_path):
    bt = Harness(tmp_path)

    xml_text = """
  <root BTCPP_format="4" >
    <BehaviorTree ID="PowerManagerT">
      <ReactiveSequence>
        <Script code=" deviceA:=BATT; deviceB:=CONTROLLER; battery_level:=30 "/>
        <CheckLevel deviceType="{deviceA}" percentage="{battery_level}" isLowBattery="{isLowBattery}"/>
        <SaySomething message="FIRST low batteries!" _skipIf="!isLowBattery" />

        <Script code=" battery_level:=20 "/>
        <CheckLevel deviceType="{deviceA}" percentage="{battery_level}" isLowBattery="{isLowBattery}"/>
        <SaySomething message="SECOND low batteries!" _skipIf="!isLowBattery" />
      </ReactiveSequence>
    </BehaviorTree>
  </root> """

    bt.register(SaySomething, "SaySomething")
    bt.register_simple_condition(
        "CheckLevel",
        check_level,
        [
            ("percentage", float, port(doc="getInput<double>")),
            ("deviceType", int, port(doc="getInput<DeviceType>")),
            ("isLowBattery", bool, port(doc="percent < 25", direction="output")),
        ],
    )
    for name, value in {"BATT": BATT, "CONTROLLER": CONTROLLER}.items():  # registerScriptingEnums<DeviceType>()
        bt.factory.register_enum(name, value)

    tree = bt.load(xml_text)
    status = tree.tick_while_running()
    assert status == "SUCCESS"

    assert tree.get("deviceA") == BATT
    assert tree.get("deviceB") == CONTROLLER
    assert tree.get("isLowBattery") is True


class SampleNode595(Behaviour, PortsDeclared):
    """The file's SampleNode595: writes 0 to its output ``find_enemy`` (``OutputPort<uint8_t>``)."""

    @dataclass(frozen=True, kw_only=True)
    class Params:
        find_enemy: int = port(doc="always 0", direction="output")

    def __init__(self, name: str, **ports: Any) -> None:
        super().__init__(name)
        self.params = self.bind_params(ports)

    def update(self) -> Status:
        self.set_output("find_enemy", 0)
        return Status.SUCCESS


@TEST("ParserTest.Issue595")
def test_issue595(tmp_path):
    bt = Harness(tmp_path)

    xml_text = """
  <root BTCPP_format="4" >
    <BehaviorTree ID="PowerManagerT">
      <Sequence>
        <SampleNode595 find_enemy="{find_enemy}" />
        <TestA _skipIf="find_enemy==0"/>
      </Sequence>
    </BehaviorTree>
  </root> """

    counters = bt.register_test_tick("Test", 1)
    bt.register(SampleNode595, "SampleNode595")

    tree = bt.load(xml_text)
    status = tree.tick_while_running()

    assert status == "SUCCESS"
    assert counters[0] == 0


# ----------------------------------------------------------------------------- more script TESTs
# https://github.com/BehaviorTree/BehaviorTree.CPP/issues/1029
OPERATOR_ASSOCIATIVITY: list[Step] = [
    # "5 - 2 + 1" should be (5-2)+1 = 4, NOT 5-(2+1) = 2
    result_eq("5 - 2 + 1", float, 4.0),
    # "10 - 3 - 2" should be (10-3)-2 = 5, NOT 10-(3-2) = 9
    result_eq("10 - 3 - 2", float, 5.0),
    # "2 + 3 - 1" should be (2+3)-1 = 4
    result_eq("2 + 3 - 1", float, 4.0),
    # "12 / 3 / 2" should be (12/3)/2 = 2, NOT 12/(3/2) = 8
    result_eq("12 / 3 / 2", float, 2.0),
    # "12 / 3 * 2" should be (12/3)*2 = 8, NOT 12/(3*2) = 2
    result_eq("12 / 3 * 2", float, 8.0),
    # Mixed precedence: "2 + 3 * 4 - 1" should be 2+(3*4)-1 = 13
    result_eq("2 + 3 * 4 - 1", float, 13.0),
    # Verify string concatenation operator (..) still works after operand fix
    result_eq("A:='hello'; B:=' world'; A .. B", str, "hello world"),
    # Chained concatenation (left-associative)
    result_eq("A .. ' ' .. B", str, "hello  world"),
]


@SCRIPT("ParserTest.OperatorAssociativity_Issue1029")
@cases(OPERATOR_ASSOCIATIVITY)
def test_operator_associativity_issue1029(env, step):
    check(OPERATOR_ASSOCIATIVITY, step, env)


# https://github.com/BehaviorTree/BehaviorTree.CPP/issues/923
# Regression test: ValidateScript must not crash on large invalid scripts
# that produce error messages exceeding any fixed-size buffer.
def _large_invalid_script() -> str:
    script = ""
    for _ in range(10):
        script += "+6e66>6666.6+66\r6>6;6e62=6+6e66>66666'; en';o';o'; en'; "
        script += "\x7f" "n" "\x7f" "r;6.6+66.H>6+6" "\x80" "6" "\x1e" ";@e66"  # fmt: skip
    return script


VALIDATE_SCRIPT_LARGE_ERROR: list[Step] = [
    # Must not crash (old code used a fixed char[2048] buffer causing OOB read)
    expect("a large invalid script is invalid", lambda env: not validate_script(_large_invalid_script())),
]


@SCRIPT("ParserTest.ValidateScriptLargeError_Issue923")
@cases(VALIDATE_SCRIPT_LARGE_ERROR)
def test_validate_script_large_error_issue923(env, step):
    check(VALIDATE_SCRIPT_LARGE_ERROR, step, env)


# https://github.com/BehaviorTree/BehaviorTree.CPP/issues/832
COMPARE_WITH_NEGATIVE_NUMBER: list[Step] = [
    # "A != -1" should parse and evaluate correctly
    result_eq("A:=0; A!=-1", int, 1),  # 0 != -1 is true
    result_eq("A:=-1; A!=-1", int, 0),  # -1 != -1 is false
    result_eq("A:=0; A==-1", int, 0),  # 0 == -1 is false
    result_eq("A:=0; A>-1", int, 1),  # 0 > -1 is true
    result_eq("A:=0; A<-1", int, 0),  # 0 < -1 is false
    # Also test that ValidateScript accepts these expressions
    validate("A:=0; A!=-1", True),
    validate("A:=0; A>-1", True),
]


@SCRIPT("ParserTest.CompareWithNegativeNumber_Issue832")
@cases(COMPARE_WITH_NEGATIVE_NUMBER)
def test_compare_with_negative_number_issue832(env, step):
    check(COMPARE_WITH_NEGATIVE_NUMBER, step, env)


@TEST("ParserTest.CompareWithNegativeNumber_Issue832")
def test_compare_with_negative_number_issue832_tree(tmp_path):
    # Reproducer from the issue: precondition with negative literal
    bt = Harness(tmp_path)
    xml_text = """
  <root BTCPP_format="4">
      <BehaviorTree>
         <Sequence>
             <Script code=" A:=0 " />
             <AlwaysSuccess _failureIf="A!=-1"/>
         </Sequence>
      </BehaviorTree>
  </root>
  """
    tree = bt.load(xml_text)
    # A==0, so A!=-1 is true, meaning _failureIf triggers => FAILURE
    status = tree.tick_while_running()
    assert status == "FAILURE"


@TEST("ParserTest.NewLine")
def test_new_line(tmp_path):
    bt = Harness(tmp_path)

    xml_text = """
  <root BTCPP_format="4" >
    <BehaviorTree ID="Main">
      <Script code="A:=5;&#10;B:=6"/>
    </BehaviorTree>
  </root> """

    tree = bt.load(xml_text)
    status = tree.tick_while_running()

    assert status == "SUCCESS"
    assert tree.get("A") == 5
    assert tree.get("B") == 6


TOKENIZER_EDGE_CASES: list[Step] = [
    # Unterminated string
    validate("'hello", False),
    # Hex edge cases
    validate("0x", False),
    validate("0xG", False),
    # Exponent without digits
    validate("3e", False),
    validate("3e+", False),
    # DotDot adjacent to integer: "65..66" should parse as 65 .. 66
    parse_step("A:='65'; B:='66'; A..B"),
    has_value("A:='65'; B:='66'; A..B"),
    value_eq("A:='65'; B:='66'; A..B", str, "6566"),
    # Empty and whitespace-only scripts
    validate("", False),
    validate("   ", False),
    validate("\t\n\r", False),
]


@SCRIPT("ParserTest.TokenizerEdgeCases")
@cases(TOKENIZER_EDGE_CASES)
def test_tokenizer_edge_cases(env, step):
    check(TOKENIZER_EDGE_CASES, step, env)


CHAINED_COMPARISONS: list[Step] = [
    # 1 < 2 < 3 should be true (chained: 1<2 AND 2<3)
    parsed_eq("1 < 2 < 3", int, 1),
    # 3 > 2 > 1 should be true
    parsed_eq("3 > 2 > 1", int, 1),
    # 1 < 2 > 3 should be false (1<2 is true, but 2>3 is false)
    parsed_eq("1 < 2 > 3", int, 0),
    # Chained equality
    parsed_eq("5 == 5 == 5", int, 1),
    parsed_eq("5 == 5 != 3", int, 1),
    # 1 <= 2 <= 3
    parsed_eq("1 <= 2 <= 3", int, 1),
    # 3 >= 2 >= 1
    parsed_eq("3 >= 2 >= 1", int, 1),
]


@SCRIPT("ParserTest.ChainedComparisons")
@cases(CHAINED_COMPARISONS)
def test_chained_comparisons(env, step):
    check(CHAINED_COMPARISONS, step, env)


OPERATOR_PRECEDENCE: list[Step] = [
    # Bitwise AND binds tighter than bitwise OR
    # 6 | 3 & 5 should be 6 | (3 & 5) = 6 | 1 = 7
    parsed_eq("6 | 3 & 5", int, 7),
    # Bitwise OR binds tighter than logical AND
    # true && (6 | 0) should be true
    parsed_eq("true && (6 | 0)", int, 1),
    # Logical AND binds tighter than logical OR
    # false || true && true should be false || (true && true) = true
    parsed_eq("false || true && true", int, 1),
    # false && true || true should be (false && true) || true = true
    parsed_eq("false && true || true", int, 1),
    # Parentheses override precedence
    parsed_eq("(2 + 3) * 4", float, 20.0),
    parsed_eq("2 * (3 + 4)", float, 14.0),
]


@SCRIPT("ParserTest.OperatorPrecedence")
@cases(OPERATOR_PRECEDENCE)
def test_operator_precedence(env, step):
    check(OPERATOR_PRECEDENCE, step, env)


UNARY_OPERATORS: list[Step] = [
    # Logical NOT
    parsed_eq("!true", int, 0),
    parsed_eq("!false", int, 1),
    parsed_eq("!!true", int, 1),
    # Bitwise complement
    parse_step("~0"),
    has_value("~0"),
    value_eq("~0", int, ~0),  # cast<int64_t>, ~int64_t(0)
    # Unary minus
    parsed_eq("-(3 + 2)", float, -5.0),
    # Unary minus in expressions
    parsed_eq("10 + -3", float, 7.0),
]


@SCRIPT("ParserTest.UnaryOperators")
@cases(UNARY_OPERATORS)
def test_unary_operators(env, step):
    check(UNARY_OPERATORS, step, env)


TERNARY_EXPRESSIONS: list[Step] = [
    parsed_eq("true ? 1 : 2", int, 1),
    parsed_eq("false ? 1 : 2", int, 2),
    # Ternary with expressions in branches
    parsed_eq("true ? 2 + 3 : 10", float, 5.0),
    parsed_eq("false ? 10 : 2 + 3", float, 5.0),
    # Ternary with comparison as condition
    parsed_eq("3 > 2 ? 'yes' : 'no'", str, "yes"),
    parsed_eq("3 < 2 ? 'yes' : 'no'", str, "no"),
]


@SCRIPT("ParserTest.TernaryExpressions")
@cases(TERNARY_EXPRESSIONS)
def test_ternary_expressions(env, step):
    check(TERNARY_EXPRESSIONS, step, env)


MULTIPLE_STATEMENTS: list[Step] = [
    # Multiple semicolons
    do(lambda env: env.parse_and_execute("a:=1;;; b:=2;;")),
    var_eq("a", float, 1.0),
    var_eq("b", float, 2.0),
    # Last expression is the return value
    parse_step("a:=10; b:=20; a+b"),
    value_eq("a:=10; b:=20; a+b", float, 30.0),
]


@SCRIPT("ParserTest.MultipleStatements")
@cases(MULTIPLE_STATEMENTS)
def test_multiple_statements(env, step):
    check(MULTIPLE_STATEMENTS, step, env)
