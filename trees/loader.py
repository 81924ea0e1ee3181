"""Build py_trees from BehaviorTree.CPP v4 XML — after validating the whole file set.

A tree file is data a user edits (by hand or in Groot2), so every mistake must stop start-up with
one line naming the file, the line, the element and what was expected, before anything is built or
ticked. The loader works in three steps:

1. **read** (:func:`read_document`): the file and its ``<include>``s as line-numbered elements
   (trees/xml_source.py); ``<root BTCPP_format="4">``, include paths relative to the including file,
   include cycles, duplicate tree IDs, the main tree, the ``<SubTree>`` models of ``<TreeNodesModel>``.
2. **compile** (:func:`describe_tree`): the main tree, every ``<SubTree>`` expanded in place, into a
   :class:`TreeDescription`: node types looked up in the factory (trees/factory.py: the BT.CPP built-ins
   and the registered behaviours), BT.CPP's load rules (a tree ID may not be a node's name), ports
   checked and converted from strings, ``{key}`` ports resolved to blackboard entries through the
   SubTree scopes (trees/scopes.py) with their types checked against each other, scripts parsed
   (errors at file:line:column), child counts, SubTree references and recursion. Problems are collected;
   the first one is raised as :class:`~mission.core.errors.TreeError` (``err.problems`` holds them all).
3. **build** (:func:`load_tree`): py_trees behaviours from the description, by the factory's builders,
   each given BT.CPP's tick (trees/execution.py). A ``<SubTree ID="X">`` is flattened: the subtree's root
   is built in place and named ``X`` (or the SubTree's ``name``), so viewers show which subtree is
   running; the SubTree's own BT.CPP state rides on that root.

Every function takes the factory to look node types up in; without one, :func:`shipped_factory` (the
shipped behaviours, no perception sources) — enough to describe, validate or draw a tree.
"""

from __future__ import annotations

import difflib
import re
from collections.abc import Collection, Iterator, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from py_trees.behaviour import Behaviour

from mission.behaviours.ports import (
    BlackboardRef,
    Port,
    PortsDeclared,
    is_pointer,
    missing_port,
    unknown_port,
    wrong_type,
)
from mission.core.errors import TreeError
from mission.trees import scopes
from mission.trees.builtins import BUILTIN_IDS
from mission.trees.execution import (
    POSTCONDITIONS,
    PRECONDITIONS,
    Conditions,
    Layer,
    NodeRuntime,
    TreeRuntime,
    install,
)
from mission.trees.factory import RESERVED_PORT_NAMES, BehaviourFactory, shipped_factory
from mission.trees.manifest import BuildContext, NodeKind, NodeManifest
from mission.trees.script import Script, ScriptSyntaxError, parse
from mission.trees.wiring import Wiring
from mission.trees.xml_source import SourceElement, display_path, parse_file

TREES_DIR = Path(__file__).resolve().parent
FORMAT = "4"

#: ``<Action ID="X"/>`` is the explicit spelling of ``<X/>`` (Groot2 can write either)
EXPLICIT_KIND_TAGS = ("Action", "Condition", "Control", "Decorator")
#: attributes BT.CPP/Groot2 may write that carry no behaviour here
IGNORED_ATTRIBUTES = frozenset({"_description", "_uid", "_fullpath"})
CONDITION_ATTRIBUTES = (*PRECONDITIONS, *POSTCONDITIONS)
#: characters BT.CPP forbids in a tree or node type name (basic_types.cpp findForbiddenChar)
_FORBIDDEN = re.compile(r"[ \t\n\r<>&\"'/\\:*?|.\x00-\x1f\x7f]")


# ---------------------------------------------------------------------------------------- paths
def shipped_trees() -> list[str]:
    """File names of the trees that ship with the package (trees/*.xml)."""
    return sorted(p.name for p in TREES_DIR.glob("*.xml"))


def example_trees() -> list[str]:
    """The example trees that ship with the package (trees/examples/*.xml), as ``examples/<name>``."""
    return sorted(f"examples/{p.name}" for p in (TREES_DIR / "examples").glob("*.xml"))


def resolve_tree_path(name_or_path: str | Path) -> Path:
    """A tree file: the path as given when it exists, else a shipped file (``follow`` or ``follow.xml``,
    ``examples/remap_follow``)."""
    given = Path(name_or_path)
    if given.is_file():
        return given
    for candidate in (TREES_DIR / str(name_or_path), TREES_DIR / f"{name_or_path}.xml"):
        if candidate.is_file():
            return candidate
    raise TreeError(
        f"{name_or_path}: tree file not found; expected a path to a BehaviorTree.CPP v4 XML file "
        f"or a shipped tree: {', '.join(shipped_trees() + example_trees())}"
    )


# ---------------------------------------------------------------------------------- description
@dataclass
class TreeDescription:
    """One node of a tree as written in the file, checked and with converted port values.

    The root returned by :func:`describe_tree` is the main tree itself (``tag="BehaviorTree"``,
    ``kind="SubTree"``); a ``<SubTree>`` has ``kind="SubTree"`` and the referenced tree's root as its
    only child. Viewers draw this without building behaviours. `uid` numbers the nodes as BT.CPP does
    (depth first, a SubTree before its tree's nodes, from 1; the BehaviorTree itself is 0).
    """

    tag: str  # node type: "FollowTarget", "Sequence", "SubTree", "BehaviorTree"
    name: str  # instance name (the `name` attribute, default: the tag; subtrees: the ID)
    kind: NodeKind
    file: str  # as shown in messages (relative to the working directory when inside it)
    line: int
    ports: dict[str, Any] = field(default_factory=dict)  # written in the file: converted, or BlackboardRef
    effective_ports: dict[str, Any] = field(default_factory=dict)  # with declared defaults
    children: list[TreeDescription] = field(default_factory=list)
    subtree: str | None = None  # the tree ID for SubTree / BehaviorTree nodes
    manifest: NodeManifest | None = field(default=None, repr=False, compare=False)  # None for SubTrees
    uid: int = 0
    conditions: dict[str, Script] = field(default_factory=dict, repr=False, compare=False)
    scope: scopes.Scope | None = field(default=None, repr=False, compare=False)
    wiring: Wiring | None = field(default=None, repr=False, compare=False)
    scripts: dict[str, Script] = field(default_factory=dict, repr=False, compare=False)
    entries: dict[str, Any] = field(default_factory=dict, repr=False, compare=False)  # SubTree constants by entry
    #: attributes starting with ``_`` that are no port or condition, kept for the application (BT.CPP's
    #: ``config().other_attributes``)
    other_attributes: dict[str, str] = field(default_factory=dict, repr=False, compare=False)

    def walk(self) -> Iterator[TreeDescription]:
        """This node and every node below it, depth first."""
        yield self
        for child in self.children:
            yield from child.walk()


# ------------------------------------------------------------------------------------- reading
@dataclass
class PortModel:
    """A port of a ``<SubTree ID>`` model in ``<TreeNodesModel>``: a default, or a port every use must remap."""

    direction: str
    default: str | None
    where: str


@dataclass
class TreeDocument:
    """A tree file with its includes: every ``<BehaviorTree>`` element by ID, and the main tree."""

    path: Path
    main_id: str
    trees: dict[str, SourceElement]
    files: list[Path]
    subtree_models: dict[str, dict[str, PortModel]] = field(default_factory=dict)


def read_document(path: str | Path, main_tree: str | None = None) -> TreeDocument:
    """Read a tree file and its includes; raise TreeError at the first file-level problem.

    `main_tree` picks the tree to run by ID (BT.CPP's ``createTree(name)``), over the file's
    ``main_tree_to_execute``."""
    top = resolve_tree_path(path)
    trees: dict[str, SourceElement] = {}
    files: list[Path] = []
    models: dict[str, dict[str, PortModel]] = {}
    top_root = _read_file(top.resolve(), [], trees, files, models)
    own = [el.name for el in top_root.children if el.tag == "BehaviorTree"]
    if main_tree is not None:
        if main_tree not in trees:
            raise TreeError(top_root.error(f"no tree named {main_tree!r} to run; trees defined: {_names(trees)}"))
        return TreeDocument(top, main_tree, trees, files, models)
    main = top_root.attrib.get("main_tree_to_execute")
    if main is not None:
        if main not in trees:
            raise TreeError(
                top_root.error(f'main_tree_to_execute="{main}" names no tree; trees defined: {_names(trees)}')
            )
        return TreeDocument(top, main, trees, files, models)
    candidates = own if own else list(trees)
    if len(candidates) != 1:
        raise TreeError(
            top_root.error(
                f"the file defines {len(candidates)} trees ({', '.join(candidates) or 'none'}); "
                'expected exactly one <BehaviorTree ID="..."> or main_tree_to_execute="ID"'
            )
        )
    return TreeDocument(top, candidates[0], trees, files, models)


def _read_file(
    path: Path,
    stack: list[Path],
    trees: dict[str, SourceElement],
    files: list[Path],
    models: dict[str, dict[str, PortModel]],
) -> SourceElement:
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
    seen_model = False
    for el in root.children:
        if el.tag == "include":
            _read_include(el, path, stack, trees, files, models)
        elif el.tag == "BehaviorTree":
            tree_id = el.attrib.get("ID")
            if not tree_id:
                if sum(child.tag == "BehaviorTree" for child in root.children) > 1:
                    raise TreeError(
                        el.error('missing ID; a file with several trees must name each: <BehaviorTree ID="Name">')
                    )
                # one unnamed tree in its file: BT.CPP names it BehaviorTree_<n>, n counting such trees
                tree_id = f"BehaviorTree_{sum(not t.attrib.get('ID') for t in trees.values())}"
                el.name = tree_id
            if tree_id in trees:
                raise TreeError(el.error(f"tree {tree_id} is already defined at {trees[tree_id].where}"))
            trees[tree_id] = el
        elif el.tag == "TreeNodesModel":
            if seen_model:
                raise TreeError(el.error("a second <TreeNodesModel>; BT.CPP reads one per file"))
            seen_model = True
            _read_models(el, models)
        else:
            raise TreeError(el.error("unexpected element; expected <BehaviorTree>, <include> or <TreeNodesModel>"))
    return root


def _read_models(section: SourceElement, models: dict[str, dict[str, PortModel]]) -> None:
    """The ``<SubTree ID>`` models (their ports' defaults are used when a SubTree does not remap them)."""
    for model in section.children:
        if model.tag != "SubTree":
            continue
        tree_id = model.attrib.get("ID")
        if not tree_id:
            raise TreeError(model.error("missing ID; a <SubTree> model names the tree it describes"))
        ports = models.setdefault(tree_id, {})
        for port_el in model.children:
            direction = port_el.tag.removesuffix("_port")
            if direction not in ("input", "output", "inout") or not port_el.tag.endswith("_port"):
                continue
            name = port_el.attrib.get("name")
            if not name:
                raise TreeError(port_el.error("missing name; expected <input_port name=...>"))
            problem = _port_name_problem(name)
            if problem:  # BT.CPP's validatePortName refuses the whole file
                raise TreeError(port_el.error(f"port name {name!r} {problem}; expected a name such as target_pose"))
            ports[name] = PortModel(direction, port_el.attrib.get("default"), port_el.where)


def _port_name_problem(name: str) -> str | None:
    """Why BT.CPP refuses `name` as a port's name (validatePortName), or None."""
    if name[0].isdigit():
        return "starts with a digit"
    bad = _FORBIDDEN.search(name)
    if bad:
        return f"contains the forbidden character {bad.group()!r}"
    if name in RESERVED_PORT_NAMES:
        return "is a reserved attribute name"
    return None


def _read_include(
    el: SourceElement,
    including: Path,
    stack: list[Path],
    trees: dict[str, SourceElement],
    files: list[Path],
    models: dict[str, dict[str, PortModel]],
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
        raise TreeError(
            el.error(
                f"included file not found: {display_path(target)} "
                f"(paths are relative to this file, or name a shipped tree: {', '.join(shipped_trees())})"
            )
        )
    _read_file(target, chain, trees, files, models)


def _a(word: str) -> str:
    return f"{'an' if word[0] in 'AEIOU' else 'a'} {word}"


def _names(items: Any) -> str:
    return ", ".join(sorted(items)) or "none"


# ----------------------------------------------------------------------------------- compiling
def convert_port(text: str, port: Port) -> Any:
    """A port's XML string as the declared Python type; ValueError says what was expected."""
    return port.parse(text)


def subtree_constant(text: str) -> Any:
    """A SubTree attribute's constant as BT.CPP stores it in the SubTree's blackboard: an int when it is one,
    else a float when it is one, else the text."""
    if not text or text != text.strip() or "_" in text:
        return text
    if not any(c in text for c in ".eE"):
        try:
            return int(text, 10)
        except ValueError:
            pass
    if not re.fullmatch(r"[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?", text):
        return text
    return float(text)


def _pointer_key(name: str, text: str) -> str | None:
    """The entry a port's text names (``{key}``, ``{=}`` / ``=``: the port's own name), or None for a constant."""
    if text in ("{=}", "="):
        return name
    if is_pointer(text):
        return text.strip(" ")[1:-1]
    return None


class _Compiler:
    """Checks every tree (each SubTree use expanded in place), collecting problems deduplicated, in order."""

    def __init__(self, doc: TreeDocument, factory: BehaviourFactory) -> None:
        self.doc = doc
        self.factory = factory
        self.enums = factory.enums
        self.problems: list[str] = []
        self.unknown: dict[str, str] = {}  # node type nothing registers → where it is first used
        self.reached: set[str] = set()
        self.uid = 0
        self.declared: set[str] = set()  # entries BT.CPP creates when the tree is built
        self.types: dict[str, tuple[type, str]] = {}  # entry → the type its first typed port gave it, and where
        self.instances: dict[str, str] = {}  # SubTree instance path → where that SubTree was written

    def problem(self, message: str) -> None:
        if message not in self.problems:
            self.problems.append(message)

    def next_uid(self) -> int:
        self.uid += 1
        return self.uid

    # -- trees ---------------------------------------------------------------------------------
    def check_names(self) -> None:
        """BT.CPP's rule (4.6.2+): a tree ID is not the name of a registered node; names are valid model names."""
        for tree_id, el in self.doc.trees.items():
            clash = self._clash(tree_id)
            if clash:
                self.problem(el.error(clash))
            bad = _FORBIDDEN.search(tree_id)
            if bad or tree_id in ("Root", "root"):
                what = f"contains {bad.group(0)!r}" if bad else "is reserved"
                self.problem(el.error(f"tree ID {tree_id!r} {what}; BT.CPP refuses it: rename the tree"))

    def _clash(self, tree_id: str) -> str | None:
        manifest = self.factory.manifest(tree_id)
        if manifest is None and tree_id not in BUILTIN_IDS:
            return None
        kind = "a BT.CPP built-in" if tree_id in BUILTIN_IDS else f"the registered {manifest.kind.lower()}"  # type: ignore[union-attr]
        return (
            f"tree ID {tree_id!r} is also {kind} {tree_id}, which BT.CPP 4.6.2+ refuses "
            f'("must not use the name of a registered Node"); rename the tree, e.g. {tree_id}Tree, '
            f'and its <SubTree ID="{tree_id}"> references'
        )

    def tree(self, tree_id: str, scope: scopes.Scope, stack: tuple[str, ...]) -> TreeDescription:
        """The ``<BehaviorTree ID>`` element as a SubTree-kind node whose child is the tree's root."""
        el = self.doc.trees[tree_id]
        self.reached.add(tree_id)
        desc = TreeDescription("BehaviorTree", tree_id, "SubTree", display_path(el.file), el.line, subtree=tree_id)
        desc.scope = scope
        for attr in el.attrib:
            if attr != "ID" and not attr.startswith("_"):
                self.problem(el.error(f"unknown attribute {attr!r}; expected only ID"))
        if len(el.children) != 1:
            self.problem(el.error(f"has {len(el.children)} root nodes; expected exactly one"))
        for child in el.children:
            node = self.node(child, scope, (*stack, tree_id))
            if node is not None:
                desc.children.append(node)
        return desc

    # -- conditions and scripts ------------------------------------------------------------------
    def script(self, el: SourceElement, attr: str, text: str) -> Script | None:
        try:
            return parse(text)
        except ScriptSyntaxError as err:
            index = len("\n".join(text.split("\n")[: err.line - 1])) + (1 if err.line > 1 else 0) + err.column - 1
            self.problem(el.error_at(attr, index, f"{attr}: {err.message} (in script {text!r})"))
            return None

    def conditions(self, el: SourceElement, attrs: dict[str, str]) -> dict[str, Script]:
        found: dict[str, Script] = {}
        for attr in CONDITION_ATTRIBUTES:
            if attr in attrs:
                parsed = self.script(el, attr, attrs.pop(attr))
                if parsed is not None:
                    found[attr] = parsed
        return found

    # -- ports -------------------------------------------------------------------------------------
    def entry(self, el: SourceElement, scope: scopes.Scope, attr: str, key: str) -> BlackboardRef | None:
        problem = scopes.key_problem(key)
        if problem:
            self.problem(el.error(f'port {attr}="{{{key}}}": {problem}; expected a blackboard key such as {{goal}}'))
            return None
        path = scope.entry_path(key)
        self.declared.add(path)
        return BlackboardRef(key, path)

    def use_type(self, el: SourceElement, attr: str, ref: BlackboardRef, kind: type, node_type: str) -> None:
        """BT.CPP's rule: once an entry is typed by a port, every other port on it has the same type (an entry
        first used as a string converts to anything)."""
        where = f"port {attr} of <{node_type}> at {el.where}"
        first = self.types.get(ref.path)
        if first is None:
            known = scopes.mission_key_type(ref.path)
            if known is not None:
                first = (known, f"the mission key {ref.path}")
            else:
                self.types[ref.path] = (kind, where)
                return
        if first[0] is not str and first[0] is not kind:
            self.problem(
                el.error(
                    f"port {attr}: blackboard entry {ref} is {_type_name(kind)} here but {_type_name(first[0])} "
                    f"for {first[1]}; BT.CPP refuses an entry whose type changes"
                )
            )

    def other_attribute(self, el: SourceElement, attr: str, text: str, other: dict[str, str]) -> None:
        """An attribute starting with ``_`` that is no port or condition: BT.CPP keeps it for the application
        (``other_attributes``), and so do we; one that looks like a misspelt condition is still refused."""
        known = [*CONDITION_ATTRIBUTES, "_autoremap"]
        hint = next((k for k in known if k.lower() == attr.lower()), None) or next(
            iter(difflib.get_close_matches(attr, known, n=1, cutoff=0.85)), None
        )
        if hint is not None:
            self.problem(
                el.error(
                    f"unknown attribute {attr!r} (did you mean {hint}?); "
                    f"BT.CPP's are {', '.join(CONDITION_ATTRIBUTES)}; "
                    "other attributes starting with '_' are kept for the application, not run"
                )
            )
            return
        other[attr] = text

    def ports(
        self,
        el: SourceElement,
        node_type: str,
        attrs: dict[str, str],
        manifest: NodeManifest,
        scope: scopes.Scope,
        other: dict[str, str],
    ) -> tuple[dict[str, Any], Wiring]:
        declared = manifest.ports
        values: dict[str, Any] = {}
        wiring = Wiring(declared)
        for attr, text in attrs.items():
            if attr in IGNORED_ATTRIBUTES:
                continue
            if attr.startswith("_"):
                self.other_attribute(el, attr, text, other)
                continue
            if attr not in declared:
                self.problem(el.error(unknown_port(attr, node_type, declared)))
                continue
            port = declared[attr]
            wiring.written[attr] = text
            key = _pointer_key(attr, text)
            if key is None:
                if not port.reads:
                    self.problem(
                        el.error(
                            f'port {attr}="{text}" is an output: it takes a blackboard entry to write, such as '
                            f'{attr}="{{{attr}}}"'
                        )
                    )
                    continue
                if attr in manifest.scripts:
                    script = self.script(el, attr, text)
                    if script is not None:
                        values[attr] = text
                        wiring.constants[attr] = text
                    continue
                try:
                    if port.type is int and text.strip() in self.enums:  # an enum port: BT.CPP takes the name too
                        value = self.enums[text.strip()]
                    else:
                        value = text if attr in manifest.untyped else port.parse(text)
                except ValueError as exc:
                    self.problem(el.error(wrong_type(attr, str(exc), text)))
                    continue
                values[attr] = value
                wiring.constants[attr] = value
                continue
            ref = self.entry(el, scope, attr, key)
            if ref is None:
                continue
            values[attr] = ref
            if port.reads:
                wiring.inputs[attr] = ref
            if port.writes:
                wiring.outputs[attr] = ref
            if attr not in manifest.untyped:
                self.use_type(el, attr, ref, port.type, node_type)
        for name, port in declared.items():
            if name in wiring.written:
                continue
            if port.reads and not port.required:
                key = (
                    _pointer_key(name, port.default) if isinstance(port.default, str) and "{" in port.default else None
                )
                ref = self.entry(el, scope, name, key) if key else None
                if ref is not None:  # BT.CPP: a default written "{key}" is that entry, read before every tick
                    wiring.inputs[name] = ref
                else:
                    wiring.constants[name] = port.default
            elif port.direction == "output" and not port.required and isinstance(port.default, str):
                key = _pointer_key(name, port.default)
                ref = self.entry(el, scope, name, key) if key else None
                if ref is not None:
                    wiring.outputs[name] = ref
        return values, wiring

    # -- nodes -----------------------------------------------------------------------------------
    def node(self, el: SourceElement, scope: scopes.Scope, stack: tuple[str, ...]) -> TreeDescription | None:
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
            return self.subtree(el, attrs, scope, stack)

        manifest = self.factory.manifest(node_type)
        if manifest is None:
            self.unknown.setdefault(node_type, f"line {el.line}")
            self.problem(el.error(self._unknown_node(node_type)))
            for child in el.children:
                self.node(child, scope, stack)
            return None
        kind, declared = manifest.kind, manifest.ports
        if explicit_kind is not None and explicit_kind != kind:
            self.problem(el.error(f"{node_type} is {_a(kind)}, not {_a(explicit_kind)}; write <{kind} ID=...>"))

        uid = self.next_uid()
        name = attrs.pop("name", node_type)
        conditions = self.conditions(el, attrs)
        other: dict[str, str] = {}
        written, wiring = self.ports(el, node_type, attrs, manifest, scope, other)
        effective = {k: p.default for k, p in declared.items() if p.reads and not p.required}
        effective.update({k: ref for k, ref in wiring.inputs.items() if k not in written})  # "{key}" defaults
        effective.update(written)
        missing = [k for k, p in declared.items() if p.required and k not in written and k not in wiring.written]
        for port_name in missing:
            self.problem(el.error(missing_port(port_name, declared[port_name])))
        scripts = {
            attr: parsed
            for attr in manifest.scripts
            if isinstance(written.get(attr), str) and (parsed := _parse_quietly(written[attr])) is not None
        }

        children = [c for c in (self.node(child, scope, stack) for child in el.children) if c is not None]
        self.child_count(el, node_type, manifest, len(el.children))
        connected = any(isinstance(v, BlackboardRef) for v in effective.values())
        reading = {k for k, p in declared.items() if p.reads}
        if manifest.check and not missing and not connected and reading <= set(effective):
            message = manifest.check({k: v for k, v in effective.items() if k in reading}, len(el.children))
            if message:
                self.problem(el.error(message))
        return TreeDescription(
            node_type,
            name,
            kind,
            display_path(el.file),
            el.line,
            written,
            effective,
            children,
            manifest=manifest,
            uid=uid,
            conditions=conditions,
            scope=scope,
            wiring=wiring,
            scripts=scripts,
            other_attributes=other,
        )

    def child_count(self, el: SourceElement, node_type: str, manifest: NodeManifest, n: int) -> None:
        kind = manifest.kind
        if manifest.children is not None:
            low, high = manifest.children
            if n < low or (high is not None and n > high):
                expected = f"exactly {low}" if low == high else f"{low} to {high}" if high else f"at least {low}"
                self.problem(el.error(f"{node_type} has {n} child{'ren' if n != 1 else ''}; expected {expected}"))
        elif kind == "Decorator" and n != 1:
            self.problem(el.error(f"decorator has {n} children; expected exactly 1"))
        elif kind == "Control" and n == 0:
            self.problem(el.error("control node has no children; expected at least 1"))
        elif kind in ("Action", "Condition") and n:
            self.problem(el.error(f"{kind.lower()} node has {n} child{'ren' if n > 1 else ''}; expected none"))
        if node_type == "ReactiveSequence":  # BT.CPP's VerifyXML counts the <AsyncSequence> children
            asynchronous = [child for child in el.children if child.tag == "AsyncSequence"]
            if len(asynchronous) > 1:
                self.problem(
                    el.error(
                        f"ReactiveSequence has {len(asynchronous)} asynchronous children (<AsyncSequence> at lines "
                        f"{', '.join(str(c.line) for c in asynchronous)}); expected at most 1, as BT.CPP: it would "
                        "restart one while the other runs"
                    )
                )

    def subtree(
        self, el: SourceElement, attrs: dict[str, str], scope: scopes.Scope, stack: tuple[str, ...]
    ) -> TreeDescription | None:
        tree_id = attrs.pop("ID", "")
        if el.children:
            self.problem(el.error(f"SubTree has {len(el.children)} children; expected none (it refers to a tree)"))
        if not tree_id:
            self.problem(el.error('missing ID; expected <SubTree ID="TreeName"/>'))
            return None
        clash = self._clash(tree_id)
        if clash:
            self.problem(el.error(clash))
        uid = self.next_uid()
        name = attrs.pop("name", tree_id)
        conditions = self.conditions(el, attrs)
        autoremap = False
        other: dict[str, str] = {}
        remap: dict[str, str] = {}
        constants: dict[str, str] = {}
        shown: dict[str, Any] = {}
        for attr, text in attrs.items():
            if attr in IGNORED_ATTRIBUTES:
                continue
            if attr == "_autoremap":
                try:
                    autoremap = Port(bool).parse(text)
                except ValueError:
                    self.problem(el.error(f'_autoremap="{text}": expected true or false'))
                continue
            if attr.startswith("_"):
                self.other_attribute(el, attr, text, other)
                continue
            key = attr if text == "{=}" else text.strip(" ")[1:-1] if is_pointer(text) else None
            if key is not None:
                problem = scopes.key_problem(key)
                if problem:
                    self.problem(el.error(f'port {attr}="{text}": {problem}'))
                    continue
                remap[attr] = key
                shown[attr] = BlackboardRef(key, scope.entry_path(key))
                self.declared.add(scope.entry_path(key))
            else:
                constants[attr] = text
                shown[attr] = text
        for port_name, model in self.doc.subtree_models.get(tree_id, {}).items():
            if port_name in remap or port_name in constants or autoremap:
                continue
            if model.default is None:
                self.problem(
                    el.error(
                        f'the <SubTree ID="{tree_id}"> model ({model.where}) has a mandatory port {port_name}, '
                        f'which this SubTree does not remap; add {port_name}="{{key}}" or a value'
                    )
                )
                continue
            key = _pointer_key(port_name, model.default)
            if key is not None:
                remap[port_name] = key
            else:
                constants[port_name] = model.default
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
        instance = name if "name" in el.attrib else f"{tree_id}::{uid}"
        child_scope = scope.child(instance, remap, constants, autoremap)
        if child_scope.path in self.instances:  # Groot2 and the blackboards tell instances apart by path
            self.problem(
                el.error(
                    f"duplicate SubTree path {child_scope.path!r} (also {self.instances[child_scope.path]}); "
                    "BT.CPP refuses two SubTrees with the same name under one parent: give each a unique name, "
                    "or leave name out to number them"
                )
            )
        self.instances[child_scope.path] = f"at {el.where}"
        entries: dict[str, Any] = {}
        for attr, text in constants.items():
            path = child_scope.entry_path(attr)
            value = subtree_constant(text)
            entries[path] = value
            self.declared.add(path)
            if not isinstance(value, str):
                self.types.setdefault(path, (type(value), f'the constant {attr}="{text}" of <SubTree> at {el.where}'))
        inner = self.tree(tree_id, child_scope, stack)
        return TreeDescription(
            "SubTree",
            name,
            "SubTree",
            display_path(el.file),
            el.line,
            ports=shown,
            subtree=tree_id,
            children=inner.children,
            uid=uid,
            conditions=conditions,
            scope=scope,
            entries=entries,
            other_attributes=other,
        )

    def _unknown_node(self, node_type: str) -> str:
        builtins = [m.tag for m in self.factory.builtins()]
        leaves = [m.tag for m in self.factory.behaviours()]
        hint = difflib.get_close_matches(node_type, [*leaves, *builtins, "SubTree"], n=1)
        return (
            f"unknown node {node_type!r}{f' (did you mean {hint[0]}?)' if hint else ''}; "
            f"expected a registered behaviour ({', '.join(leaves) or 'none'}) "
            f"or a built-in ({', '.join(builtins)}, SubTree)"
        )


def _type_name(kind: type) -> str:
    return getattr(kind, "__name__", str(kind))


def _parse_quietly(text: str) -> Script | None:
    try:
        return parse(text)
    except ScriptSyntaxError:
        return None


def _compile(
    path: str | Path, factory: BehaviourFactory | None, main_tree: str | None = None
) -> tuple[TreeDescription, _Compiler]:
    doc = read_document(path, main_tree)
    compiler = _Compiler(doc, shipped_factory() if factory is None else factory)
    compiler.check_names()
    try:
        main = compiler.tree(doc.main_id, scopes.Scope(), ())
        declared, types = set(compiler.declared), dict(compiler.types)
        for tree_id in doc.trees:  # trees nothing uses are still the user's file: check them too
            if tree_id not in compiler.reached:
                compiler.types, compiler.instances = {}, {}
                compiler.tree(tree_id, scopes.Scope(), ())
        compiler.declared, compiler.types = declared, types
    except RecursionError:  # each file is at most MAX_DEPTH deep, but SubTrees expand into each other
        raise TreeError(
            f"{display_path(doc.path)}: the expanded tree (SubTrees in place) nests too deeply to load; "
            "expected fewer levels of SubTrees inside SubTrees"
        ) from None
    if len(compiler.unknown) > 1:  # another team's tree: name every node type at once, and how to draw it
        listed = ", ".join(f"{tag} ({where})" for tag, where in compiler.unknown.items())
        compiler.problems.insert(
            0,
            f"{display_path(doc.path)}: {len(compiler.unknown)} unknown node types: {listed}; expected registered "
            "behaviours or BT.CPP built-ins (`mission nodes-model` lists them). `mission viz` draws such a tree "
            "(with --nodes-model FILE for their TreeNodesModel) but cannot run it",
        )
    if compiler.problems:
        err = TreeError(compiler.problems[0])
        err.problems = list(compiler.problems)  # type: ignore[attr-defined]
        raise err
    return main, compiler


# ------------------------------------------------------------------------------------ public API
def describe_tree(path: str | Path, factory: BehaviourFactory | None = None) -> TreeDescription:
    """The main tree as checked data (nothing built): for drawing and for checks before a run."""
    return _compile(path, factory)[0]


def validate_tree(path: str | Path, factory: BehaviourFactory | None = None) -> None:
    """Every check :func:`load_tree` makes, without building behaviours; raises TreeError."""
    _compile(path, factory)


def check_targets(path: str | Path, targets: Collection[str], factory: BehaviourFactory | None = None) -> None:
    """Every ``target`` port (written or defaulted) names one of `targets` (the config's perception.targets).

    A misspelt target is a valid string to the schema, and the node would wait forever for a track that
    cannot exist ("targte never seen"); this makes it a start-up error at the node's line instead. A target
    read from the blackboard (``target="{tgt}"``) is checked where it is a SubTree's constant."""
    known = set(targets)
    main = describe_tree(path, factory)
    constants: dict[str, Any] = {}
    for node in main.walk():
        constants.update(node.entries)
    for node in main.walk():
        value = node.effective_ports.get("target")
        how = "" if "target" in node.ports else " (the port's default)"
        if isinstance(value, BlackboardRef) and isinstance(constants.get(value.path), str):
            value, how = constants[value.path], f" (from {value})"
        if isinstance(value, str) and value not in known:
            raise TreeError(
                f"{node.file}:{node.line}: <{node.tag}>: target {value!r}{how} is not a perception target; "
                f"expected one of perception.targets: {_names(known)}"
            )


def load_tree(
    path: str | Path,
    factory: BehaviourFactory | None = None,
    runtime: TreeRuntime | None = None,
    main_tree: str | None = None,
    blackboard: Mapping[str, Any] | None = None,
) -> Behaviour:
    """Validate the tree file (and its includes) completely, then build it; returns the root behaviour.

    Node types are looked up in `factory` and built as it was told: each registered behaviour with its
    registration arguments (for the running mission, ``shipped_factory(deps)`` with the perception
    dependencies). The tree's blackboards start empty (``/tree/…`` entries of an earlier tree are removed);
    the root's ``tick`` is BT.CPP's ``tickOnce``. `runtime` lets a test observe every node's executeTick;
    `main_tree` names the tree to run when it is not the file's main tree (BT.CPP's ``createTree(name)``);
    `blackboard` holds entries of the root blackboard by their tree-file names, written before the tree is
    built (BT.CPP's ``createTree(name, blackboard)`` with a blackboard the caller filled).
    """
    main, compiler = _compile(path, factory, main_tree)
    tree = runtime if runtime is not None else TreeRuntime()
    builder = _Builder(tree, compiler)
    scopes.clear_tree_entries()
    root_scope = scopes.Scope()
    for key, value in (blackboard or {}).items():
        scopes.write(root_scope.entry_path(key), value)
    root = builder.build(main)
    install(root, root.bt, root=True)  # type: ignore[attr-defined]
    return root


def build(desc: TreeDescription) -> Behaviour:
    """py_trees behaviours for a checked description (SubTrees flattened, roots named after their ID)."""
    root = _Builder(TreeRuntime(), None).build(desc)
    install(root, root.bt, root=True)  # type: ignore[attr-defined]
    return root


class _Builder:
    def __init__(self, tree: TreeRuntime, compiler: _Compiler | None) -> None:
        self.tree = tree
        self.enums: Mapping[str, int] = compiler.enums if compiler is not None else {}
        self.declared: set[str] = compiler.declared if compiler is not None else set()

    def env(self, scope: scopes.Scope | None) -> scopes.ScriptEnv:
        return scopes.ScriptEnv(scope if scope is not None else scopes.Scope(), self.enums, self.declared)

    def conditions(self, desc: TreeDescription) -> Conditions:
        pre = tuple((name, desc.conditions[name]) for name in PRECONDITIONS if name in desc.conditions)
        post = {name: desc.conditions[name] for name in POSTCONDITIONS if name in desc.conditions}
        return Conditions(pre, post, self.env(desc.scope))

    def build(self, desc: TreeDescription) -> Behaviour:
        if desc.kind == "SubTree":
            for path, value in desc.entries.items():
                scopes.write(path, value)
            root = self.build(desc.children[0])
            root.name = desc.name
            if desc.tag == "SubTree":  # the <SubTree> node itself rides on its tree's root
                root.bt.layers.insert(
                    0, Layer(desc.uid, desc.name, self.conditions(desc), other_attributes=desc.other_attributes)
                )  # type: ignore[attr-defined]
            return root
        children = [self.build(c) for c in desc.children]
        assert desc.manifest is not None, f"{desc.tag} was described without its node type"
        wiring = desc.wiring if desc.wiring is not None else Wiring(desc.manifest.ports)
        scope = desc.scope if desc.scope is not None else scopes.Scope()
        context = BuildContext(desc.scripts, scope.entry_path, self.enums)
        values = {k: v for k, v in desc.effective_ports.items() if desc.manifest.ports.get(k, Port(str)).reads}
        try:
            node = desc.manifest.build(desc.name, children, values, context)
        except Exception as exc:  # a constructor refusing what it was given: report it where the node was written
            raise TreeError(f"{desc.file}:{desc.line}: <{desc.tag}>: {exc}") from exc
        rt = NodeRuntime(
            self.tree,
            [Layer(desc.uid, desc.name, self.conditions(desc), other_attributes=desc.other_attributes)],
            ports=wiring,
        )
        if isinstance(node, PortsDeclared):
            if wiring.inputs:
                rt.refresh = wiring.refresh_params
            node.port_sink = wiring.write
            node.connected_outputs = frozenset(wiring.outputs)
        install(node, rt)
        return node
