"""A tree as Graphviz DOT text (for people who already use Graphviz; SVG and HTML do not need it).

Colours and shapes follow :mod:`mission.viz.style`, so a `dot -Tpng` picture matches the SVG.
"""

from __future__ import annotations

from mission.viz.layout import glyph
from mission.viz.model import VizNode
from mission.viz.style import KIND_COLOURS, STATUS_COLOURS


def _quote(text: str) -> str:
    return '"' + text.replace("\\", "\\\\").replace('"', '\\"').replace("\n", "\\n") + '"'


def _html(text: str) -> str:
    return text.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;").replace('"', "&quot;")


def render_dot(root: VizNode, *, title: str | None = None, ports: bool = True, feedback: bool = False) -> str:
    """DOT source for the tree under `root`."""
    out = [
        "digraph behaviour_tree {",
        '  graph [rankdir=TB, nodesep=0.25, ranksep=0.45, bgcolor="#fafbfc", fontname="DejaVu Sans"'
        + (f", label={_quote(title)}, labelloc=t, fontsize=16" if title else "")
        + "];",
        '  node [shape=box, style="rounded,filled", fontname="DejaVu Sans", fontsize=11, margin="0.12,0.06"];',
        '  edge [arrowhead=none, color="#9aa0a6"];',
    ]
    for n in root.walk():
        frame, fill = STATUS_COLOURS.get(n.status, STATUS_COLOURS["INVALID"])
        if n.status == "INVALID":
            frame = KIND_COLOURS.get(n.kind, frame)
        g = glyph(n)
        rows = [f"<B>{_html(f'{g} {n.name}' if g else n.name)}</B>"]
        if n.label_type:
            rows.append(f'<FONT POINT-SIZE="9" COLOR="#5f6368">{_html(n.label_type)}</FONT>')
        if ports:
            rows += [f'<FONT POINT-SIZE="9">{_html(f"{k} = {v}")}</FONT>' for k, v in n.ports.items()]
        if feedback and n.feedback:
            rows.append(f'<FONT POINT-SIZE="9" COLOR="#5f6368"><I>{_html(n.feedback[:60])}</I></FONT>')
        label = "<" + "<BR/>".join(rows) + ">"
        style = '"rounded,filled,dashed"' if n.kind == "SubTree" else '"rounded,filled"'
        width = 2.5 if n.status == "RUNNING" or n.kind == "Control" else 1.3
        out.append(f'  n{n.id} [label={label}, color="{frame}", fillcolor="{fill}", style={style}, penwidth={width}];')
    for n in root.walk():
        for c in n.children:
            colour = STATUS_COLOURS.get(c.status, STATUS_COLOURS["INVALID"])[0]
            out.append(f'  n{n.id} -> n{c.id} [color="{colour}"];')
    out.append("}")
    return "\n".join(out) + "\n"
