"""A tidy top-down layout of a behaviour tree: every picture of a tree (SVG, PNG, HTML, live page) uses it.

A behaviour tree is a tree, so no graph layout engine is needed: each subtree is laid out on its own,
siblings are pushed apart only as far as their outlines (per-depth contours) require, and a parent sits
centred over its children (Reingold–Tilford with variable box sizes). Rows are as tall as their tallest
box, so every depth lines up.

A node's box ("card") holds its name, its type, its ports (static drawings) and its feedback message
(live drawings); :func:`card` decides those lines and the box size, and every renderer draws them.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from mission.viz.fonts import fit, text_width
from mission.viz.model import VizNode

# Typography of a card (px).
NAME_SIZE = 13.0
TYPE_SIZE = 11.0
PORT_SIZE = 10.5
FEEDBACK_SIZE = 11.0
LINE_GAP = 4.0
PAD_X = 12.0
PAD_Y = 8.0
MIN_W = 120.0
MAX_W = 260.0
MAX_PORTS = 5

# Glyphs shown before the name of control nodes, as Groot draws them.
CONTROL_GLYPHS = {
    "Sequence": "→", "ReactiveSequence": "→", "SequenceWithMemory": "→",
    "Fallback": "?", "ReactiveFallback": "?", "Selector": "?",
    "Parallel": "⇉", "ParallelAll": "⇉",
}  # fmt: skip
KIND_GLYPHS = {"Decorator": "◆", "SubTree": "❏"}


def glyph(node: VizNode) -> str:
    """The small symbol before a node's name: how control flows through it."""
    if node.kind == "Control":
        return CONTROL_GLYPHS.get(node.type, "→" if "Sequence" in node.type else "?")
    return KIND_GLYPHS.get(node.kind, "")


@dataclass(frozen=True)
class TextLine:
    role: str  # name | type | port | feedback
    text: str
    size: float
    baseline: float  # y of the baseline from the card's top


@dataclass(frozen=True)
class Card:
    w: float
    h: float
    lines: tuple[TextLine, ...]
    feedback_chars: int  # how many feedback characters fit (the live page truncates to it)


def _port_text(key: str, value: str) -> str:
    return f"{key} = {value}"


def card(node: VizNode, *, ports: bool = True, feedback: bool = False) -> Card:
    """The box for `node`: which text lines it shows and how big it is."""
    g = glyph(node)
    name = f"{g} {node.name}" if g else node.name
    texts: list[tuple[str, str, float, bool]] = [("name", name, NAME_SIZE, True)]
    if node.label_type:
        texts.append(("type", node.label_type, TYPE_SIZE, False))
    if ports and node.ports:
        items = list(node.ports.items())
        shown = items if len(items) <= MAX_PORTS else items[: MAX_PORTS - 1]
        texts += [("port", _port_text(k, v), PORT_SIZE, False) for k, v in shown]
        if len(shown) < len(items):
            texts.append(("port", f"+{len(items) - len(shown)} more", PORT_SIZE, False))
    widest = max(text_width(t, s, bold=b) for _, t, s, b in texts)
    w = min(MAX_W, max(MIN_W, widest + 2 * PAD_X))
    inner = w - 2 * PAD_X
    if feedback:
        texts.append(("feedback", node.feedback, FEEDBACK_SIZE, False))
    lines: list[TextLine] = []
    y = PAD_Y
    for role, text, size, bold in texts:
        y += size
        lines.append(TextLine(role, fit(text, size, inner, bold=bold), size, y))
        y += LINE_GAP
    avg = text_width("abcdefghijklmnopqrstuvwxyz ", FEEDBACK_SIZE) / 27.0
    return Card(w=w, h=y - LINE_GAP + PAD_Y, lines=tuple(lines), feedback_chars=max(8, int(inner / avg)))


@dataclass(frozen=True)
class Box:
    x: float  # top-left corner
    y: float
    w: float
    h: float

    @property
    def cx(self) -> float:
        return self.x + self.w / 2

    @property
    def bottom(self) -> float:
        return self.y + self.h


@dataclass
class Layout:
    boxes: dict[int, Box]
    cards: dict[int, Card]
    edges: list[tuple[int, int]]  # (parent id, child id)
    width: float
    height: float
    rows: list[float] = field(default_factory=list)  # y of each depth's top


H_GAP = 16.0
V_GAP = 44.0
MARGIN = 16.0


def layout_tree(root: VizNode, *, ports: bool = True, feedback: bool = False) -> Layout:
    """Positions for every node of the tree under `root` (ids as in :meth:`VizNode.walk`)."""
    cards = {n.id: card(n, ports=ports, feedback=feedback) for n in root.walk()}

    # Pass 1: per subtree, offsets of children relative to their parent's centre, and the subtree's
    # contour: (left, right) extent at each depth below and including the node, relative to its centre.
    offsets: dict[int, float] = {}

    def place(node: VizNode) -> list[tuple[float, float]]:
        half = cards[node.id].w / 2
        if not node.children:
            return [(-half, half)]
        contours = [place(c) for c in node.children]
        positions = [0.0]
        merged = list(contours[0])
        for cont in contours[1:]:
            shift = max(merged[d][1] - cont[d][0] + H_GAP for d in range(min(len(merged), len(cont))))
            positions.append(shift)
            for d, (lo, hi) in enumerate(cont):
                if d < len(merged):
                    merged[d] = (merged[d][0], hi + shift)
                else:
                    merged.append((lo + shift, hi + shift))
        centre = (positions[0] + positions[-1]) / 2
        for c, p in zip(node.children, positions, strict=True):
            offsets[c.id] = p - centre
        below = [(lo - centre, hi - centre) for lo, hi in merged]
        return [(-half, half), *below]

    place(root)

    # Row heights: each depth as tall as its tallest card.
    depth_of: dict[int, int] = {}
    row_h: list[float] = []

    def depths(node: VizNode, d: int) -> None:
        depth_of[node.id] = d
        if d == len(row_h):
            row_h.append(0.0)
        row_h[d] = max(row_h[d], cards[node.id].h)
        for c in node.children:
            depths(c, d + 1)

    depths(root, 0)
    rows = [MARGIN]
    for h in row_h[:-1]:
        rows.append(rows[-1] + h + V_GAP)

    # Pass 2: absolute centres.
    centres: dict[int, float] = {}
    edges: list[tuple[int, int]] = []

    def absolute(node: VizNode, cx: float) -> None:
        centres[node.id] = cx
        for c in node.children:
            edges.append((node.id, c.id))
            absolute(c, cx + offsets[c.id])

    absolute(root, 0.0)
    left = min(centres[i] - cards[i].w / 2 for i in centres)
    boxes = {
        i: Box(x=centres[i] - cards[i].w / 2 - left + MARGIN, y=rows[depth_of[i]], w=cards[i].w, h=cards[i].h)
        for i in centres
    }
    width = max(b.x + b.w for b in boxes.values()) + MARGIN
    height = max(b.bottom for b in boxes.values()) + MARGIN
    return Layout(boxes=boxes, cards=cards, edges=edges, width=width, height=height, rows=rows)
