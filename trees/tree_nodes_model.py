"""Groot2's ``<TreeNodesModel>``: the leaves a tree may use, with their ports, types and defaults.

Groot2 shows a node's ports (and offers them in its palette) only when the file describes the node
type. The shipped tree files carry this section, generated from the behaviours registered in a factory
(each one's ports as its ``Params`` declare them); a test regenerates it and compares, and
``python -m mission.trees.tree_nodes_model`` rewrites the shipped files after a behaviour's ports change
(``--check`` only reports).
"""

from __future__ import annotations

import argparse
import re
import sys
from collections.abc import Collection
from pathlib import Path
from xml.sax.saxutils import escape, quoteattr

from mission.behaviours.ports import Port
from mission.core.files import atomic_write_text
from mission.core.types import Pose2D
from mission.trees.factory import BehaviourFactory, shipped_factory

#: Python port types in BehaviorTree.CPP's spelling (what Groot2 shows); a C++ host would declare Pose2D as a
#: struct of three doubles read from "x;y;yaw"
GROOT_TYPES: dict[type, str] = {str: "std::string", int: "int", float: "double", bool: "bool", Pose2D: "Pose2D"}

_SECTION = re.compile(r"^([ \t]*)<TreeNodesModel>.*?</TreeNodesModel>[ \t]*\n?", re.S | re.M)
_SUBTREE_MODEL = re.compile(r"^[ \t]*(?:<SubTree\b[^>]*/>|<SubTree\b[^>]*[^/]>.*?</SubTree>)[ \t]*\n", re.S | re.M)


def format_default(value: object) -> str:
    """A default as BT.CPP would parse it back (bools as true/false)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    return str(value)


def _port_xml(name: str, port: Port) -> str:
    """``<input_port>``, ``<output_port>`` or ``<inout_port>``; an output's default is the entry it writes."""
    attrs = f"name={quoteattr(name)} type={quoteattr(GROOT_TYPES.get(port.type, port.type_name))}"
    if port.direction == "output":
        if isinstance(port.default, str):
            attrs += f" default={quoteattr(port.default)}"
    elif not port.required:
        attrs += f" default={quoteattr(format_default(port.default))}"
    tag = f"{port.direction}_port"
    return f"<{tag} {attrs}>{escape(port.doc)}</{tag}>" if port.doc else f"<{tag} {attrs}/>"


def nodes_model_xml(
    factory: BehaviourFactory, indent: str = "", *, descriptions: bool = False, used: Collection[str] = ()
) -> str:
    """``<TreeNodesModel>`` for every behaviour registered in `factory` (sorted by tag), each line
    prefixed by `indent`. The built-ins are left out: Groot2 knows them. So are deprecated behaviours
    (PerceiveTargets), unless their tag is in `used` (the tree being shown uses them). With `descriptions`,
    each node also carries what it does, as BT.CPP writes a node's metadata
    (``<MetadataFields><Metadata description="…"/></MetadataFields>``): the palette and the monitor do."""
    lines = ["<TreeNodesModel>"]
    for node in factory.behaviours(deprecated=True):
        if node.deprecated and node.tag not in used:
            continue
        about = descriptions and bool(node.doc)
        if not node.ports and not about:
            lines.append(f"  <{node.kind} ID={quoteattr(node.tag)}/>")
            continue
        lines.append(f"  <{node.kind} ID={quoteattr(node.tag)}>")
        lines.extend(f"    {_port_xml(name, port)}" for name, port in node.ports.items())
        if about:
            lines.append(f"    <MetadataFields><Metadata description={quoteattr(node.doc)}/></MetadataFields>")
        lines.append(f"  </{node.kind}>")
    lines.append("</TreeNodesModel>")
    return "".join(f"{indent}{line}\n" for line in lines)


def nodes_model_section(text: str) -> str | None:
    """The ``<TreeNodesModel>`` block of a tree file's text, as written (None when absent)."""
    match = _SECTION.search(text)
    return match.group(0) if match else None


def with_nodes_model(text: str, factory: BehaviourFactory, *, descriptions: bool = False) -> str:
    """Tree file text with its ``<TreeNodesModel>`` replaced by (or, before ``</root>``, given) the current one.

    The ``<SubTree ID>`` models already there (the ports of the file's own trees, written by hand) are kept."""
    match = _SECTION.search(text)
    if match:
        indent = match.group(1)
        subtrees = "".join(m.group(0) for m in _SUBTREE_MODEL.finditer(match.group(0)))
        section = nodes_model_xml(factory, indent, descriptions=descriptions)
        if subtrees:
            section = section.replace(f"{indent}</TreeNodesModel>\n", f"{subtrees}{indent}</TreeNodesModel>\n")
        return text[: match.start()] + section + text[match.end() :]
    return text.replace("</root>", "\n" + nodes_model_xml(factory, "  ", descriptions=descriptions) + "</root>")


def shipped_tree_files() -> list[Path]:
    """The shipped tree files whose model this module keeps current: trees/*.xml and trees/examples/*.xml."""
    here = Path(__file__).resolve().parent
    return sorted(here.glob("*.xml")) + sorted((here / "examples").glob("*.xml"))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description="Regenerate the TreeNodesModel section of the shipped tree files.")
    parser.add_argument("--check", action="store_true", help="report stale files, change nothing (exit 1 if any)")
    args = parser.parse_args(argv)
    factory = shipped_factory()
    stale = []
    for path in shipped_tree_files():
        text = path.read_text()
        new = with_nodes_model(text, factory)
        if new != text:
            stale.append(path.name)
            if not args.check:
                atomic_write_text(path, new)
    verb = "stale" if args.check else "updated"
    print(f"{verb}: {', '.join(stale) or 'none'}")
    return 1 if args.check and stale else 0


if __name__ == "__main__":
    sys.exit(main())
