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
  before anything is built, the Groot2 TreeNodesModel and the README's behaviour table.

The messages about a bad port (:func:`unknown_port`, :func:`missing_port`, :func:`wrong_type`) are here
too, so a tree file and a Python caller are told the same thing.
"""

from __future__ import annotations

import dataclasses
import difflib
import numbers
import typing
from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any, ClassVar, Literal

Direction = Literal["input", "output"]

#: the Python types a port may have: what a tree file's strings convert to, and what Groot2 can show
PORT_TYPES: tuple[type, ...] = (str, int, float, bool)

_METADATA_KEY = "mission.port"  # where port() keeps the meaning and direction in a dataclass field


class _Required:
    def __repr__(self) -> str:
        return "REQUIRED"


REQUIRED: Any = _Required()


@dataclass(frozen=True)
class Port:
    """One XML attribute of a node: its Python type (str, int, float, bool), default, and meaning."""

    type: type
    default: Any = REQUIRED
    doc: str = ""
    direction: Direction = "input"

    @property
    def required(self) -> bool:
        return self.default is REQUIRED

    def accepts(self, value: object) -> bool:
        """Whether a Python value can be this port's value: an int for a float port, never a bool for a number."""
        if isinstance(value, bool):
            return self.type is bool
        if self.type is float:
            return isinstance(value, numbers.Real)
        if self.type is int:
            return isinstance(value, numbers.Integral)
        return isinstance(value, self.type)


def port(default: Any = REQUIRED, doc: str = "", *, direction: Direction = "input") -> Any:
    """A field of a behaviour's ``Params``: one port, with its default (REQUIRED: none) and meaning.

    Typed ``Any`` so that ``offset_m: float = port(0.5, "…")`` reads as the field's default does.
    """
    metadata = {_METADATA_KEY: (doc, direction)}
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
        doc, direction = f.metadata[_METADATA_KEY]
        kind = hints[f.name]
        if kind not in PORT_TYPES:
            named = getattr(kind, "__name__", repr(kind))
            raise TypeError(f"{where}.{f.name}: type {named} is not a port type; expected str, int, float or bool")
        default = REQUIRED if f.default is dataclasses.MISSING else f.default
        if default is not REQUIRED and type(default) is not kind:
            raise TypeError(f"{where}.{f.name}: default {default!r} is not {kind.__name__}")
        ports[f.name] = Port(kind, default, doc, direction)
    return MappingProxyType(ports)


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
    return f"missing required port {name} ({declared.type.__name__}); {declared.doc}".rstrip("; ")


def wrong_type(name: str, expected: str, got: object) -> str:
    """``port gain expects float, got 'far'``"""
    return f"port {name} expects {expected}, got {got!r}"


# ----------------------------------------------------------------------------- the declaration
@dataclass(frozen=True, kw_only=True)
class NoParams:
    """The ``Params`` of a behaviour without ports."""


class PortsDeclared:
    """Mixin for a behaviour class: ``NODE_TYPE`` (Groot2's kind) and the ports its ``Params`` declares.

    A subclass nests its own ``Params``; ``PORTS`` is derived from it when the subclass is created.
    """

    NODE_TYPE: ClassVar[Literal["Action", "Condition", "Decorator", "Control"]] = "Action"
    Params: ClassVar[type] = NoParams
    PORTS: ClassVar[Mapping[str, Port]] = MappingProxyType({})

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        cls.PORTS = declared_ports(cls.Params, cls.__name__)

    @classmethod
    def bind_params(cls, given: Mapping[str, Any]) -> Any:
        """``cls.Params`` for the keyword arguments `given`, checked against the declaration.

        An unknown or missing port or a value of the wrong type is a TypeError naming the port (as
        calling a function wrongly is); ints become floats for float ports; ``Params.__post_init__``
        raises ValueError for a value out of range.
        """
        owner = cls.__name__
        for name in given:
            if name not in cls.PORTS:
                raise TypeError(f"{owner}: {unknown_port(name, owner, cls.PORTS)}")
        values: dict[str, Any] = {}
        for name, declared in cls.PORTS.items():
            if name not in given:
                if declared.required:
                    raise TypeError(f"{owner}: {missing_port(name, declared)}")
                continue
            value = given[name]
            if not declared.accepts(value):
                raise TypeError(f"{owner}: {wrong_type(name, declared.type.__name__, value)}")
            values[name] = declared.type(value)
        return cls.Params(**values)

