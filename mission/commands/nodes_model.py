"""`mission nodes-model`: Groot2's palette — the TreeNodesModel of every behaviour a run can use.

    mission nodes-model                    # to stdout
    mission nodes-model -o palette.xml     # a models file: Groot2 → "Import models from file"
    mission nodes-model --into patrol.xml  # a tree file of your own, so it opens in Groot2 with ports

The behaviours are the runner's: the shipped ones and every installed package's ``mission.behaviours``
entry points (mission.app.behaviour_plugins). A plugin that fails to load stops the command (a palette
without it would look complete and not be).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from mission.app.behaviour_plugins import register_installed
from mission.core.errors import MissionError
from mission.core.files import atomic_write_text, unwritable
from mission.trees.factory import shipped_factory
from mission.trees.tree_nodes_model import nodes_model_xml, with_nodes_model
from mission.trees.xml_source import parse_file


def main(args: argparse.Namespace) -> int:
    factory = shipped_factory()
    problems = register_installed(factory)
    if problems:
        raise MissionError("\n".join(problems))
    count = len(factory.behaviours())
    if args.into:
        path = Path(args.into)
        root = parse_file(path)  # a missing or malformed file: file:line, before anything is written
        if root.tag != "root":
            raise MissionError(f'{path}: expected a tree file (<root BTCPP_format="4">), found <{root.tag}>')
        _write(path, with_nodes_model(path.read_text(encoding="utf-8"), factory, descriptions=True), "--into")
        print(f"mission: {path}: TreeNodesModel of {count} behaviours", file=sys.stderr)
        return 0
    text = f'<root BTCPP_format="4">\n{nodes_model_xml(factory, "  ", descriptions=True)}</root>\n'
    if args.output:
        _write(Path(args.output), text, "-o")
        print(f"mission: {args.output}: TreeNodesModel of {count} behaviours", file=sys.stderr)
    else:
        sys.stdout.write(text)
    return 0


def _write(path: Path, text: str, option: str) -> None:
    try:
        atomic_write_text(path, text)
    except OSError as err:
        raise MissionError(f"{option} {path}: {unwritable(err, path)}") from None
