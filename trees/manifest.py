"""What the tree factory knows about one node type: its tag, Groot2 kind, ports, builder and checks.

BehaviorTree.CPP calls this a node's manifest. The BT.CPP built-ins (trees/controls.py) and the behaviours
registered in a factory (trees/factory.py) are both manifests, so the loader checks and builds every node
of a tree file the same way, and the TreeNodesModel and the README's table read the same records.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any, Literal

from py_trees.behaviour import Behaviour

from mission.behaviours.ports import Port

NodeKind = Literal["Action", "Condition", "Control", "Decorator", "SubTree"]

#: (instance name, built children, port values with defaults) → the py_trees behaviour
Builder = Callable[[str, list[Behaviour], dict[str, Any]], Behaviour]
#: (port values with defaults, number of children) → what is wrong with them, or None
Check = Callable[[dict[str, Any], int], "str | None"]


@dataclass(frozen=True)
class NodeManifest:
    """One node type a tree file may use; `check` runs when the tree is validated, before anything is built."""

    tag: str
    kind: NodeKind
    doc: str
    build: Builder
    ports: Mapping[str, Port] = field(default_factory=dict)
    check: Check | None = None
