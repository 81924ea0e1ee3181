"""The one data shape every tree drawing starts from: a node with its kind, ports, status and feedback.

Three sources feed it — a live tree's snapshot dict (:func:`mission.core.snapshot.snapshot`), a tree file's
static description (``mission.trees.loader.describe_tree``) and a recorded tick of a JSON-lines log — so the
text, DOT, SVG, PNG and HTML renderers never care where a tree came from. Nodes are numbered in
pre-order (``id``); that number is how a tick log and the live page refer to a node.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from typing import Any

STATUSES = ("INVALID", "RUNNING", "SUCCESS", "FAILURE")
KINDS = ("Action", "Condition", "Control", "Decorator", "SubTree")

# BehaviorTree.CPP tags (and py_trees classes) that are control flow, for descriptions without a kind.
_CONTROL_TAGS = {
    "Sequence",
    "ReactiveSequence",
    "SequenceWithMemory",
    "Fallback",
    "ReactiveFallback",
    "Selector",
    "Parallel",
    "ParallelAll",
    "IfThenElse",
    "WhileDoElse",
    "Switch",
}
_DECORATOR_TAGS = {
    "Inverter",
    "ForceSuccess",
    "ForceFailure",
    "RetryUntilSuccessful",
    "Repeat",
    "Timeout",
    "KeepRunningUntilFailure",
    "Delay",
    "RunOnce",
    "SuccessIsFailure",
    "FailureIsSuccess",
    "Retry",
    "OneShot",
    "EternalGuard",
}


@dataclass
class VizNode:
    """One node of a tree as a viewer sees it."""

    id: int
    name: str
    type: str  # the XML tag or py_trees class name
    kind: str  # Action | Condition | Control | Decorator | SubTree
    status: str = "INVALID"
    feedback: str = ""
    ports: dict[str, str] = field(default_factory=dict)
    children: list[VizNode] = field(default_factory=list)
    duration_us: float | None = None  # this node's own tick time, when recorded
    line: int | None = None  # line in the tree file, for static descriptions
    subtree: str | None = None  # the subtree ID this node is the root of (or refers to)
    defaults: dict[str, str] = field(default_factory=dict)  # ports left at their declared default

    def walk(self) -> Iterator[VizNode]:
        """Pre-order: the order of ``id``."""
        yield self
        for c in self.children:
            yield from c.walk()

    @property
    def label_type(self) -> str:
        """The type line under the name, empty when the name already says it."""
        text = "" if self.type == self.name else self.type
        if self.subtree and self.kind != "SubTree":
            text = f"{text} · subtree {self.subtree}" if text else f"subtree {self.subtree}"
        return text


def to_dict(node: VizNode) -> dict[str, Any]:
    """The static part of a tree (no statuses) as JSON-ready nested dicts — a tick log's header."""
    d: dict[str, Any] = {"name": node.name, "type": node.type, "kind": node.kind}
    for key in ("ports", "defaults"):
        if getattr(node, key):
            d[key] = dict(getattr(node, key))
    if node.subtree:
        d["subtree"] = node.subtree
    if node.line:
        d["line"] = node.line
    d["children"] = [to_dict(c) for c in node.children]
    return d


def _renumber(root: VizNode) -> VizNode:
    for i, n in enumerate(root.walk()):
        n.id = i
    return root


def from_snapshot(snap: dict[str, Any]) -> VizNode:
    """A tree from :func:`mission.core.snapshot.snapshot` (a live tree, the ROS topic, a log header)."""

    def build(d: dict[str, Any]) -> VizNode:
        return VizNode(
            id=0,
            name=str(d.get("name", "?")),
            type=str(d.get("type", "")),
            kind=str(d.get("kind", "Action")),
            status=str(d.get("status", "INVALID")),
            feedback=str(d.get("feedback", "") or ""),
            ports={str(k): str(v) for k, v in (d.get("ports") or {}).items()},
            children=[build(c) for c in d.get("children", [])],
            duration_us=d.get("duration_us"),
            line=d.get("line"),
            subtree=d.get("subtree"),
            defaults={str(k): str(v) for k, v in (d.get("defaults") or {}).items()},
        )

    return _renumber(build(snap))


def _kind_of(tag: str, given: str | None, has_children: bool) -> str:
    if given:
        k = str(given)
        for known in KINDS:
            if k.lower() == known.lower():
                return known
        return k
    if tag == "SubTree":
        return "SubTree"
    if tag in _CONTROL_TAGS:
        return "Control"
    if tag in _DECORATOR_TAGS:
        return "Decorator"
    if tag.startswith("Is") or tag.endswith("Condition"):
        return "Condition"
    return "Control" if has_children else "Action"


def from_description(desc: Any) -> VizNode:
    """A tree from a static description (``mission.trees.loader.describe_tree``): tag, name, kind, ports,
    children, line.

    Duck-typed on attributes (or dict keys) so the loader's dataclass can evolve without breaking drawings.
    """

    def attr(o: Any, name: str, default: Any = None) -> Any:
        if isinstance(o, dict):
            return o.get(name, default)
        return getattr(o, name, default)

    def build(d: Any) -> VizNode:
        tag = str(attr(d, "tag", "") or attr(d, "type", "") or "?")
        children = list(attr(d, "children", []) or [])
        name = str(attr(d, "name", "") or tag)
        ports = dict(attr(d, "ports", {}) or {})
        effective = dict(attr(d, "effective_ports", {}) or {})
        manifest = attr(d, "manifest")
        modelled = manifest is not None and not getattr(manifest, "runnable", True)
        return VizNode(
            id=0,
            name=name,
            type=tag,
            kind=_kind_of(tag, attr(d, "kind"), bool(children)),
            ports={str(k): _port_str(v) for k, v in ports.items()},
            children=[build(c) for c in children],
            line=attr(d, "line"),
            subtree=attr(d, "subtree"),
            defaults={str(k): _port_str(v) for k, v in effective.items() if k not in ports},
            feedback=str(manifest.doc) if modelled else "",
        )

    root = attr(desc, "root", None)
    return _renumber(build(root if root is not None else desc))


def _port_str(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    return str(value)


def flatten_subtrees(root: VizNode) -> VizNode:
    """The description as the loader builds it: each SubTree replaced by its root, renamed after the subtree.

    A live tree (py_trees) has no SubTree nodes, so this is the static shape that matches it node for node.
    """

    def flat(n: VizNode) -> VizNode:
        if n.kind == "SubTree" and len(n.children) == 1:
            inner = flat(n.children[0])
            inner.name = n.name
            inner.subtree = n.subtree or n.name
            return inner
        n.children = [flat(c) for c in n.children]
        return n

    flat_root = flat(root)
    flat_root.subtree = None  # the main tree is the whole picture, not a subtree of it
    return _renumber(flat_root)


def merge_static(live: VizNode, static: VizNode) -> bool:
    """Copy tags, ports and subtree names from a (flattened) description onto a live tree of the same shape.

    Returns False and changes nothing when the shapes differ (a tree built some other way).
    """
    pairs = list(zip(live.walk(), static.walk(), strict=False))
    if count(live) != count(static) or any(a.name != b.name or len(a.children) != len(b.children) for a, b in pairs):
        return False
    for a, b in pairs:
        a.type, a.kind, a.ports, a.defaults, a.line = b.type, b.kind, dict(b.ports), dict(b.defaults), b.line
        a.subtree = b.subtree
    return True


def apply_tick(root: VizNode, nodes: Sequence[Sequence[Any]]) -> VizNode:
    """Set statuses from a recorded tick's ``nodes`` rows ``[status, feedback, duration_us]`` in pre-order."""
    for n, row in zip(root.walk(), nodes, strict=False):
        n.status = str(row[0]) if len(row) > 0 else "INVALID"
        n.feedback = str(row[1]) if len(row) > 1 and row[1] is not None else ""
        n.duration_us = row[2] if len(row) > 2 else None
    return root


def count(root: VizNode) -> int:
    return sum(1 for _ in root.walk())
