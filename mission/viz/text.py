"""A tree as indented text for terminals and logs: unicode (box drawing, glyphs) or plain ASCII.

    → Mission  ReactiveSequence
    ├── ◆ ForceSuccess
    │   └── PerceiveTargets  Action
    ...

With statuses (a recorded tick) each line starts with a status mark and ends with the feedback message.
"""

from __future__ import annotations

from mission.viz.layout import glyph
from mission.viz.model import VizNode

UNICODE_MARKS = {"SUCCESS": "✔", "FAILURE": "✘", "RUNNING": "●", "INVALID": "·"}
ASCII_MARKS = {"SUCCESS": "[+]", "FAILURE": "[x]", "RUNNING": "[*]", "INVALID": "[ ]"}
ASCII_GLYPHS = {"→": "->", "?": "?", "⇉": "=>", "◆": "<>", "❏": "[]"}


def render_text(root: VizNode, *, unicode: bool = True, statuses: bool = False, ports: bool = True) -> str:
    """The tree under `root` as lines of text (statuses and feedback when `statuses`)."""
    tee, last, pipe, blank = ("├── ", "└── ", "│   ", "    ") if unicode else ("|-- ", "`-- ", "|   ", "    ")
    marks = UNICODE_MARKS if unicode else ASCII_MARKS
    lines: list[str] = []

    def describe(n: VizNode) -> str:
        g = glyph(n)
        if g and not unicode:
            g = ASCII_GLYPHS.get(g, g)
        text = f"{g} {n.name}" if g else n.name
        detail = [n.label_type] if n.label_type else []
        if n.kind in ("Action", "Condition") and not n.label_type:
            detail.append(n.kind)
        if ports and n.ports:
            detail.append(" ".join(f"{k}={v}" for k, v in n.ports.items()))
        if detail:
            text += "  " + "  ".join(detail)
        if statuses:
            text = f"{marks.get(n.status, '?')} {text}"
            if n.feedback:
                text += f"  — {n.feedback}" if unicode else f"  -- {n.feedback}"
        if not unicode:
            text = text.encode("ascii", "replace").decode("ascii")
        return text

    def walk(n: VizNode, prefix: str, is_last: bool, is_root: bool) -> None:
        lines.append(describe(n) if is_root else prefix + (last if is_last else tee) + describe(n))
        child_prefix = "" if is_root else prefix + (blank if is_last else pipe)
        for i, c in enumerate(n.children):
            walk(c, child_prefix, i == len(n.children) - 1, False)

    walk(root, "", True, True)
    return "\n".join(lines) + "\n"
