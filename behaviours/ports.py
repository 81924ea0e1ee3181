"""How a behaviour declares its XML ports, and the dependencies the tree factory injects.

BehaviorTree.CPP style: a node's ports are attributes in the tree file (``<FollowTarget target="target"
offset_m="0.5"/>``). A class lists them in ``PORTS``; the loader (trees/loader.py) checks names,
required-ness and types before the first tick, converts the strings, and passes them to the
constructor as keyword arguments. Classes that need injected dependencies accept a ``deps`` keyword.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, ClassVar, Literal

from mission.core.config import TargetSpec
from mission.core.perception import PerceptionSource


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
    direction: Literal["input", "output"] = "input"

    @property
    def required(self) -> bool:
        return self.default is REQUIRED


@dataclass
class Dependencies:
    """What the application injects into the behaviours that ask for it (never globals)."""

    sources: list[PerceptionSource] = field(default_factory=list)
    targets: dict[str, TargetSpec] = field(default_factory=dict)
    policy: str = "hybrid"


class PortsDeclared:
    """Mixin: `PORTS` maps attribute name → Port; `NODE_TYPE` is Action or Condition (for Groot2)."""

    PORTS: ClassVar[dict[str, Port]] = {}
    NODE_TYPE: ClassVar[Literal["Action", "Condition", "Decorator", "Control"]] = "Action"
