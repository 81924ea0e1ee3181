"""How a behaviour declares its XML ports — once — and the dependencies an application passes in.

BehaviorTree.CPP style: a node's ports are attributes in the tree file (``<FollowTarget target="target"
offset_m="0.5"/>``). A behaviour declares them in one place, a frozen keyword-only dataclass nested in the
class and named ``Params``: each field is a port (its annotation is the type, :func:`port` gives the
default, the meaning and the direction), and ``__post_init__`` holds the checks on values beyond their
type (ranges, formats). Everything else is derived from that declaration, so nothing can drift:

* ``PORTS`` (name → :class:`Port`), computed when the class is created — a malformed declaration fails
  at import;
* the constructor: ``FollowTarget("follow", offset_m=0.7)`` binds its keywords with
  :meth:`PortsDeclared.bind_params` (an unknown name, a missing required port or a wrong type is a
  TypeError naming the port) and keeps the result as ``self.params``;
* the tree loader's checks (trees/loader.py), which convert the XML strings and bind them the same way
  before anything is built, the Groot2 TreeNodesModel and the docs' behaviour table.

Directions are BehaviorTree.CPP's: an ``input`` port is a value the node reads (a constant in the tree
file, or a blackboard entry ``{key}`` read before every tick, so ``self.params`` always holds the current
value); an ``output`` port is an entry the node writes with :meth:`PortsDeclared.set_output` (its field is
not a constructor argument, and its default, if any, is the entry it writes when the tree file does not
connect it: ``port("{goal}", …, direction="output")``); an ``inout`` port is both. Port types are str,
int, float, bool and :class:`~mission.core.types.Pose2D` (written ``"x;y;yaw"`` as text).

The messages about a bad port (:func:`unknown_port`, :func:`missing_port`, :func:`wrong_type`) are here
too, so a tree file and a Python caller are told the same thing.
"""

from __future__ import annotations

import dataclasses
import difflib
import keyword
import math
import numbers
import typing
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any, ClassVar, Literal

from mission.core.types import Pose2D

Direction = Literal["input", "output", "inout"]
DIRECTIONS: tuple[str, ...] = ("input", "output", "inout")

#: the Python types a port may have: what a tree file's strings convert to, and what Groot2 can show
PORT_TYPES: tuple[type, ...] = (str, int, float, bool, Pose2D)

_METADATA_KEY = "mission.port"  # where port() keeps the meaning and direction in a dataclass field


class _Required:
    def __repr__(self) -> str:
        return "REQUIRED"


REQUIRED: Any = _Required()


@dataclass(frozen=True)
class Port:
    """One XML attribute of a node: its Python type, default, meaning and direction.

    For an ``output`` port the default is the blackboard entry it writes when the tree file leaves it
    out (``"{key}"``), or REQUIRED for none: an output need not be connected.
    """

    type: type
    default: Any = REQUIRED
    doc: str = ""
    direction: Direction = "input"

    @property
    def required(self) -> bool:
        """A value must be written in the tree file (inputs and inouts without a default)."""
        return self.direction != "output" and self.default is REQUIRED

    @property
    def reads(self) -> bool:
        return self.direction != "output"

    @property
    def writes(self) -> bool:
        return self.direction != "input"

    @property
    def type_name(self) -> str:
        return getattr(self.type, "__name__", str(self.type))

    def accepts(self, value: object) -> bool:
        """Whether a Python value can be this port's value: an int for a float port, never a bool for a number."""
        if isinstance(value, bool):
            return self.type is bool
        if self.type is float:
            return isinstance(value, numbers.Real)
        if self.type is int:
            return isinstance(value, numbers.Integral)
        return isinstance(value, self.type)

    def parse(self, text: str) -> Any:
        """The port's value written as text (XML, a SubTree constant, a string entry); ValueError says what
        was expected. Booleans are true/false/1/0, poses ``x;y;yaw`` (BT.CPP's separator)."""
        if self.type is str:
            return text
        if self.type is bool:
            low = text.strip().lower()
            if low in ("true", "1"):
                return True
            if low in ("false", "0"):
                return False
            raise ValueError("bool (true/false)")
        if self.type is Pose2D:
            parts = text.split(";")
            try:
                x, y, yaw = (float(p) for p in parts)
            except ValueError:
                raise ValueError("Pose2D ('x;y;yaw')") from None
            if not all(math.isfinite(v) for v in (x, y, yaw)):
                raise ValueError("Pose2D ('x;y;yaw', finite numbers)")
            return Pose2D(x, y, yaw)
        try:
            value = self.type(text.strip())
        except (TypeError, ValueError):
            raise ValueError(self.type_name) from None
        if self.type is float and not math.isfinite(value):  # "nan" / "inf" parse, but no behaviour can use them
            raise ValueError("a finite float")
        return value

    def coerce(self, value: object) -> Any:
        """A blackboard entry's value as this port's type, as BT.CPP's getInput converts it: text is parsed,
        an integral float is a fine int, 0/1 are booleans, numbers become text for a str port; ValueError
        says what was expected."""
        if isinstance(value, str) and self.type is not str:
            return self.parse(value)
        if self.type is str:
            if isinstance(value, bool):
                return "1" if value else "0"
            if isinstance(value, float):
                return f"{value:f}"  # std::to_string(double), as BT.CPP turns a number into text
            if isinstance(value, int):
                return str(value)
        elif self.type is bool and isinstance(value, numbers.Real) and value in (0, 1):
            return bool(value)
        elif self.type is int and isinstance(value, float) and not isinstance(value, bool) and value.is_integer():
            return int(value)
        if not self.accepts(value):
            raise ValueError(self.type_name)
        return self.type(value) if self.type in (int, float) else value


@dataclass(frozen=True)
class BlackboardRef:
    """A port connected to a blackboard entry: ``{key}`` in the tree file, `path` the entry it resolved to.

    Given to a constructor in place of a value, it means "read before every tick"; the loader resolves
    `path` through the SubTree scopes (trees/scopes.py)."""

    key: str  # as written between the braces: "tgt", "@tgt"
    path: str  # the py_trees blackboard entry: "/tree/tgt", "/mission/state", …

    def __str__(self) -> str:
        return "{" + self.key + "}"


def port(default: Any = REQUIRED, doc: str = "", *, direction: Direction = "input") -> Any:
    """A field of a behaviour's ``Params``: one port, with its default (REQUIRED: none) and meaning.

    Typed ``Any`` so that ``offset_m: float = port(0.5, "…")`` reads as the field's default does. An
    output's field is always None in ``Params`` (the node writes it, nobody passes it); its `default` is
    the entry it writes when the tree file does not say (``"{key}"``), REQUIRED for none.
    """
    if direction not in DIRECTIONS:
        raise TypeError(f"port direction {direction!r}: expected one of {', '.join(DIRECTIONS)}")
    metadata = {_METADATA_KEY: (doc, direction, default)}
    if direction == "output":
        return field(default=None, metadata=metadata)
    if default is REQUIRED:
        return field(metadata=metadata)
    return field(default=default, metadata=metadata)


def declared_ports(params: type, owner: str) -> Mapping[str, Port]:
    """The ports a ``Params`` dataclass declares, in field order; TypeError naming what is malformed."""
    where = f"{owner}.Params"
    if not (isinstance(params, type) and dataclasses.is_dataclass(params)):
        raise TypeError(f"{where}: expected a dataclass declaring the ports, got {params!r}")
    if not params.__dataclass_params__.frozen:  # type: ignore[attr-defined]
        raise TypeError(f"{where}: expected @dataclass(frozen=True, kw_only=True); port values never change")
    hints = typing.get_type_hints(params)
    ports: dict[str, Port] = {}
    for f in dataclasses.fields(params):
        if _METADATA_KEY not in f.metadata:
            raise TypeError(f"{where}.{f.name}: expected a port(default, doc) field")
        doc, direction, default = f.metadata[_METADATA_KEY]
        kind = hints[f.name]
        if kind not in PORT_TYPES:
            named = getattr(kind, "__name__", repr(kind))
            raise TypeError(
                f"{where}.{f.name}: type {named} is not a port type; expected str, int, float, bool or Pose2D"
            )
        if direction == "output":
            if default is not REQUIRED and not (isinstance(default, str) and is_pointer(default)):
                raise TypeError(
                    f"{where}.{f.name}: an output's default is the entry it writes, '{{key}}'; got {default!r}"
                )
        elif default is not REQUIRED and type(default) is not kind:
            raise TypeError(f"{where}.{f.name}: default {default!r} is not {kind.__name__}")
        ports[port_name(f.name)] = Port(kind, default, doc, direction)
    return MappingProxyType(ports)


def port_name(field_name: str) -> str:
    """The port a ``Params`` field declares: its name, less the trailing ``_`` of a Python keyword
    (``in_`` declares the port ``in``, as PEP 8 spells a name that clashes with a keyword)."""
    bare = field_name[:-1]
    return bare if field_name.endswith("_") and keyword.iskeyword(bare) else field_name


def field_name(port: str) -> str:
    """The ``Params`` field that holds `port` (``in`` → ``in_``)."""
    return f"{port}_" if keyword.iskeyword(port) else port


def is_pointer(text: str) -> bool:
    """``{key}`` (BT.CPP's blackboard pointer, spaces around allowed) or ``{=}``."""
    stripped = text.strip(" ")
    return len(stripped) >= 3 and stripped[0] == "{" and stripped[-1] == "}"


# ------------------------------------------------------------------------ what a bad port is told
def unknown_port(name: str, owner: str, ports: Mapping[str, Port]) -> str:
    """``unknown port 'gian' (did you mean gain?); Probe ports: label, gain``"""
    hint = difflib.get_close_matches(name, list(ports), n=1)
    return (
        f"unknown port {name!r}{f' (did you mean {hint[0]}?)' if hint else ''}; "
        f"{owner} ports: {', '.join(ports) or 'none'}"
    )


def missing_port(name: str, declared: Port) -> str:
    """``missing required port mode (str); which mode``"""
    return f"missing required port {name} ({declared.type_name}); {declared.doc}".rstrip("; ")


def wrong_type(name: str, expected: str, got: object) -> str:
    """``port gain expects float, got 'far'``"""
    return f"port {name} expects {expected}, got {got!r}"


# ----------------------------------------------------------------------------- the declaration
@dataclass(frozen=True, kw_only=True)
class NoParams:
    """The ``Params`` of a behaviour without ports."""


#: writes one output port's value where the tree file connected it (installed by the tree loader);
#: returns False when the port is not connected
OutputSink = Callable[[str, Any], bool]


class PortsDeclared:
    """Mixin for a behaviour class: ``NODE_TYPE`` (Groot2's kind) and the ports its ``Params`` declares.

    A subclass nests its own ``Params``; ``PORTS`` is derived from it when the subclass is created.
    """

    NODE_TYPE: ClassVar[Literal["Action", "Condition", "Decorator", "Control"]] = "Action"
    Params: ClassVar[type] = NoParams
    PORTS: ClassVar[Mapping[str, Port]] = MappingProxyType({})
    #: where set_output writes (the tree loader installs it on each node it builds; None: nothing connected)
    port_sink: OutputSink | None = None
    #: the output ports the tree file connected to an entry (the loader sets it with port_sink)
    connected_outputs: frozenset[str] = frozenset()

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        cls.PORTS = declared_ports(cls.Params, cls.__name__)

    @classmethod
    def bind_params(cls, given: Mapping[str, Any]) -> Any:
        """``cls.Params`` for the keyword arguments `given`, checked against the declaration.

        An unknown or missing port or a value of the wrong type is a TypeError naming the port (as
        calling a function wrongly is); ints become floats for float ports; ``Params.__post_init__``
        raises ValueError for a value out of range. Outputs are not arguments (the node writes them).

        A :class:`BlackboardRef` in place of a value (a port the tree file connects to an entry) is read
        before every tick; until then the port holds its default, or REQUIRED, and the declaration's
        checks wait for the real values.
        """
        owner = cls.__name__
        for name in given:
            if name not in cls.PORTS:
                raise TypeError(f"{owner}: {unknown_port(name, owner, cls.PORTS)}")
            if not cls.PORTS[name].reads:
                raise TypeError(f"{owner}: {name} is an output port: the node writes it, nobody gives it a value")
        values: dict[str, Any] = {}
        pending = False
        for name, declared in cls.PORTS.items():
            if not declared.reads:
                continue
            if name not in given:
                if declared.required:
                    raise TypeError(f"{owner}: {missing_port(name, declared)}")
                continue
            value = given[name]
            if isinstance(value, BlackboardRef):
                pending = True
                values[name] = declared.default
                continue
            if not declared.accepts(value):
                raise TypeError(f"{owner}: {wrong_type(name, declared.type_name, value)}")
            values[name] = declared.type(value) if declared.type in (int, float) else value
        if pending:
            return _provisional(cls.Params, values)
        return cls.Params(**{field_name(name): value for name, value in values.items()})

    def output_connected(self, name: str) -> bool:
        """Whether the tree file connected output `name`: a value that costs work to compute is only worth
        computing for set_output when someone reads it."""
        return name in self.connected_outputs

    def set_output(self, name: str, value: Any) -> bool:
        """Write output (or inout) port `name`: the blackboard entry the tree file connected it to.

        Returns False when the port is not connected (nothing is written, nothing checked: a leaf sets its
        outputs every tick, most of them unconnected). A value of the wrong type for a connected port is a
        TypeError: the declaration says what the port carries."""
        declared = self.PORTS.get(name)
        if declared is None or not declared.writes:
            raise ValueError(
                f"{type(self).__name__}: {name} is not an output port; outputs: "
                f"{', '.join(n for n, p in self.PORTS.items() if p.writes) or 'none'}"
            )
        sink = self.port_sink
        if sink is None or name not in self.connected_outputs:
            return False
        if value is not None and not declared.accepts(value):
            raise TypeError(f"{type(self).__name__}: {wrong_type(name, declared.type_name, value)}")
        return sink(name, value)


def _provisional(params: type, values: dict[str, Any]) -> Any:
    """A Params holding `values` without running its checks: the ports read from the blackboard are not
    known before the first tick (their fields hold the default, or REQUIRED, until then)."""
    obj = object.__new__(params)
    for f in dataclasses.fields(params):
        value = values.get(port_name(f.name), f.default if f.default is not dataclasses.MISSING else REQUIRED)
        object.__setattr__(obj, f.name, value)
    return obj
