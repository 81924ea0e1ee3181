"""A tree as PNG, drawn with matplotlib from the same layout and palette as the SVG — no Graphviz needed.

matplotlib is already a dependency (report pictures) and ships DejaVu Sans, the font the layout measures,
so the PNG matches the SVG box for box.
"""

from __future__ import annotations

from pathlib import Path

from mission.core.errors import MissionError
from mission.core.files import atomic_path
from mission.viz.layout import PAD_X, layout_tree
from mission.viz.model import VizNode
from mission.viz.style import INK, KIND_COLOURS, MUTED, STATUS_COLOURS
from mission.viz.svg import STRIPE_W, TITLE_H

_ROLE_STYLE = {
    "name": {"weight": "bold", "color": INK},
    "type": {"color": MUTED},
    "port": {"color": "#3c4043"},
    "feedback": {"color": MUTED, "style": "italic"},
}


def render_png(
    root: VizNode,
    path: str | Path,
    *,
    ports: bool = True,
    feedback: bool = False,
    title: str | None = None,
    scale: float = 1.5,
) -> Path:
    """Write the tree under `root` to `path` as PNG (`scale` × the SVG's pixel size)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import FancyBboxPatch, Rectangle

    lay = layout_tree(root, ports=ports, feedback=feedback)
    top = TITLE_H if title else 0.0
    width, height = lay.width, lay.height + top
    dpi = 72.0 * scale  # 1 layout px = 1 pt, so font sizes in px carry over
    fig = plt.figure(figsize=(width / 72.0, height / 72.0), dpi=dpi)
    ax = fig.add_axes((0, 0, 1, 1))
    ax.set_xlim(0, width)
    ax.set_ylim(height, 0)
    ax.axis("off")
    fig.patch.set_facecolor("#fafbfc")
    if title:
        ax.text(PAD_X, 21, title, fontsize=15, fontweight="bold", color=INK, family="DejaVu Sans")
    nodes = {n.id: n for n in root.walk()}
    order = sorted(lay.edges, key=lambda e: nodes[e[1]].status != "INVALID")
    for parent, child in order:
        p, c = lay.boxes[parent], lay.boxes[child]
        frame = STATUS_COLOURS.get(nodes[child].status, STATUS_COLOURS["INVALID"])[0]
        y_mid = top + c.y - 20.0
        lw = 2.6 if nodes[child].status == "RUNNING" else 1.6
        ax.plot([p.cx, p.cx, c.cx, c.cx], [top + p.bottom, y_mid, y_mid, top + c.y], color=frame, lw=lw * 0.75)
    for n in root.walk():
        box, crd = lay.boxes[n.id], lay.cards[n.id]
        frame, fill = STATUS_COLOURS.get(n.status, STATUS_COLOURS["INVALID"])
        lw = 2.5 if n.status == "RUNNING" else (2.0 if n.kind == "Control" else 1.5)
        radius = 12.0 if n.kind == "Condition" else 5.0
        ax.add_patch(
            FancyBboxPatch(
                (box.x, top + box.y),
                box.w,
                box.h,
                boxstyle=f"round,pad=0,rounding_size={radius}",
                facecolor=fill,
                edgecolor=frame,
                linewidth=lw * 0.75,
                linestyle="--" if n.kind == "SubTree" else "-",
            )
        )
        ax.add_patch(
            Rectangle((box.x + 1, top + box.y + 1), STRIPE_W, box.h - 2, facecolor=KIND_COLOURS.get(n.kind, MUTED))
        )
        for line in crd.lines:
            ax.text(
                box.x + PAD_X,
                top + box.y + line.baseline,
                line.text,
                fontsize=line.size,
                family="DejaVu Sans",
                va="baseline",
                **_ROLE_STYLE[line.role],
            )
    path = Path(path)
    try:
        with atomic_path(path) as tmp:
            fig.savefig(tmp, format="png", dpi=dpi, facecolor=fig.get_facecolor())
    except OSError as err:  # as write_output says it for the text formats
        raise MissionError(f"{path}: cannot write ({err.strerror or err})") from err
    finally:
        plt.close(fig)
    return path
