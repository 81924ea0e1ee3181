"""BehaviorTree.CPP's script language: parsed once at load (lark), evaluated against the blackboard at tick time.

Used by ``Script``, ``ScriptCondition``, ``Precondition`` and the ``_skipIf`` / ``_successIf`` /
``_failureIf`` / ``_while`` / ``_onSuccess`` / ``_onFailure`` / ``_onHalted`` / ``_post`` attributes.
The grammar follows BT.CPP 4.10's parser (src/script_parser.cpp) operator by operator, lowest first:

=========================  ====================================================================
``:=  =  +=  -=  *=  /=``  assignment (``:=`` creates the entry, ``=`` requires it to exist)
``c ? a : b``              ternary (right-associative)
``||``, then ``&&``        logical (both sides are evaluated, as in BT.CPP: no short circuit)
``== != < > <= >=``        comparison, chainable (``0 < x < 10``)
``|  ^``, then ``&``       bitwise, on integral numbers
``+  -  ..``               sum, difference, string concatenation (``..`` also joins numbers)
``*  /``                   product, quotient (a division by zero gives ±inf or nan, as doubles do)
``-  ~  !``                prefix: negation, bitwise complement, logical not
=========================  ====================================================================

Operands: numbers (``42``, ``0x2A``, ``4.2``, ``1e-3``), strings in single quotes (``'DONE'``), ``true`` /
``false``, blackboard entries by name (``@name`` is the root blackboard's entry) and enum names (the mission
states ``EXPLORE`` … ``FAILED``, or a factory's own), which take precedence over entries of the same name.
Statements are separated by ``;`` (BT.CPP also accepts statements side by side without one; this parser
asks for the ``;``). Values follow BT.CPP: arithmetic gives floats, a string compared with a number is
read as a number (an enum name counts), equality of numbers allows float32 epsilon.

A syntax error is a :class:`ScriptSyntaxError` with the 1-based line and column inside the script; the
loader turns it into ``file:line:column`` of the attribute in the tree file. Errors while running (an
unknown entry, a type mismatch) are :class:`ScriptError`; the node that ran the script fails with it.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any, Protocol

import lark

#: BT.CPP compares doubles with this tolerance (std::numeric_limits<float>::epsilon())
EPSILON = 1.1920928955078125e-07

_GRAMMAR = r"""
    start: _SEMI* statement (_SEMI+ statement)* _SEMI*

    ?statement: expr

    ?expr: assignment
         | ternary
    assignment: NAME ASSIGN expr

    ?ternary: logic_or
            | logic_or "?" expr ":" ternary -> conditional

    ?logic_or: logic_and
             | logic_or OR logic_and -> binary
    ?logic_and: comparison
              | logic_and AND comparison -> binary
    ?comparison: bit_or
               | bit_or (COMPARE bit_or)+ -> chain
    ?bit_or: bit_and
           | bit_or BIT_OR_XOR bit_and -> binary
    ?bit_and: sum
            | bit_and BIT_AND sum -> binary
    ?sum: product
        | sum SUM_OP product -> binary
    ?product: prefix
            | product PRODUCT_OP prefix -> binary
    ?prefix: atom
           | PREFIX_OP prefix -> unary
    ?atom: NUMBER -> number
         | STRING -> string
         | BOOLEAN -> boolean
         | NAME -> name
         | "(" expr ")"

    ASSIGN: ":=" | "+=" | "-=" | "*=" | "/=" | /=(?!=)/
    OR: "||"
    AND: "&&"
    COMPARE: "==" | "!=" | "<=" | ">=" | "<" | ">"
    BIT_OR_XOR: /\|(?!\|)/ | "^"
    BIT_AND: /&(?!&)/
    SUM_OP: "+" | "-" | ".."
    PRODUCT_OP: "*" | "/"
    PREFIX_OP: "-" | "~" | "!"
    NUMBER.2: /0[xX][0-9a-fA-F]+(?![0-9a-zA-Z_.])/
            | /[0-9]+(\.[0-9]+)?([eE][+-]?[0-9]+)?(?![0-9a-zA-Z_]|\.[0-9a-zA-Z_])/
    STRING: /'[^']*'/
    BOOLEAN.2: /(true|false)(?![A-Za-z0-9_])/
    NAME: /@?[A-Za-z_][A-Za-z0-9_]*/
    _SEMI: ";"

    %ignore /[ \t\r\n]+/
"""

_PARSER = lark.Lark(_GRAMMAR, parser="lalr", maybe_placeholders=False)

#: what each terminal looks like to a user reading an error message
_TERMINALS = {
    "NAME": "a name",
    "NUMBER": "a number",
    "STRING": "a 'string'",
    "BOOLEAN": "true/false",
    "ASSIGN": "an assignment",
    "OR": "'||'",
    "AND": "'&&'",
    "COMPARE": "a comparison",
    "BIT_OR_XOR": "'|' or '^'",
    "BIT_AND": "'&'",
    "SUM_OP": "'+', '-' or '..'",
    "PRODUCT_OP": "'*' or '/'",
    "PREFIX_OP": "'-', '~' or '!'",
    "LPAR": "'('",
    "RPAR": "')'",
    "QMARK": "'?'",
    "COLON": "':'",
    "_SEMI": "';'",
    "$END": "the end of the script",
}


class ScriptSyntaxError(ValueError):
    """A script that does not parse: `line` and `column` (1-based) inside the script text."""

    def __init__(self, message: str, line: int, column: int) -> None:
        super().__init__(message)
        self.message = message
        self.line = line
        self.column = column


class ScriptError(RuntimeError):
    """A script that parsed but cannot run now (an entry that does not exist, a type mismatch)."""


class Empty:
    """The value of an entry that exists (a port declared it) but was never written."""

    def __repr__(self) -> str:
        return "<empty>"


EMPTY: Any = Empty()


class Environment(Protocol):
    """Where a script's names live: the node's blackboard scope and the enums."""

    enums: Mapping[str, int]

    def lookup(self, name: str) -> Any:
        """The entry's value, EMPTY when it exists but was never written; KeyError when it does not exist."""
        ...

    def assign(self, name: str, value: Any, create: bool) -> None:
        """Write an entry (``create``: make it if missing); KeyError when it does not exist and not `create`."""
        ...


# ------------------------------------------------------------------------------------- values
def is_number(value: Any) -> bool:
    return isinstance(value, (int, float))  # bool is an int: true/false are numbers, as in BT.CPP


def to_bool(value: Any) -> bool:
    """A script result as a condition (``_skipIf``, ScriptCondition): numbers and booleans only."""
    if is_number(value):
        return bool(value)
    if value is EMPTY:
        raise ScriptError("the result is an entry that was never written")
    raise ScriptError(f"expected a boolean or a number as the result, got {describe(value)}")


def describe(value: Any) -> str:
    if isinstance(value, str):
        return f"the string {value!r}"
    if value is EMPTY:
        return "an entry that was never written"
    return f"{type(value).__name__} {value!r}" if is_number(value) else f"a value of type {type(value).__name__}"


def to_text(value: Any) -> str:
    """A value as BT.CPP's ``Any::cast<std::string>`` writes it: doubles with six decimals."""
    if isinstance(value, bool):
        return "1" if value else "0"
    if isinstance(value, float):
        return f"{value:f}"
    return str(value)


def string_to_number(text: str, enums: Mapping[str, int]) -> float:
    """BT.CPP's StringToDouble: 'true'/'false', an enum name, or a number written as text."""
    if text == "true":
        return 1.0
    if text == "false":
        return 0.0
    if text in enums:
        return float(enums[text])
    try:
        return float(text)
    except ValueError:
        raise ScriptError(f"cannot compare the string {text!r} with a number") from None


# ---------------------------------------------------------------------------------- the tree
class Expr:
    """A node of a parsed script."""

    line: int = 1
    column: int = 1

    def evaluate(self, env: Environment) -> Any:
        raise NotImplementedError

    def names(self) -> set[str]:
        """Every blackboard name the expression mentions (read or written)."""
        return set()


@dataclass
class Literal(Expr):
    value: Any

    def evaluate(self, env: Environment) -> Any:
        return self.value


@dataclass
class Name(Expr):
    name: str

    def evaluate(self, env: Environment) -> Any:
        if self.name in env.enums:
            return env.enums[self.name]
        try:
            return env.lookup(self.name)
        except KeyError:
            raise ScriptError(f"variable not found: {self.name}") from None

    def names(self) -> set[str]:
        return {self.name}


def _operand(value: Any, side: str, op: str) -> Any:
    if value is EMPTY:
        raise ScriptError(f"the {side} operand of [{op}] is an entry that was never written")
    return value


def _integral(value: Any, op: str) -> int:
    if isinstance(value, float) and not value.is_integer():
        raise ScriptError(f"[{op}] needs integral operands, got {value!r}")
    return int(value)


def _divide(a: float, b: float) -> float:
    if b != 0:
        return a / b
    if a == 0 or math.isnan(a):
        return math.nan
    return math.copysign(math.inf, a) * math.copysign(1.0, b)


_ARITHMETIC: dict[str, Callable[[float, float], float]] = {
    "+": lambda a, b: a + b,
    "-": lambda a, b: a - b,
    "*": lambda a, b: a * b,
    "/": _divide,
}


@dataclass
class Unary(Expr):
    op: str
    operand: Expr

    def evaluate(self, env: Environment) -> Any:
        value = _operand(self.operand.evaluate(env), "right", self.op)
        if isinstance(value, str):
            raise ScriptError(f"[{self.op}] cannot be applied to the string {value!r}")
        if not is_number(value):
            raise ScriptError(f"[{self.op}] needs a number, got {describe(value)}")
        if self.op == "-":
            return -float(value)
        if self.op == "!":
            return not value
        return float(~_integral(value, "~"))

    def names(self) -> set[str]:
        return self.operand.names()


@dataclass
class Binary(Expr):
    op: str
    left: Expr
    right: Expr

    def evaluate(self, env: Environment) -> Any:
        a = _operand(self.left.evaluate(env), "left", self.op)
        b = _operand(self.right.evaluate(env), "right", self.op)  # both sides, always (BT.CPP does not short-circuit)
        if is_number(a) and is_number(b):
            if self.op in _ARITHMETIC:
                return _ARITHMETIC[self.op](float(a), float(b))
            if self.op in ("&", "|", "^"):
                x, y = _integral(a, self.op), _integral(b, self.op)
                return float(x & y if self.op == "&" else x | y if self.op == "|" else x ^ y)
            if self.op == "&&":
                return bool(a) and bool(b)
            if self.op == "||":
                return bool(a) or bool(b)
        if self.op == "+" and isinstance(a, str) and isinstance(b, str):
            return a + b
        if (
            self.op == ".."
            and (isinstance(a, str) or isinstance(b, str))
            and all(isinstance(v, str) or is_number(v) for v in (a, b))
        ):
            return to_text(a) + to_text(b)
        raise ScriptError(f"[{self.op}] is not defined for {describe(a)} and {describe(b)}")

    def names(self) -> set[str]:
        return self.left.names() | self.right.names()


def _holds(a: Any, op: str, b: Any) -> bool:
    if op == "==":
        return abs(a - b) <= EPSILON if isinstance(a, float) or isinstance(b, float) else a == b
    if op == "!=":
        return not _holds(a, "==", b)
    if op == "<":
        return a < b  # type: ignore[no-any-return]
    if op == ">":
        return a > b  # type: ignore[no-any-return]
    if op == "<=":
        return a <= b  # type: ignore[no-any-return]
    return a >= b  # type: ignore[no-any-return]


@dataclass
class Chain(Expr):
    """``a < b < c``: every adjacent pair must hold (BT.CPP's chained comparison)."""

    operands: list[Expr]
    ops: list[str]

    def evaluate(self, env: Environment) -> Any:
        left = self.operands[0].evaluate(env)
        for op, operand in zip(self.ops, self.operands[1:], strict=True):
            right = operand.evaluate(env)
            a, b = _operand(left, "left", op), _operand(right, "right", op)
            if is_number(a) and is_number(b):
                a, b = (float(a), float(b)) if isinstance(a, float) or isinstance(b, float) else (a, b)
            elif isinstance(a, str) and isinstance(b, str):
                pass
            elif isinstance(a, str) and is_number(b):
                a, b = string_to_number(a, env.enums), float(b)
            elif is_number(a) and isinstance(b, str):
                a, b = float(a), string_to_number(b, env.enums)
            else:
                raise ScriptError(f"cannot compare {describe(a)} with {describe(b)}")
            if not _holds(a, op, b):
                return False
            left = right
        return True

    def names(self) -> set[str]:
        return set().union(*(o.names() for o in self.operands))


@dataclass
class Conditional(Expr):
    condition: Expr
    then: Expr
    otherwise: Expr

    def evaluate(self, env: Environment) -> Any:
        value = self.condition.evaluate(env)
        if isinstance(value, str):
            chosen = bool(value)
        elif is_number(value):
            chosen = value != 0
        else:
            raise ScriptError(f"the condition of ?: must be a number or a string, got {describe(value)}")
        return (self.then if chosen else self.otherwise).evaluate(env)

    def names(self) -> set[str]:
        return self.condition.names() | self.then.names() | self.otherwise.names()


def _keep_type(current: Any, new: Any, target: str) -> Any:
    """A number written over a number keeps the entry's type, as BT.CPP's Any::copyInto does: an integer
    entry takes only integral values."""
    if isinstance(current, bool) or isinstance(new, bool):
        return new if isinstance(new, bool) and isinstance(current, bool) else float(new)
    if isinstance(current, int):
        if isinstance(new, float) and not new.is_integer():
            raise ScriptError(f"[{target}] holds an integer; {new!r} would be truncated")
        return int(new)
    return float(new)


@dataclass
class Assignment(Expr):
    target: str
    op: str
    value: Expr

    def evaluate(self, env: Environment) -> Any:
        try:
            current = env.lookup(self.target)
        except KeyError:
            if self.op != ":=":
                raise ScriptError(
                    f"the blackboard entry [{self.target}] does not exist yet; use [:=] to create it"
                ) from None
            current = EMPTY
        new = _operand(self.value.evaluate(env), "right", self.op)
        if self.op in (":=", "="):
            if current is not EMPTY and isinstance(new, str) and is_number(current):
                new = string_to_number(new, env.enums)  # a string written into a number entry is read as a number
            elif current is not EMPTY and isinstance(current, str) and not isinstance(new, str):
                raise ScriptError(f"cannot assign {describe(new)} to [{self.target}], which holds a string")
            elif current is not EMPTY and is_number(current) and is_number(new):
                new = _keep_type(current, new, self.target)
        else:
            if current is EMPTY:
                raise ScriptError(f"[{self.op}] needs [{self.target}] to hold a value; it was never written")
            if is_number(new) and is_number(current):
                new = _ARITHMETIC[self.op[0]](float(current), float(new))
            elif self.op == "+=" and isinstance(new, str) and isinstance(current, str):
                new = current + new
            else:
                raise ScriptError(f"[{self.op}] is not defined for {describe(current)} and {describe(new)}")
            if is_number(new):
                new = _keep_type(current, new, self.target)
        env.assign(self.target, new, create=True)
        return new

    def names(self) -> set[str]:
        return {self.target} | self.value.names()


@dataclass
class Script:
    """A parsed script: its statements, run in order; the value is the last statement's."""

    source: str
    statements: list[Expr]

    def run(self, env: Environment) -> Any:
        result: Any = None
        for statement in self.statements:
            result = statement.evaluate(env)
        return result

    def names(self) -> set[str]:
        return set().union(*(s.names() for s in self.statements))

    def assigned(self) -> set[str]:
        """Names the script writes with ``:=`` (the entries it creates)."""
        out: set[str] = set()

        def visit(e: Expr) -> None:
            if isinstance(e, Assignment):
                if e.op == ":=":
                    out.add(e.target)
                visit(e.value)
            for child in vars(e).values():
                if isinstance(child, Expr):
                    visit(child)
                elif isinstance(child, list):
                    for c in child:
                        if isinstance(c, Expr):
                            visit(c)

        for s in self.statements:
            visit(s)
        return out


# ---------------------------------------------------------------------------------- building
class _Build(lark.Transformer):  # type: ignore[type-arg]
    """lark's parse tree → the Expr classes above, each at the line and column of its first token."""

    def __default_token__(self, token: lark.Token) -> lark.Token:
        return token

    @staticmethod
    def _at(expr: Expr, first: Any) -> Expr:
        expr.line = int(getattr(first, "line", 1) or 1)
        expr.column = int(getattr(first, "column", 1) or 1)
        return expr

    def start(self, children: list[Any]) -> list[Expr]:
        return list(children)

    def assignment(self, children: list[Any]) -> Expr:
        name, op, value = children
        return self._at(Assignment(str(name), str(op), value), name)

    def conditional(self, children: list[Any]) -> Expr:
        return self._at(Conditional(*children), children[0])

    def binary(self, children: list[Any]) -> Expr:
        left, op, right = children
        return self._at(Binary(str(op), left, right), left)

    def chain(self, children: list[Any]) -> Expr:
        return self._at(Chain(children[0::2], [str(op) for op in children[1::2]]), children[0])

    def unary(self, children: list[Any]) -> Expr:
        op, operand = children
        return self._at(Unary(str(op), operand), op)

    @staticmethod
    def _token(expr: Expr, token: lark.Token) -> Expr:
        expr.line, expr.column = token.line or 1, token.column or 1
        return expr

    def number(self, children: list[lark.Token]) -> Expr:
        (token,) = children
        text = str(token)
        if text[:2].lower() == "0x":
            return self._token(Literal(int(text, 16)), token)
        if any(c in text for c in ".eE"):
            return self._token(Literal(float(text)), token)
        return self._token(Literal(int(text)), token)

    def string(self, children: list[lark.Token]) -> Expr:
        (token,) = children
        return self._token(Literal(str(token)[1:-1]), token)

    def boolean(self, children: list[lark.Token]) -> Expr:
        (token,) = children
        return self._token(Literal(str(token) == "true"), token)

    def name(self, children: list[lark.Token]) -> Expr:
        (token,) = children
        return self._token(Name(str(token)), token)


def _expected(names: Any) -> str:
    readable = sorted({_TERMINALS.get(n, repr(n)) for n in names})
    return ", ".join(readable[:6]) + (", …" if len(readable) > 6 else "")


def parse(source: str) -> Script:
    """A script, checked completely; ScriptSyntaxError (with line and column) when it is not valid."""
    if not source.strip(" \t\r\n;"):
        raise ScriptSyntaxError("empty script; expected at least one statement", 1, 1)
    try:
        tree = _PARSER.parse(source)
    except lark.exceptions.UnexpectedCharacters as err:
        char = source[err.pos_in_stream] if err.pos_in_stream < len(source) else ""
        hint = " (strings use single quotes)" if char == '"' else ""
        raise ScriptSyntaxError(f"unexpected character {char!r}{hint}", err.line, err.column) from None
    except lark.exceptions.UnexpectedToken as err:
        token = err.token
        if token.type == "$END":
            line, column = _end_position(source)
            message = f"unexpected end of script; expected {_expected(err.expected)}"
            raise ScriptSyntaxError(message, line, column) from None
        line, column = token.line or 1, token.column or 1
        rest = source.split("\n")[line - 1][column - 1 :]
        if token.type == "ASSIGN" or rest.startswith(":="):
            shown = ":=" if rest.startswith(":=") else str(token)
            message = f"unexpected {shown!r}: only a blackboard entry's name can be assigned to"
        elif {"_SEMI", "$END"} & set(err.expected):
            message = f"unexpected {str(token)!r}; separate statements with ';'"
        else:
            message = f"unexpected {str(token)!r}; expected {_expected(err.expected)}"
        raise ScriptSyntaxError(message, line, column) from None
    except lark.exceptions.UnexpectedEOF as err:
        line, column = _end_position(source)
        raise ScriptSyntaxError(f"unexpected end of script; expected {_expected(err.expected)}", line, column) from None
    return Script(source, _Build().transform(tree))


def _end_position(source: str) -> tuple[int, int]:
    lines = source.split("\n")
    return len(lines), len(lines[-1]) + 1
