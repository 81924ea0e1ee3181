"""Tree files as line-numbered elements, so every error can name ``file:line``.

Python's ElementTree drops line numbers, so this module parses with ``xml.parsers.expat`` directly
and keeps, for every element, its tag, attributes (in file order), the line of its start tag and the
file it came from. Nothing here knows about behaviour trees; the loader interprets the elements.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path
from xml.parsers import expat

from mission.core.errors import TreeError

# Deepest element nesting a tree file may have. Real trees are a dozen levels deep; loading recurses per level.
MAX_DEPTH = 100


def display_path(path: Path) -> str:
    """How a file is named in error messages: relative to the working directory when inside it."""
    try:
        rel = os.path.relpath(path)
    except ValueError:  # another drive (Windows)
        return str(path)
    return str(path) if rel.startswith("..") else rel


@dataclass
class SourceElement:
    """One XML element with where it was written."""

    tag: str
    attrib: dict[str, str]
    line: int
    file: Path
    children: list[SourceElement] = field(default_factory=list)

    @property
    def where(self) -> str:
        """``file:line`` of the start tag."""
        return f"{display_path(self.file)}:{self.line}"

    @property
    def label(self) -> str:
        """The element as a user recognises it: ``<Tag>``, or ``<Tag ID="X">`` / ``<include path="p">``."""
        for key in ("ID", "path"):
            if key in self.attrib:
                return f'<{self.tag} {key}="{self.attrib[key]}">'
        return f"<{self.tag}>"

    def error(self, message: str) -> str:
        """The one-line problem report for this element: ``file:line: <Tag>: message``."""
        return f"{self.where}: {self.label}: {message}"


def parse_file(path: Path) -> SourceElement:
    """Parse one XML file into line-numbered elements; malformed XML → TreeError naming file and line."""
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise TreeError(f"{display_path(path)}: cannot read tree file: {exc.strerror or exc}") from None
    return parse_bytes(data, path)


def parse_bytes(data: bytes, path: Path) -> SourceElement:
    """Parse XML text that came from `path` (used in messages and to resolve includes)."""
    if not data.strip():
        raise TreeError(f'{display_path(path)}:1: empty file; expected <root BTCPP_format="4"> with a <BehaviorTree>')
    parser = expat.ParserCreate()
    stack: list[SourceElement] = []
    roots: list[SourceElement] = []

    def start(tag: str, attrib: dict[str, str]) -> None:
        element = SourceElement(tag, dict(attrib), parser.CurrentLineNumber, path)
        if len(stack) >= MAX_DEPTH:  # the checker and builder recurse: stop here, not with a RecursionError
            raise TreeError(element.error(f"nested {len(stack)} elements deep; expected at most {MAX_DEPTH} "
                                          "(split the tree into <SubTree>s)"))
        if stack:
            stack[-1].children.append(element)
        else:
            roots.append(element)
        stack.append(element)

    def end(_tag: str) -> None:
        stack.pop()

    parser.StartElementHandler = start
    parser.EndElementHandler = end
    try:
        parser.Parse(data, True)
    except expat.ExpatError as exc:
        reason = expat.errors.messages.get(exc.code, str(exc))
        raise TreeError(
            f"{display_path(path)}:{exc.lineno}: malformed XML: {reason} (column {exc.offset + 1}); "
            "expected a well-formed BehaviorTree.CPP v4 file"
        ) from None
    return roots[0]
