"""A tree as SVG, laid out by :mod:`mission.viz.layout` — no Graphviz needed.

Each node is a ``<g class="node k-KIND st-STATUS" id="node-N">`` group, each edge a
``<path class="edge st-STATUS" data-child="N">``; the live page and the log scrubber change only those
classes and the feedback text, so the same drawing serves files, reports and the browser.
"""

from __future__ import annotations

from xml.sax.saxutils import escape, quoteattr

from mission.viz.layout import PAD_X, Layout, layout_tree
from mission.viz.model import VizNode
from mission.viz.style import KIND_COLOURS, STATUS_COLOURS, tree_css

LEGEND_H = 34.0
TITLE_H = 30.0
STRIPE_W = 5.0


def node_tooltip(n: VizNode) -> str:
    """Everything known about a node, for hover text."""
    parts = [f"{n.name} ({n.type}, {n.kind})"]
    parts += [f"  {k} = {v}" for k, v in n.ports.items()]
    parts += [f"  {k} = {v} (default)" for k, v in n.defaults.items()]
    if n.status != "INVALID" or n.feedback:
        parts.append(f"status: {n.status}")
    if n.feedback:
        parts.append(f"feedback: {n.feedback}")
    if n.duration_us is not None:
        parts.append(f"tick: {n.duration_us:.0f} µs")
    if n.line:
        parts.append(f"line {n.line}")
    return "\n".join(parts)


def _edge_path(lay: Layout, parent: int, child: int) -> str:
    p, c = lay.boxes[parent], lay.boxes[child]
    y_mid = c.y - 20.0
    return f"M{p.cx:.1f},{p.bottom:.1f} V{y_mid:.1f} H{c.cx:.1f} V{c.y:.1f}"


def _legend(y: float) -> list[str]:
    out = [f'<g class="legend" transform="translate({PAD_X:.0f},{y:.1f})">']
    x = 0.0
    for status, (frame, fill) in STATUS_COLOURS.items():
        label = "not ticked" if status == "INVALID" else status.lower()
        out.append(
            f'<rect x="{x:.0f}" y="0" width="14" height="14" rx="3" fill="{fill}" stroke="{frame}" '
            f'stroke-width="1.5"/><text x="{x + 19:.0f}" y="11">{label}</text>'
        )
        x += 30 + 7 * len(label)
    x += 14
    for kind, colour in KIND_COLOURS.items():
        out.append(
            f'<rect x="{x:.0f}" y="0" width="5" height="14" fill="{colour}"/>'
            f'<text x="{x + 10:.0f}" y="11">{kind}</text>'
        )
        x += 22 + 7 * len(kind)
    out.append("</g>")
    return out


def render_svg(
    root: VizNode,
    *,
    ports: bool = True,
    feedback: bool = False,
    title: str | None = None,
    legend: bool = True,
    standalone: bool = True,
    layout: Layout | None = None,
) -> str:
    """The SVG text of the tree under `root` (statuses drawn as they are in the nodes)."""
    lay = layout or layout_tree(root, ports=ports, feedback=feedback)
    top = TITLE_H if title else 0.0
    width = max(lay.width, 620.0 if legend else 0.0)
    height = lay.height + top + (LEGEND_H if legend else 0.0)
    out: list[str] = []
    if standalone:
        out.append('<?xml version="1.0" encoding="UTF-8"?>')
    out.append(
        f'<svg xmlns="http://www.w3.org/2000/svg" class="bt" width="{width:.0f}" height="{height:.0f}" '
        f'viewBox="0 0 {width:.0f} {height:.0f}">'
    )
    out.append(f"<style>\n{tree_css()}\n</style>")
    out.append(f'<rect width="{width:.0f}" height="{height:.0f}" fill="#fafbfc"/>')
    if title:
        out.append(f'<text class="title" x="{PAD_X:.0f}" y="21">{escape(title)}</text>')
    out.append(f'<g transform="translate(0,{top:.0f})">')
    nodes = {n.id: n for n in root.walk()}
    out.append('<g class="edges">')
    for parent, child in lay.edges:
        out.append(
            f'<path class="edge st-{nodes[child].status}" data-child="{child}" d="{_edge_path(lay, parent, child)}"/>'
        )
    out.append("</g>")
    for n in root.walk():
        box, crd = lay.boxes[n.id], lay.cards[n.id]
        radius = 12.0 if n.kind == "Condition" else 5.0
        out.append(
            f'<g class="node k-{n.kind} st-{n.status}" id="node-{n.id}" data-id="{n.id}" '
            f'data-name={quoteattr(n.name)} data-fbmax="{crd.feedback_chars}" '
            f'transform="translate({box.x:.1f},{box.y:.1f})">'
        )
        out.append(f"<title>{escape(node_tooltip(n))}</title>")
        out.append(f'<rect class="frame" width="{box.w:.1f}" height="{box.h:.1f}" rx="{radius:.0f}"/>')
        out.append(f'<rect class="stripe" x="1" y="1" width="{STRIPE_W:.0f}" height="{box.h - 2:.1f}" rx="2"/>')
        for line in crd.lines:
            cls = {"name": "name", "type": "type", "port": "port", "feedback": "fb"}[line.role]
            out.append(f'<text class="{cls}" x="{PAD_X:.0f}" y="{line.baseline:.1f}">{escape(line.text)}</text>')
        out.append("</g>")
    out.append("</g>")
    if legend:
        out.extend(_legend(top + lay.height + 4))
    out.append("</svg>")
    return "\n".join(out) + "\n"
