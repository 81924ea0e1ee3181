"""Build py_trees from BehaviorTree.CPP v4 XML — after validating the whole file set.

A tree file is data a user edits (by hand or in Groot2), so every mistake must stop start-up with
one line naming the file, the line, the element and what was expected, before anything is built or
ticked. The loader works in three steps:

1. **read** (:func:`read_document`): the file and its ``<include>``s as line-numbered elements
   (trees/xml_source.py); ``<root BTCPP_format="4">``, include paths relative to the including file,
   include cycles, duplicate tree IDs, the main tree.
2. **compile** (:func:`describe_tree`): every ``<BehaviorTree>`` into a :class:`TreeDescription`:
   node types looked up in the factory (trees/factory.py: the BT.CPP built-ins and the registered
   behaviours), ports checked and converted from strings, then checked as each node type's
   declaration checks them (ranges, formats), child counts, SubTree references and recursion.
   Problems are collected; the first one is raised as :class:`~mission.core.errors.TreeError`
   (``err.problems`` holds them all).
3. **build** (:func:`load_tree`): py_trees behaviours from the description, by the factory's
   builders. Port values are constants passed to constructors (no blackboard remapping, so no UUID
   keys), with the arguments each behaviour was registered with (its dependencies).
   A ``<SubTree ID="X">`` is flattened: the subtree's root is built in place and named ``X`` (or the
   SubTree's ``name``), so viewers show which subtree is running.

Every function takes the factory to look node types up in; without one, :func:`shipped_factory` (the
shipped behaviours, no perception sources) — enough to describe, validate or draw a tree.
"""

from __future__ import annotations

import difflib
import math
import re
from collections.abc import Collection, Iterator, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from py_trees.behaviour import Behaviour

from mission.behaviours.ports import Port, missing_port, unknown_port, wrong_type
from mission.core.errors import TreeError
from mission.trees.controls import UNSUPPORTED_BUILTINS
from mission.trees.factory import BehaviourFactory, shipped_factory
from mission.trees.manifest import NodeKind, NodeManifest
from mission.trees.xml_source import SourceElement, display_path, parse_file

TREES_DIR = Path(__file__).resolve().parent
FORMAT = "4"

#: ``<Action ID="X"/>`` is the explicit spelling of ``<X/>`` (Groot2 can write either)
EXPLICIT_KIND_TAGS = ("Action", "Condition", "Control", "Decorator")
#: attributes BT.CPP/Groot2 may write that carry no behaviour here
IGNORED_ATTRIBUTES = frozenset({"_description", "_uid", "_fullpath"})
_REMAP = re.compile(r"^\s*\{.*\}\s*$")
_TRUE = frozenset({"true", "1"})
_FALSE = frozenset({"false", "0"})


# ---------------------------------------------------------------------------------------- paths
def shipped_trees() -> list[str]:
    """File names of the trees that ship with the package (trees/*.xml)."""
    return sorted(p.name for p in TREES_DIR.glob("*.xml"))


def resolve_tree_path(name_or_path: str | Path) -> Path:
    """A tree file: the path as given when it exists, else a shipped file (``follow`` or ``follow.xml``)."""
    given = Path(name_or_path)
    if given.is_file():
        return given
    for candidate in (TREES_DIR / str(name_or_path), TREES_DIR / f"{name_or_path}.xml"):
        if candidate.is_file():
            return candidate
    raise TreeError(
        f"{name_or_path}: tree file not found; expected a path to a BehaviorTree.CPP v4 XML file "
        f"or a shipped tree: {', '.join(shipped_trees())}"
    )


# ---------------------------------------------------------------------------------- description
@dataclass
class TreeDescription:
    """One node of a tree as written in the file, checked and with converted port values.

    The root returned by :func:`describe_tree` is the main tree itself (``tag="BehaviorTree"``,
    ``kind="SubTree"``); a ``<SubTree>`` has ``kind="SubTree"`` and the referenced tree's root as its
    only child. Viewers draw this without building behaviours.
    """

    tag: str  # node type: "FollowTarget", "Sequence", "SubTree", "BehaviorTree"
    name: str  # instance name (the `name` attribute, default: the tag; subtrees: the ID)
    kind: NodeKind
    file: str  # as shown in messages (relative to the working directory when inside it)
    line: int
    ports: dict[str, Any] = field(default_factory=dict)  # written in the file, converted
    effective_ports: dict[str, Any] = field(default_factory=dict)  # with declared defaults
    children: list[TreeDescription] = field(default_factory=list)
    subtree: str | None = None  # the tree ID for SubTree / BehaviorTree nodes
    manifest: NodeManifest | None = field(default=None, repr=False, compare=False)  # None for SubTrees

    def walk(self) -> Iterator[TreeDescription]:
        """This node and every node below it, depth first."""
        yield self
        for child in self.children:
            yield from child.walk()


# ------------------------------------------------------------------------------------- reading
@dataclass
class TreeDocument:
    """A tree file with its includes: every ``<BehaviorTree>`` element by ID, and the main tree."""

    path: Path
    main_id: str
    trees: dict[str, SourceElement]
    files: list[Path]


def read_document(path: str | Path) -> TreeDocument:
    """Read a tree file and its includes; raise TreeError at the first file-level problem."""
    top = resolve_tree_path(path)
    trees: dict[str, SourceElement] = {}
    files: list[Path] = []
    top_root = _read_file(top.resolve(), [], trees, files)
    own = [el.attrib["ID"] for el in top_root.children if el.tag == "BehaviorTree"]
    main = top_root.attrib.get("main_tree_to_execute")
    if main is not None:
        if main not in trees:
            raise TreeError(
                top_root.error(f'main_tree_to_execute="{main}" names no tree; trees defined: {_names(trees)}')
            )
        return TreeDocument(top, main, trees, files)
    candidates = own if own else list(trees)
    if len(candidates) != 1:
        raise TreeError(
            top_root.error(
                f"the file defines {len(candidates)} trees ({', '.join(candidates) or 'none'}); "
                'expected exactly one <BehaviorTree ID="..."> or main_tree_to_execute="ID"'
            )
        )
    return TreeDocument(top, candidates[0], trees, files)


def _read_file(path: Path, stack: list[Path], trees: dict[str, SourceElement], files: list[Path]) -> SourceElement:
    root = parse_file(path)
    files.append(path)
    if root.tag != "root":
        raise TreeError(root.error(f'expected <root BTCPP_format="{FORMAT}"> as the document element'))
    fmt = root.attrib.get("BTCPP_format")
    if fmt is None:
        raise TreeError(root.error(f'missing BTCPP_format="{FORMAT}"; this loader reads BehaviorTree.CPP v4 files'))
    if fmt != FORMAT:
        raise TreeError(root.error(f'BTCPP_format="{fmt}" is not supported; expected "{FORMAT}"'))
    for attr in root.attrib:
        if attr not in ("BTCPP_format", "main_tree_to_execute"):
            raise TreeError(root.error(f"unknown attribute {attr!r}; expected BTCPP_format, main_tree_to_execute"))
    for el in root.children:
        if el.tag == "include":
            _read_include(el, path, stack, trees, files)
        elif el.tag == "BehaviorTree":
            tree_id = el.attrib.get("ID")
            if not tree_id:
                raise TreeError(el.error('missing ID; expected <BehaviorTree ID="Name">'))
            if tree_id in trees:
                raise TreeError(el.error(f"tree {tree_id} is already defined at {trees[tree_id].where}"))
            trees[tree_id] = el
        elif el.tag != "TreeNodesModel":
            raise TreeError(el.error("unexpected element; expected <BehaviorTree>, <include> or <TreeNodesModel>"))
    return root


def _read_include(
    el: SourceElement, including: Path, stack: list[Path], trees: dict[str, SourceElement], files: list[Path]
) -> None:
    if "ros_pkg" in el.attrib:
        raise TreeError(el.error("ros_pkg includes are not supported; expected a path relative to this file"))
    rel = el.attrib.get("path")
    if not rel:
        raise TreeError(el.error('missing path; expected <include path="other.xml"/>'))
    target = (including.parent / rel).resolve()
    if not target.is_file() and not Path(rel).is_absolute() and (TREES_DIR / rel).is_file():
        target = (TREES_DIR / rel).resolve()  # a shipped subtree (follow.xml) from a user's own tree file
    chain = [*stack, including]
    if target in chain:
        cycle = " → ".join(display_path(p) for p in [*chain[chain.index(target) :], target])
        raise TreeError(el.error(f"include cycle: {cycle}"))
    if target in files:  # already read through another include (a diamond, not a cycle)
        return
    if not target.is_file():
        raise TreeError(el.error(
            f"included file not found: {display_path(target)} "
            f"(paths are relative to this file, or name a shipped tree: {', '.join(shipped_trees())})"
        ))  # fmt: skip
    _read_file(target, chain, trees, files)


def _a(word: str) -> str:
    return f"{'an' if word[0] in 'AEIOU' else 'a'} {word}"


def _names(items: Any) -> str:
    return ", ".join(sorted(items)) or "none"


# ----------------------------------------------------------------------------------- compiling
def convert_port(text: str, port: Port) -> Any:
    """A port's XML string as the declared Python type; ValueError says what was expected."""
    if port.type is bool:
        low = text.strip().lower()
        if low in _TRUE:
            return True
        if low in _FALSE:
            return False
        raise ValueError("bool (true/false)")
    if port.type is str:
        return text
    try:
        value = port.type(text.strip())
    except (TypeError, ValueError):
        raise ValueError(getattr(port.type, "__name__", str(port.type))) from None
    if port.type is float and not math.isfinite(value):  # "nan" / "inf" parse, but no behaviour can use them
        raise ValueError("a finite float")
    return value


class _Compiler:
    """Checks every tree (each SubTree use expanded in place), collecting problems deduplicated, in order."""

    def __init__(self, doc: TreeDocument, factory: BehaviourFactory) -> None:
        self.doc = doc
        self.factory = factory
        self.problems: list[str] = []
        self.reached: set[str] = set()

    def problem(self, message: str) -> None:
        if message not in self.problems:
            self.problems.append(message)

    def tree(self, tree_id: str, stack: tuple[str, ...]) -> TreeDescription:
        """The ``<BehaviorTree ID>`` element as a SubTree-kind node whose child is the tree's root."""
        el = self.doc.trees[tree_id]
        self.reached.add(tree_id)
        desc = TreeDescription("BehaviorTree", tree_id, "SubTree", display_path(el.file), el.line, subtree=tree_id)
        for attr in el.attrib:
            if attr != "ID" and not attr.startswith("_"):
                self.problem(el.error(f"unknown attribute {attr!r}; expected only ID"))
        if len(el.children) != 1:
            self.problem(el.error(f"has {len(el.children)} root nodes; expected exactly one"))
        for child in el.children:
            node = self.node(child, (*stack, tree_id))
            if node is not None:
                desc.children.append(node)
        return desc

    def node(self, el: SourceElement, stack: tuple[str, ...]) -> TreeDescription | None:
        attrs = dict(el.attrib)
        node_type = el.tag
        explicit_kind = None
        if el.tag in EXPLICIT_KIND_TAGS:
            explicit_kind = el.tag
            node_type = attrs.pop("ID", "")
            if not node_type:
                self.problem(el.error(f'missing ID; expected <{el.tag} ID="NodeType" .../>'))
                return None
        if node_type == "SubTree":
            return self.subtree(el, attrs, stack)

        manifest = self.factory.manifest(node_type)
        if manifest is None:
            self.problem(el.error(self._unknown_node(node_type)))
            for child in el.children:
                self.node(child, stack)
            return None
        kind, ports = manifest.kind, manifest.ports
        if explicit_kind is not None and explicit_kind != kind:
            self.problem(el.error(f"{node_type} is {_a(kind)}, not {_a(explicit_kind)}; write <{kind} ID=...>"))

        name = attrs.pop("name", node_type)
        written = self.ports(el, node_type, attrs, ports)
        effective = {k: p.default for k, p in ports.items() if not p.required}
        effective.update(written)
        missing = [k for k, p in ports.items() if p.required and k not in attrs]
        for port_name in missing:
            self.problem(el.error(missing_port(port_name, ports[port_name])))

        children = [c for c in (self.node(child, stack) for child in el.children) if c is not None]
        self.child_count(el, kind, len(el.children))
        if manifest.check and not missing and set(ports) <= set(effective):
            message = manifest.check(effective, len(el.children))
            if message:
                self.problem(el.error(message))
        return TreeDescription(
            node_type, name, kind, display_path(el.file), el.line, written, effective, children, manifest=manifest
        )

    def ports(
        self, el: SourceElement, node_type: str, attrs: dict[str, str], ports: Mapping[str, Port]
    ) -> dict[str, Any]:
        values: dict[str, Any] = {}
        for attr, text in attrs.items():
            if attr in IGNORED_ATTRIBUTES:
                continue
            if attr.startswith("_"):
                self.problem(el.error(f"{attr} (BT.CPP scripting pre/post conditions) is not supported"))
                continue
            if attr not in ports:
                self.problem(el.error(unknown_port(attr, node_type, ports)))
                continue
            if _REMAP.match(text):
                self.problem(
                    el.error(
                        f'port {attr}="{text}" is a blackboard remapping, which is not supported yet; '
                        "expected a constant value"
                    )
                )
                continue
            try:
                values[attr] = convert_port(text, ports[attr])
            except ValueError as exc:
                self.problem(el.error(wrong_type(attr, str(exc), text)))
        return values

    def child_count(self, el: SourceElement, kind: NodeKind, n: int) -> None:
        if kind == "Decorator" and n != 1:
            self.problem(el.error(f"decorator has {n} children; expected exactly 1"))
        elif kind == "Control" and n == 0:
            self.problem(el.error("control node has no children; expected at least 1"))
        elif kind in ("Action", "Condition") and n:
            self.problem(el.error(f"{kind.lower()} node has {n} child{'ren' if n > 1 else ''}; expected none"))

    def subtree(self, el: SourceElement, attrs: dict[str, str], stack: tuple[str, ...]) -> TreeDescription | None:
        tree_id = attrs.pop("ID", "")
        name = attrs.pop("name", tree_id)
        if el.children:
            self.problem(el.error(f"SubTree has {len(el.children)} children; expected none (it refers to a tree)"))
        for attr in attrs:
            if attr in IGNORED_ATTRIBUTES or attr == "_autoremap":
                continue
            self.problem(
                el.error(
                    f"SubTree port {attr!r}: remapping into subtrees is not supported yet; "
                    "set constant ports on the nodes inside the subtree"
                )
            )
        if not tree_id:
            self.problem(el.error('missing ID; expected <SubTree ID="TreeName"/>'))
            return None
        if tree_id not in self.doc.trees:
            hint = difflib.get_close_matches(tree_id, self.doc.trees, n=1)
            self.problem(
                el.error(
                    f"unknown subtree {tree_id!r}{f' (did you mean {hint[0]}?)' if hint else ''}; "
                    f"trees defined: {_names(self.doc.trees)}"
                )
            )
            return None
        if tree_id in stack:
            cycle = " → ".join([*stack[stack.index(tree_id) :], tree_id])
            self.problem(el.error(f"recursive subtree: {cycle}; a tree cannot contain itself"))
            return None
        inner = self.tree(tree_id, stack)
        return TreeDescription(
            "SubTree", name, "SubTree", display_path(el.file), el.line, subtree=tree_id, children=inner.children
        )

    def _unknown_node(self, node_type: str) -> str:
        builtins = [m.tag for m in self.factory.builtins()]
        if node_type in UNSUPPORTED_BUILTINS:
            return (
                f"the BT.CPP built-in {node_type} is not supported by this loader; "
                f"supported built-ins: {', '.join(builtins)}, SubTree"
            )
        leaves = [m.tag for m in self.factory.behaviours()]
        hint = difflib.get_close_matches(node_type, [*leaves, *builtins, "SubTree"], n=1)
        return (
            f"unknown node {node_type!r}{f' (did you mean {hint[0]}?)' if hint else ''}; "
            f"expected a registered behaviour ({', '.join(leaves) or 'none'}) "
            f"or a built-in ({', '.join(builtins)}, SubTree)"
        )


def _compile(path: str | Path, factory: BehaviourFactory | None) -> TreeDescription:
    doc = read_document(path)
    compiler = _Compiler(doc, shipped_factory() if factory is None else factory)
    try:
        main = compiler.tree(doc.main_id, ())
        for tree_id in doc.trees:  # trees nothing uses are still the user's file: check them too
            if tree_id not in compiler.reached:
                compiler.tree(tree_id, ())
    except RecursionError:  # each file is at most MAX_DEPTH deep, but SubTrees expand into each other
        raise TreeError(
            f"{display_path(doc.path)}: the expanded tree (SubTrees in place) nests too deeply to load; "
            "expected fewer levels of SubTrees inside SubTrees"
        ) from None
    if compiler.problems:
        err = TreeError(compiler.problems[0])
        err.problems = list(compiler.problems)  # type: ignore[attr-defined]
        raise err
    return main


# ------------------------------------------------------------------------------------ public API
def describe_tree(path: str | Path, factory: BehaviourFactory | None = None) -> TreeDescription:
    """The main tree as checked data (nothing built): for drawing and for checks before a run."""
    return _compile(path, factory)


def validate_tree(path: str | Path, factory: BehaviourFactory | None = None) -> None:
    """Every check :func:`load_tree` makes, without building behaviours; raises TreeError."""
    _compile(path, factory)


def check_targets(path: str | Path, targets: Collection[str], factory: BehaviourFactory | None = None) -> None:
    """Every ``target`` port (written or defaulted) names one of `targets` (the config's perception.targets).

    A misspelt target is a valid string to the schema, and the node would wait forever for a track that
    cannot exist ("targte never seen"); this makes it a start-up error at the node's line instead."""
    known = set(targets)
    for node in describe_tree(path, factory).walk():
        value = node.effective_ports.get("target")
        if isinstance(value, str) and value not in known:
            how = "" if "target" in node.ports else " (the port's default)"
            raise TreeError(
                f"{node.file}:{node.line}: <{node.tag}>: target {value!r}{how} is not a perception target; "
                f"expected one of perception.targets: {_names(known)}"
            )


def load_tree(path: str | Path, factory: BehaviourFactory | None = None) -> Behaviour:
    """Validate the tree file (and its includes) completely, then build it; returns the root behaviour.

    Node types are looked up in `factory` and built as it was told: each registered behaviour with its
    registration arguments (for the running mission, ``shipped_factory(deps)`` with the perception
    dependencies).
    """
    return build(_compile(path, factory))


def build(desc: TreeDescription) -> Behaviour:
    """py_trees behaviours for a checked description (SubTrees flattened, roots named after their ID)."""
    if desc.kind == "SubTree":
        root = build(desc.children[0])
        root.name = desc.name
        return root
    children = [build(c) for c in desc.children]
    assert desc.manifest is not None, f"{desc.tag} was described without its node type"
    try:
        return desc.manifest.build(desc.name, children, dict(desc.effective_ports))
    except Exception as exc:  # a constructor refusing what it was given: report it where the node was written
        raise TreeError(f"{desc.file}:{desc.line}: <{desc.tag}>: {exc}") from exc
