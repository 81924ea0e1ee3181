"""The mission page as one self-contained HTML file: no CDN, no external URL, works from file://.

One page (``static/page.html`` + ``page.css`` + ``page.js``, inlined) in three modes:

* ``static``   — a tree file's structure (`mission viz TREE.xml --format html`);
* ``playback`` — a recorded tick log with a slider, play button and arrow keys (`mission viz --log run.jsonl
  --format html`);
* ``live``     — served by :mod:`mission.viz.web` during a run, updated by server-sent events.
"""

from __future__ import annotations

import json
from importlib import resources
from typing import Any
from xml.sax.saxutils import escape

from mission.viz.model import VizNode
from mission.viz.style import STATE_COLOURS
from mission.viz.svg import render_svg


def _asset(name: str) -> str:
    return (resources.files("mission.viz") / "static" / name).read_text(encoding="utf-8")


def _json_for_script(data: Any) -> str:
    """JSON safe inside <script>: no '</' can close the element early."""
    return json.dumps(data, separators=(",", ":"), ensure_ascii=False).replace("</", "<\\/")


def tree_svg_for_page(root: VizNode, *, live: bool) -> str:
    """The SVG the page shows: with feedback lines when there are ticks, ports always."""
    return render_svg(root, ports=True, feedback=live, legend=True, standalone=False)


def render_page(
    mode: str,
    root: VizNode | None,
    *,
    header: dict[str, Any] | None = None,
    ticks: list[dict[str, Any]] | None = None,
    tick: int | None = None,
    title: str = "mission",
    empty: str = "waiting for the run to start…",
    notice: str = "",
) -> str:
    """The whole page as a string. `root` None (a live run not started yet, or with no tree) shows an empty
    tree panel saying `empty`; `notice` is a line in the bar (a live run whose tree stopped)."""
    svg = "" if root is None else tree_svg_for_page(root, live=mode != "static")
    data = {"mode": mode, "header": header, "ticks": ticks or [], "tick": tick, "state_colours": STATE_COLOURS}
    page = _asset("page.html")
    for key, value in (
        ("{{CSS}}", _asset("page.css")),
        ("{{JS}}", _asset("page.js")),
        ("{{SVG}}", svg or f'<p class="empty" style="padding:16px">{escape(empty)}</p>'),
        ("{{NOTICE}}", escape(notice)),
        ("{{NOTICE_HIDDEN}}", "" if notice else " hidden"),
        ("{{DATA}}", _json_for_script(data)),
        ("{{TITLE}}", escape(title)),
        ("{{MODE}}", mode),
    ):
        page = page.replace(key, value)
    return page


def static_header(root: VizNode, tree_file: str | None = None) -> dict[str, Any]:
    """A header for pages of a tree file (no run): the structure the details panel shows."""
    from mission.viz.model import to_dict

    return {"kind": "header", "tree_file": tree_file, "tree": to_dict(root), "map": None}
