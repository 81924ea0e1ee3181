"""Drawing a BehaviorTree.CPP v4 file whose nodes this project does not register (issue 36): a Nav2 tree, a
team's own C++ nodes.

Groot2 draws such files from a ``<TreeNodesModel>`` — the file's own, or a palette such as the
``nav2_tree_nodes.xml`` Nav2 ships — that says each node's kind and ports. :func:`drawing_factory` does the
same for ``mission viz``: the shipped factory, plus a *model* manifest for every node type the file uses and
nothing registers, taken from the file's TreeNodesModel, then from the palettes given (``--nodes-model``),
and otherwise guessed from the file itself (its kind from how many children it has, its ports from the
attributes written). A model is drawn, never run: building one is a TreeError naming it, and a run still
refuses the file at load time (the shipped factory has no models), naming the unknown nodes.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from mission.behaviours.ports import REQUIRED, Port
from mission.core.errors import TreeError
from mission.trees.factory import BehaviourFactory, shipped_factory
from mission.trees.manifest import NodeKind
from mission.trees.xml_source import SourceElement, parse_file

KINDS: tuple[NodeKind, ...] = ("Action", "Condition", "Control", "Decorator")
STRUCTURAL = frozenset({"SubTree", "BehaviorTree", "include", "TreeNodesModel"})
NAME_ATTRIBUTES = frozenset({"name", "ID", "_description", "_uid", "_fullpath", "_autoremap"})


@dataclass
class NodeModel:
    """What is known of one node type: its kind and ports, and where that came from."""

    tag: str
    kind: NodeKind
    ports: dict[str, str] = field(default_factory=dict)  # name → direction (input | output | inout)
    source: str = ""  # "the file's TreeNodesModel", a palette's file name, or "guessed from the file"


def read_models(path: Path) -> dict[str, NodeModel]:
    """The Action / Condition / Control / Decorator models of a file's ``<TreeNodesModel>`` (a tree file or a
    palette); a file without one has none. A malformed file is a TreeError naming it."""
    root = parse_file(path)
    models: dict[str, NodeModel] = {}
    for section in (el for el in root.children if el.tag == "TreeNodesModel"):
        for el in section.children:
            if el.tag not in KINDS:
                continue
            tag = el.attrib.get("ID")
            if not tag:
                raise TreeError(el.error(f"missing ID; a <{el.tag}> model names the node type it describes"))
            ports = {
                p.attrib["name"]: p.tag.removesuffix("_port")
                for p in el.children
                if p.tag in ("input_port", "output_port", "inout_port") and p.attrib.get("name")
            }
            models[tag] = NodeModel(tag, el.tag, ports, path.name)  # type: ignore[arg-type]
    return models


def _elements(el: SourceElement) -> Iterator[SourceElement]:
    yield el
    for child in el.children:
        yield from _elements(child)


def _used(trees: Iterable[SourceElement], factory: BehaviourFactory) -> dict[str, list[SourceElement]]:
    """Every node type the trees use that `factory` does not know, with the elements that use it."""
    used: dict[str, list[SourceElement]] = {}
    for tree in trees:
        for el in _elements(tree):
            if el is tree or el.tag in STRUCTURAL:
                continue
            tag = el.attrib.get("ID", "") if el.tag in KINDS else el.tag
            if tag and factory.manifest(tag) is None:
                used.setdefault(tag, []).append(el)
    return used


def _guess(tag: str, uses: list[SourceElement]) -> NodeModel:
    """A model from the file alone: the kind its children say, every attribute written as an input."""
    if any(el.tag in KINDS for el in uses):
        kind = next(el.tag for el in uses if el.tag in KINDS)
    else:
        most = max(len(el.children) for el in uses)
        kind = "Action" if most == 0 else "Decorator" if most == 1 else "Control"
    return NodeModel(tag, kind, dict.fromkeys(_attributes(uses), "input"), "guessed from the file")  # type: ignore[arg-type]


def _attributes(uses: list[SourceElement]) -> list[str]:
    """The port attributes the file writes on these elements (not the name, the ID or Groot2's own)."""
    return [a for el in uses for a in el.attrib if a not in NAME_ATTRIBUTES and not a.startswith("_")]


def drawing_factory(path: str | Path, palettes: Iterable[str | Path] = ()) -> tuple[BehaviourFactory, list[NodeModel]]:
    """The shipped factory plus a model for every node type the file uses and nothing registers (module doc),
    and those models, in the order the file first uses them."""
    from mission.trees.loader import read_document

    factory = shipped_factory()
    doc = read_document(path)
    known: dict[str, NodeModel] = {}
    for palette in palettes:
        p = Path(palette)
        if not p.is_file():
            raise TreeError(f"--nodes-model {palette}: no such file; expected a BT.CPP file with a <TreeNodesModel>")
        known.update(read_models(p))
    for file in doc.files:  # the file's own models win over a palette's
        known.update({tag: _own(m) for tag, m in read_models(file).items()})
    models = []
    for tag, uses in _used(doc.trees.values(), factory).items():
        model = known.get(tag) or _guess(tag, uses)
        factory.model(model.tag, model.kind, _ports(model, uses), f"not runnable here: drawn from {model.source}")
        models.append(model)
    return factory, models


def _own(model: NodeModel) -> NodeModel:
    model.source = "the file's TreeNodesModel"
    return model


def _ports(model: NodeModel, uses: list[SourceElement]) -> dict[str, Port]:
    """The model's ports as optional, untyped strings, plus any attribute the file writes that it lacks (a
    model may be older than the tree): a drawing checks nothing about them."""
    names = dict(model.ports)
    for a in _attributes(uses):
        names.setdefault(a, "input")
    ports: dict[str, Any] = {}
    for name, direction in names.items():
        default = REQUIRED if direction == "output" else ""  # an output left out writes nothing
        ports[name] = Port(str, default, "from a model", direction)  # type: ignore[arg-type]
    return ports
