"""Tree files as line-numbered elements, so every error can name ``file:line``.

Python's ElementTree drops line numbers, so this module parses with ``xml.parsers.expat`` directly
and keeps, for every element, its tag, attributes (in file order), the line of its start tag and the
file it came from. Nothing here knows about behaviour trees; the loader interprets the elements.
"""

from __future__ import annotations

import bisect
import os
import re
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


_ATTRIBUTE = re.compile(r"""\s+([^\s=/>]+)\s*=\s*(?:"([^"]*)"|'([^']*)')""")
_ENTITY = re.compile(r"&(#x[0-9a-fA-F]+|#[0-9]+|[A-Za-z]+);")


@dataclass(eq=False)
class SourceText:
    """A file's text as read, for finding where inside an attribute value something was written."""

    data: bytes

    def char_offset(self, byte_offset: int) -> int:
        return len(self.data[:byte_offset].decode("utf-8", errors="replace"))

    @property
    def text(self) -> str:
        return self.data.decode("utf-8", errors="replace")


@dataclass
class SourceElement:
    """One XML element with where it was written."""

    tag: str
    attrib: dict[str, str]
    line: int
    file: Path
    children: list[SourceElement] = field(default_factory=list)
    source: SourceText | None = field(default=None, repr=False, compare=False)
    start: int = field(default=0, repr=False, compare=False)  # byte offset of the start tag's '<'
    #: the name a ``<BehaviorTree>`` without ``ID`` is known by (BT.CPP's ``BehaviorTree_<n>``)
    given_name: str | None = field(default=None, repr=False, compare=False)

    @property
    def name(self) -> str:
        """The element's ``ID``, or the name the loader gave it."""
        return self.attrib.get("ID") or self.given_name or ""

    @name.setter
    def name(self, value: str) -> None:
        self.given_name = value

    def attribute_position(self, name: str, index: int = 0) -> tuple[int, int]:
        """(line, column), 1-based, of character `index` of attribute `name`'s value as the parser gave it
        (entities such as ``&amp;`` count as the one character they stand for)."""
        if self.source is None:
            return self.line, 1
        text = self.source.text
        pos = self.source.char_offset(self.start) + 1 + len(self.tag)
        while True:
            match = _ATTRIBUTE.match(text, pos)
            if match is None:
                return self.line, 1
            if match.group(1) == name:
                group = 2 if match.group(2) is not None else 3
                raw_start, raw = match.start(group), match.group(group)
                break
            pos = match.end()
        i = decoded = 0
        while i < len(raw) and decoded < index:
            entity = _ENTITY.match(raw, i) if raw[i] == "&" else None
            i += len(entity.group(0)) if entity else 2 if raw.startswith("\r\n", i) else 1
            decoded += 1
        absolute = raw_start + i
        line = text.count("\n", 0, absolute) + 1
        return line, absolute - (text.rfind("\n", 0, absolute) + 1) + 1

    def error_at(self, name: str, index: int, message: str) -> str:
        """``file:line:column: <Tag>: message`` for a place inside attribute `name`'s value."""
        line, column = self.attribute_position(name, index)
        return f"{display_path(self.file)}:{line}:{column}: {self.label}: {message}"

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


_ENTITY_BYTES = re.compile(rb"&(#x[0-9a-fA-F]+|#[0-9]+|[A-Za-z][A-Za-z0-9]*);")
#: a quoted value holding a '<' or '&' (an escaped '&lt;' matches too: then the careful pass decides)
_MAYBE_RAW = re.compile(rb"""=\s*("[^"]*[<&]|'[^']*[<&])""")
_SKIP = ((b"<!--", b"-->"), (b"<![CDATA[", b"]]>"), (b"<?", b"?>"), (b"<!", b">"))


def escape_attribute_values(data: bytes) -> tuple[bytes, list[tuple[int, int]]]:
    """`data` with a raw ``<`` or a bare ``&`` inside attribute values escaped, as tinyxml2 (BT.CPP's parser)
    reads them: people write ``_skipIf="A<2"`` and ``code="a && b"`` by hand, and BT.CPP loads such files.

    Returns the escaped text and, for mapping the parser's byte offsets back to `data`, the points where the
    text grew: (offset in the escaped text where the growth ends, total growth so far)."""
    if not _MAYBE_RAW.search(data):  # the usual file: nothing to escape, no byte-by-byte pass
        return data, []
    out = bytearray()
    shifts: list[tuple[int, int]] = []
    i, n = 0, len(data)
    while i < n:
        skip = next((end for start, end in _SKIP if data.startswith(start, i)), None)
        if skip is not None:  # comments, CDATA, declarations: as written
            j = data.find(skip, i + 1)
            j = n if j < 0 else j + len(skip)
            out += data[i:j]
            i = j
            continue
        if data[i] != 0x3C:  # '<'
            out.append(data[i])
            i += 1
            continue
        out.append(data[i])  # a tag: copy to its '>', escaping inside quoted values
        i += 1
        quote = 0
        while i < n:
            c = data[i]
            i += 1
            if quote and c == 0x3C:
                out += b"&lt;"
                shifts.append((len(out), (shifts[-1][1] if shifts else 0) + 3))
            elif quote and c == 0x26 and not _ENTITY_BYTES.match(data, i - 1):
                out += b"&amp;"
                shifts.append((len(out), (shifts[-1][1] if shifts else 0) + 4))
            else:
                out.append(c)
                if quote and c == quote:
                    quote = 0
                elif not quote and c in (0x22, 0x27):
                    quote = c
                elif not quote and c == 0x3E:  # '>'
                    break
    return bytes(out), shifts


def parse_bytes(data: bytes, path: Path) -> SourceElement:
    """Parse XML text that came from `path` (used in messages and to resolve includes)."""
    if not data.strip():
        raise TreeError(f'{display_path(path)}:1: empty file; expected <root BTCPP_format="4"> with a <BehaviorTree>')
    escaped, shifts = escape_attribute_values(data)
    ends = [end for end, _ in shifts]

    def original(offset: int) -> int:
        k = bisect.bisect_right(ends, offset)
        return offset - (shifts[k - 1][1] if k else 0)

    parser = expat.ParserCreate()
    parser.ordered_attributes = True
    source = SourceText(data)
    stack: list[SourceElement] = []
    roots: list[SourceElement] = []

    def start(tag: str, attributes: list[str]) -> None:
        attrib = dict(zip(attributes[0::2], attributes[1::2], strict=True))
        offset = original(parser.CurrentByteIndex)
        element = SourceElement(tag, attrib, parser.CurrentLineNumber, path, [], source, offset)
        if len(stack) >= MAX_DEPTH:  # the checker and builder recurse: stop here, not with a RecursionError
            raise TreeError(
                element.error(
                    f"nested {len(stack)} elements deep; expected at most {MAX_DEPTH} (split the tree into <SubTree>s)"
                )
            )
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
        parser.Parse(escaped, True)
    except expat.ExpatError as exc:
        reason = expat.errors.messages.get(exc.code, str(exc))
        raise TreeError(
            f"{display_path(path)}:{exc.lineno}: malformed XML: {reason} (column {exc.offset + 1}); "
            "expected a well-formed BehaviorTree.CPP v4 file"
        ) from None
    return roots[0]
