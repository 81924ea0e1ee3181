"""What the tree factory knows about one node type: its tag, Groot2 kind, ports, builder and checks.

BehaviorTree.CPP calls this a node's manifest. The BT.CPP built-ins (trees/builtins.py) and the behaviours
registered in a factory (trees/factory.py) are both manifests, so the loader checks and builds every node
of a tree file the same way, and the TreeNodesModel and the docs' table read the same records.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any, Literal

from py_trees.behaviour import Behaviour

from mission.behaviours.ports import Port

NodeKind = Literal["Action", "Condition", "Control", "Decorator", "SubTree"]


@dataclass(frozen=True)
class BuildContext:
    """What a built-in needs beyond its ports to be built: the scripts parsed from its ports, where a
    blackboard key of its scope is (``entry_path``), and the scripting enums."""

    scripts: Mapping[str, Any] = field(default_factory=dict)  # port name → script.Script
    entry_path: Callable[[str], str] = lambda key: key
    enums: Mapping[str, int] = field(default_factory=dict)


#: (instance name, built children, port values with defaults, context) → the py_trees behaviour; a port
#: connected to a blackboard entry is given as a BlackboardRef
Builder = Callable[[str, list[Behaviour], dict[str, Any], BuildContext], Behaviour]
#: (port values with defaults, number of children) → what is wrong with them, or None
Check = Callable[[dict[str, Any], int], "str | None"]


@dataclass(frozen=True)
class NodeManifest:
    """One node type a tree file may use; `check` runs when the tree is validated, before anything is built.

    `children` is the number of children allowed (min, max or None) when it is not the kind's rule;
    `scripts` are ports whose text is a script (parsed at load); `untyped` ports accept a value of any type
    (BT.CPP's AnyTypeAllowed), so they take part in no type check.
    """

    tag: str
    kind: NodeKind
    doc: str
    build: Builder
    ports: Mapping[str, Port] = field(default_factory=dict)
    check: Check | None = None
    children: tuple[int, int | None] | None = None
    scripts: frozenset[str] = frozenset()
    untyped: frozenset[str] = frozenset()
    deprecated: bool = False  # still loads and runs; left out of the palette unless a tree uses it
    runnable: bool = True  # False: a model from a TreeNodesModel, drawn by `mission viz`, never built
