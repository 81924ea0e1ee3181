"""The colours of the mission's pictures: one palette for SVG, PNG, the live page and recordings.

Fill and frame say a node's *status* (what happened on the last tick); the stripe on the left says its
*kind* (what sort of node it is). Statuses follow the usual behaviour-tree convention: green success,
red failure, amber running, grey not ticked.
"""

from __future__ import annotations

from mission.viz.fonts import FONT_FAMILY, MONO_FAMILY

# status → (frame, fill, text on frame colour)
STATUS_COLOURS: dict[str, tuple[str, str]] = {
    "SUCCESS": ("#1e8e3e", "#e6f4ea"),
    "FAILURE": ("#d93025", "#fce8e6"),
    "RUNNING": ("#e37400", "#fef1dc"),
    "INVALID": ("#b8bec6", "#ffffff"),
}
KIND_COLOURS: dict[str, str] = {
    "Control": "#3c4a6b",
    "Decorator": "#7b5ea7",
    "Condition": "#00838f",
    "Action": "#1a73e8",
    "SubTree": "#5f6368",
}
# Mission states (also in mission.viz.run_report's timeline; kept as names there, as hex here for CSS/OpenCV).
STATE_COLOURS: dict[str, str] = {
    "EXPLORE": "#7f7f7f",
    "DOCK": "#9467bd",
    "FOLLOW": "#2ca02c",
    "LOST": "#ff7f0e",
    "SEARCH": "#d62728",
    "DONE": "#1f77b4",
    "FAILED": "#000000",
}
INK = "#202124"
MUTED = "#5f6368"


def hex_to_bgr(colour: str) -> tuple[int, int, int]:
    """'#rrggbb' → OpenCV's (b, g, r)."""
    c = colour.lstrip("#")
    r, g, b = (int(c[i : i + 2], 16) for i in (0, 2, 4))
    return b, g, r


def tree_css() -> str:
    """CSS for a tree SVG: embedded in every SVG file and in the HTML pages, so they look the same."""
    rules = [
        f".bt {{ font-family: {FONT_FAMILY}; }}",
        f".bt text {{ fill: {INK}; }}",
        ".bt .name { font-weight: bold; font-size: 13px; }",
        f".bt .type {{ font-size: 11px; fill: {MUTED}; }}",
        f".bt .port {{ font-size: 10.5px; fill: #3c4043; font-family: {FONT_FAMILY}; }}",
        f".bt .fb {{ font-size: 11px; font-style: italic; fill: {MUTED}; }}",
        ".bt .frame { stroke-width: 1.5; }",
        ".bt .k-Control .frame { stroke-width: 2; }",
        ".bt .k-SubTree .frame { stroke-dasharray: 5 3; }",
        ".bt .edge { fill: none; stroke-width: 1.6; }",
        ".bt .legend text { font-size: 11px; fill: #3c4043; }",
        ".bt .title { font-size: 15px; font-weight: bold; }",
    ]
    for status, (frame, fill) in STATUS_COLOURS.items():
        rules.append(f".bt .st-{status} .frame {{ stroke: {frame}; fill: {fill}; }}")
        width = "2.6" if status == "RUNNING" else "1.6"
        rules.append(f".bt .edge.st-{status} {{ stroke: {frame}; stroke-width: {width}; }}")
    rules.append(".bt .st-RUNNING .frame { stroke-width: 2.5; }")
    for kind, colour in KIND_COLOURS.items():
        rules.append(f".bt .k-{kind} .stripe {{ fill: {colour}; }}")
    rules.append(f".bt .mono {{ font-family: {MONO_FAMILY}; }}")
    return "\n".join(rules)
