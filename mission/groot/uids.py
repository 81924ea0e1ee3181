"""Node UIDs as BehaviorTree.CPP assigns them, the tree XML Groot2 is sent, and which py_trees node is which UID.

Groot2 names nodes by UID in every STATUS reply and log transition, and finds them in the tree XML by
their ``_uid`` attribute. BT.CPP numbers nodes while it builds the tree: depth first from the main
tree's root, starting at 1, a ``<SubTree>`` node getting its own UID before the nodes of the tree it
opens. A subtree used twice is two *instances*, each with its own UIDs and its own ``<BehaviorTree>``
element in the XML, told apart by ``_fullpath`` (``Follow::7``: the SubTree's ``name``, or its ID and
UID, under the path of the instance it sits in; the main tree's path is empty).

The XML is the file the loader read — each element with the tag and attributes as written — expanded
into those instances, with ``_uid`` (and ``_fullpath`` on ``<SubTree>`` and ``<BehaviorTree>``) added, and
a ``<TreeNodesModel>`` of the factory's behaviours so Groot2 shows their ports.

py_trees has no SubTree nodes: the loader builds a subtree's root in place of the ``<SubTree>`` and
names it after the subtree (trees/loader.py). So a ``<SubTree>`` UID and the UID of its subtree's root
are the same py_trees behaviour (or, should a loader build the SubTree as a scope node above the
subtree's root, that node); every other element is one behaviour, children in order.
:func:`bind` pairs them and checks names and child counts on the way.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

from py_trees.behaviour import Behaviour

from mission.trees.factory import BehaviourFactory
from mission.trees.loader import EXPLICIT_KIND_TAGS, read_document
from mission.trees.tree_nodes_model import nodes_model_xml
from mission.trees.xml_source import SourceElement

#: attributes the publisher writes itself (a file saved by Groot2 may carry stale ones)
_OWN_ATTRIBUTES = ("_uid", "_fullpath")


@dataclass
class UidNode:
    """One node of the expanded tree: its UID, the element it was written as, the instance it is in."""

    uid: int
    element: SourceElement
    instance: str  # _fullpath of the subtree instance this node belongs to ("" = the main tree)
    children: list[UidNode] = field(default_factory=list)
    opens: str | None = None  # for a <SubTree>: the _fullpath of the instance it opens

    @property
    def node_type(self) -> str:
        """The registered node type: the tag, or the ID of ``<Action ID="X">`` / ``<SubTree ID="X">``."""
        if self.element.tag in EXPLICIT_KIND_TAGS:
            return self.element.attrib.get("ID", "")
        return self.element.tag

    @property
    def is_subtree(self) -> bool:
        return self.opens is not None

    @property
    def name(self) -> str:
        """The instance name the loader gives the py_trees behaviour (``name``, else the type or subtree ID)."""
        if self.is_subtree:
            return self.element.attrib.get("name") or self.element.attrib.get("ID", "")
        return self.element.attrib.get("name") or self.node_type

    def walk(self) -> Iterator[UidNode]:
        yield self
        for child in self.children:
            yield from child.walk()


@dataclass
class Instance:
    """One use of a ``<BehaviorTree>``: the main tree, or one SubTree's copy of a tree."""

    tree_id: str
    path: str  # _fullpath: "" for the main tree
    root: UidNode

    @property
    def name(self) -> str:
        """How Groot2 asks for this instance's blackboard: the path, or the tree ID for the main tree."""
        return self.path or self.tree_id

    def nodes(self) -> Iterator[UidNode]:
        """This instance's own nodes (a SubTree node is its parent instance's; what it opens is not)."""
        stack = [self.root]
        while stack:
            node = stack.pop()
            yield node
            if not node.is_subtree:
                stack.extend(reversed(node.children))


@dataclass
class UidTree:
    """A tree file with BT.CPP's UIDs: the instances in the order BT.CPP creates them, every node by UID."""

    file: Path
    main_id: str
    instances: list[Instance]
    by_uid: dict[int, UidNode]

    @property
    def root(self) -> UidNode:
        return self.instances[0].root

    def status_order(self) -> list[int]:
        """UIDs in the order a STATUS reply lists them: instance by instance, each in UID order."""
        return [node.uid for inst in self.instances for node in sorted(inst.nodes(), key=lambda n: n.uid)]

    def xml(self, factory: BehaviourFactory | None = None) -> str:
        """The tree as Groot2 is sent it (FULLTREE, the head of a .btlog)."""
        root = ET.Element("root", {"BTCPP_format": "4"})
        for inst in self.instances:
            tree = ET.SubElement(root, "BehaviorTree", {"ID": inst.tree_id, "_fullpath": inst.path})
            _element_xml(inst.root, tree)
        if factory is not None:
            used = {node.node_type for inst in self.instances for node in inst.nodes()}
            root.append(ET.fromstring(nodes_model_xml(factory, descriptions=True, used=used)))
        ET.indent(root, space="  ")
        return ET.tostring(root, encoding="unicode")


def _element_xml(node: UidNode, parent: ET.Element) -> None:
    attrs = {k: v for k, v in node.element.attrib.items() if k not in _OWN_ATTRIBUTES}
    if node.is_subtree:
        attrs["_fullpath"] = node.opens or ""
    attrs["_uid"] = str(node.uid)
    el = ET.SubElement(parent, node.element.tag, attrs)
    if not node.is_subtree:
        for child in node.children:
            _element_xml(child, el)


def _is_subtree(el: SourceElement) -> bool:
    return el.tag == "SubTree"


def uid_tree(path: str | Path) -> UidTree:
    """The tree file (with its includes) numbered as BT.CPP numbers it. The file is assumed valid
    (the runner validated it); an unknown subtree ID raises KeyError."""
    doc = read_document(path)
    by_uid: dict[int, UidNode] = {}
    instances: list[Instance] = []
    counter = 0

    def expand(tree_id: str, path: str) -> UidNode:
        tree_el = doc.trees[tree_id]
        inst = Instance(tree_id, path, None)  # type: ignore[arg-type]  # root set below, after its UID
        instances.append(inst)
        inst.root = node(tree_el.children[0], path)
        return inst.root

    def node(el: SourceElement, instance: str) -> UidNode:
        nonlocal counter
        counter += 1
        me = UidNode(counter, el, instance)
        by_uid[me.uid] = me
        if _is_subtree(el):
            sub_id = el.attrib["ID"]
            own = el.attrib.get("name") or f"{sub_id}::{me.uid}"
            me.opens = f"{instance}/{own}" if instance else own
            me.children.append(expand(sub_id, me.opens))
        else:
            me.children.extend(node(child, instance) for child in el.children)
        return me

    expand(doc.main_id, "")
    return UidTree(doc.path, doc.main_id, instances, by_uid)


class BindError(ValueError):
    """The py_trees tree is not the one the file describes (a node's name or child count differs)."""


def bind(tree: UidTree, root: Behaviour) -> dict[int, Behaviour]:
    """UID → the py_trees behaviour that carries its status.

    A ``<SubTree>`` is either flattened (the subtree's root built in its place and named after it: the
    SubTree and its root share one behaviour) or built as a node of its own named after it, with the
    subtree's root as its only child (a loader that gives each instance its own scope may build it so).
    Checked on the way: every element's instance name and number of children match the behaviour's
    (the subtree roots and the main root are named after their tree, so only their children are checked).
    BindError names the element where the shapes part."""
    out: dict[int, Behaviour] = {}
    _pair(out, tree.root, root, named=False)
    return out


def _pair(out: dict[int, Behaviour], node: UidNode, behaviour: Behaviour, named: bool) -> None:
    out[node.uid] = behaviour
    if node.is_subtree:
        if behaviour.name != node.name:
            raise BindError(
                node.element.error(f"expected the subtree root {node.name!r}, the tree has {behaviour.name!r}")
            )
        inner = node.children[0]
        flat: dict[int, Behaviour] = {}
        try:
            _pair(flat, inner, behaviour, named=False)
        except BindError:
            if len(behaviour.children) != 1:
                raise
            scoped: dict[int, Behaviour] = {}
            try:
                _pair(scoped, inner, behaviour.children[0], named=False)
            except BindError:
                raise BindError(
                    node.element.error(f"{node.name!r} is neither the subtree's root nor a node above it")
                ) from None
            flat = scoped
        out.update(flat)
        return
    if named and behaviour.name != node.name:
        raise BindError(node.element.error(f"expected a node named {node.name!r}, the tree has {behaviour.name!r}"))
    if len(behaviour.children) != len(node.children):
        raise BindError(
            node.element.error(f"{len(node.children)} children in the file, {len(behaviour.children)} in the tree")
        )
    for child_node, child in zip(node.children, behaviour.children, strict=True):
        _pair(out, child_node, child, named=True)
