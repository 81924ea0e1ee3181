"""`mission viz`: draw a tree file, or the tree as it was at one tick of a recorded run.

    mission viz trees/mission.xml                       # unicode, to stdout
    mission viz trees/mission.xml --format svg -o mission.svg
    mission viz --log run.jsonl --tick 120 --format svg -o t120.svg
    mission viz --log run.jsonl --format html -o run.html   # the whole run, with a slider
    mission viz --log run.btlog --format html -o run.html   # a Groot2 log (mission run --btlog, or BT.CPP's)
    mission viz navigate_to_pose.xml --nodes-model nav2_tree_nodes.xml   # another team's nodes, from a model

Text formats go to stdout without -o; svg/dot/html too; png needs -o. SVG, HTML and PNG are laid out
here (mission.viz.layout) — Graphviz is not needed for any format.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from mission.core.errors import MissionError
from mission.viz.model import VizNode, from_description
from mission.viz.output import write_output

FORMATS = ("unicode", "ascii", "dot", "svg", "png", "html")


EXTENSIONS = {"svg": "svg", "png": "png", "html": "html", "htm": "html", "dot": "dot", "gv": "dot"}  # → format


def _format(args: argparse.Namespace) -> str:
    """--format, or the -o file's extension when --format was left at its default (unicode). A file whose
    extension names another picture format than --format (``--format png -o x.svg``) is a usage error: the
    file would hold bytes its name says it does not."""
    fmt = args.format or "unicode"
    if args.output is not None and not args.output:
        raise MissionError("-o: expected a file name, got an empty string")
    ext = Path(args.output).suffix.lower().lstrip(".") if args.output else ""
    named = EXTENSIONS.get(ext)
    if named is not None and fmt == "unicode":
        return named
    if named is not None and named != fmt:
        raise MissionError(
            f"-o {args.output}: a .{ext} name, but --format {fmt} writes {fmt.upper()}; "
            f"use --format {named}, or an output name for {fmt}"
        )
    return fmt


def _emit(text: str, output: str | None) -> None:
    if output:
        write_output(output, text.encode("utf-8"))
    else:
        sys.stdout.write(text)
        sys.stdout.flush()


def _draw(root: VizNode, fmt: str, output: str | None, *, live: bool, title: str, page: str | None = None) -> None:
    if fmt in ("unicode", "ascii"):
        from mission.viz.text import render_text

        _emit(render_text(root, unicode=fmt == "unicode", statuses=live), output)
    elif fmt == "dot":
        from mission.viz.dot import render_dot

        _emit(render_dot(root, title=title, feedback=live), output)
    elif fmt == "svg":
        from mission.viz.svg import render_svg

        _emit(render_svg(root, feedback=live, title=title), output)
    elif fmt == "png":
        if not output:
            raise MissionError("--format png needs -o FILE.png (PNG is not written to a terminal)")
        from mission.viz.png import render_png

        render_png(root, output, feedback=live, title=title)
    elif fmt == "html":
        _emit(page or "", output)
    else:  # argparse already limits the choices
        raise MissionError(f"unknown format {fmt!r}; expected one of {', '.join(FORMATS)}")


def main(args: argparse.Namespace) -> int:
    fmt = _format(args)
    if args.log:
        return _from_log(args, fmt)
    if args.tick is not None:
        raise MissionError("--tick needs --log FILE (a JSON-lines tick log from `mission run --log`)")
    if not args.tree:
        raise MissionError("give a tree file (mission viz TREE.xml) or a tick log (mission viz --log run.jsonl)")
    from mission.trees.loader import describe_tree, resolve_tree_path
    from mission.trees.node_models import drawing_factory

    path = resolve_tree_path(args.tree)
    factory, models = drawing_factory(path, args.nodes_model)
    root = from_description(describe_tree(path, factory))
    if models:  # one note line: what is drawn from a model is not runnable here
        by_source: dict[str, list[str]] = {}
        for m in models:
            by_source.setdefault(m.source, []).append(m.tag)
        told = "; ".join(f"{', '.join(tags)} ({source})" for source, tags in by_source.items())
        print(f"mission viz: {len(models)} node type(s) drawn from models, not runnable here: {told}", file=sys.stderr)
    page = None
    if fmt == "html":
        from mission.viz.html import render_page, static_header

        page = render_page("static", root, header=static_header(root, str(path)), title=f"{root.name} — {path.name}")
    _draw(root, fmt, args.output, live=False, title=f"{root.name} ({path.name})", page=page)
    return 0


def _from_log(args: argparse.Namespace, fmt: str) -> int:
    from mission.groot.btlog import is_btlog

    if is_btlog(args.log):  # a Groot2 log (ours or BT.CPP's), by its first bytes
        from mission.viz.btlog_view import read_btlog_ticks

        log = read_btlog_ticks(args.log)
    elif str(args.log).endswith(".btlog") and Path(args.log).is_file():
        raise MissionError(
            f"{args.log}: not a Groot2 .btlog (it does not start with the log's header); expected a log written by "
            "`mission run --btlog` or BT.CPP's Groot2 file logger"
        )
    else:
        from mission.viz.tick_log import read_log

        log = read_log(args.log)
    if args.tree:
        raise MissionError("give either a tree file or --log, not both")
    if fmt == "html":
        from mission.viz.html import render_page

        root = log.tree()
        if log.ticks:
            from mission.viz.model import apply_tick

            rec = log.record(args.tick) if args.tick is not None else log.ticks[-1]
            apply_tick(root, rec["nodes"])
        page = render_page(
            "playback", root, header=log.header, ticks=log.ticks, tick=args.tick, title=f"{root.name} — {log.path.name}"
        )
        _emit(page, args.output)
        return 0
    tick = args.tick if args.tick is not None else (log.ticks[-1]["tick"] if log.ticks else None)
    if tick is None:
        raise MissionError(f"{log.path}: the log has no ticks")
    rec = log.record(tick)
    root = log.tree_at(tick)
    title = f"{root.name} — tick {tick}, t={rec.get('t') or 0:.1f} s, {rec.get('state') or 'no state'}"
    _draw(root, fmt, args.output, live=True, title=title)
    return 0
