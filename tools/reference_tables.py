"""The documentation's reference tables, generated from the code that defines them.

Config keys, plugin params, scenario keys, ROS parameters, behaviours and CLI flags are declared once
(pydantic models, the ROS parameter table, each behaviour's ``Params``, the argparse parser); this module
renders them as markdown between ``<!-- reference:NAME -->`` … ``<!-- /reference:NAME -->`` markers so
the docs cannot drift from the code. ``python -m tools.reference_tables`` rewrites every page under docs/
(and README.md) that holds a marker; ``--check`` only reports (a test runs it).

A field's description is its trailing ``# comment`` in the model's source — the comment a developer
reads is the one a user reads.
"""

from __future__ import annotations

import argparse
import inspect
import re
import sys
import typing
from collections.abc import Callable
from pathlib import Path
from typing import Any

from pydantic import BaseModel
from pydantic_core import PydanticUndefined

from mission.core.files import atomic_write_text

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
DOCS = ROOT / "docs"


def pages() -> list[Path]:
    """The README and every documentation page, in a stable order."""
    return [README, *sorted(DOCS.rglob("*.md"))]


_BLOCK = re.compile(r"(<!-- reference:(?P<name>[\w-]+) -->\n).*?(<!-- /reference:(?P=name) -->)", re.S)
_FIELD_COMMENT = re.compile(r"^\s+(\w+)\s*:[^#\n]*#\s*(.+?)\s*$")


def _comments(model: type[BaseModel]) -> dict[str, str]:
    """field name → trailing comment on its line in the class source (the model's own documentation)."""
    try:
        source = inspect.getsource(model)
    except (OSError, TypeError):
        return {}
    out: dict[str, str] = {}
    for line in source.splitlines():
        m = _FIELD_COMMENT.match(line)
        if m and m.group(1) in model.model_fields and m.group(1) not in out:
            out[m.group(1)] = m.group(2).removeprefix("noqa").strip()
    return out


def _submodel(annotation: Any) -> type[BaseModel] | None:
    for a in (annotation, *typing.get_args(annotation)):
        if isinstance(a, type) and issubclass(a, BaseModel):
            return a
    return None


def _type_name(annotation: Any) -> str:
    if typing.get_origin(annotation) is typing.Literal:
        return " \\| ".join(repr(a) for a in typing.get_args(annotation))
    args = typing.get_args(annotation)
    if any(typing.get_origin(a) is typing.Literal for a in args):  # an optional choice: its choices, then None
        return " \\| ".join("None" if a is type(None) else _type_name(a) for a in args)
    text = getattr(annotation, "__name__", None) if not typing.get_args(annotation) else None
    text = text or str(annotation).replace("typing.", "")
    return re.sub(r"\b[\w.]+\.(\w+)", r"\1", text).replace("|", "\\|")


class _ModelDefault:
    """A sub-model default shown as ``Marker(face='left')``: only what differs from that model's own table."""

    def __init__(self, value: BaseModel) -> None:
        self.value = value

    def __repr__(self) -> str:
        fields = self.value.model_dump(exclude_defaults=True)
        return f"{type(self.value).__name__}({', '.join(f'{k}={v!r}' for k, v in fields.items())})"


def _plain(value: Any) -> Any:
    if isinstance(value, BaseModel):
        return _ModelDefault(value)
    if isinstance(value, list | tuple):
        return type(value)(_plain(v) for v in value)
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    return value


def _default(field: Any) -> str:
    if field.default is PydanticUndefined and field.default_factory is None:
        return "*required*"
    value = _plain(field.get_default(call_default_factory=True))
    return f"`{value!r}`".replace("|", "\\|")


def model_rows(model: type[BaseModel], prefix: str = "") -> list[tuple[str, str, str, str]]:
    """(dotted key, type, default, meaning) for every field, descending into nested sections."""
    rows: list[tuple[str, str, str, str]] = []
    notes = _comments(model)
    for name, field in model.model_fields.items():
        key = prefix + name
        sub = _submodel(field.annotation)
        is_list = typing.get_origin(field.annotation) in (list, dict) or isinstance(field.default, list | dict)
        if sub is not None and not is_list:
            doc = (sub.__doc__ or "").strip().splitlines()
            rows.append((key, "section", "", notes.get(name) or (doc[0] if doc else "")))
            rows.extend(model_rows(sub, key + "."))
        else:
            rows.append((key, _type_name(field.annotation), _default(field), notes.get(name, "")))
    return rows


def _table(header: tuple[str, ...], rows: list[tuple[str, ...]]) -> str:
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(cell.replace("\n", " ") for cell in row) + " |" for row in rows]
    return "\n".join(lines) + "\n"


def model_table(model: type[BaseModel], prefix: str = "") -> str:
    rows = [(f"`{k}`", t, d, m) for k, t, d, m in model_rows(model, prefix)]
    return _table(("key", "type", "default", "meaning"), rows)


# -- the blocks ----------------------------------------------------------------------------------------
def config_block() -> str:
    from mission.core.config import MissionConfig, SourceConfig, TargetSpec

    return (
        model_table(MissionConfig)
        + "\nEach entry of `perception.sources`:\n\n"
        + model_table(SourceConfig)
        + "\nEach value of `perception.targets` (unset fields match anything):\n\n"
        + model_table(TargetSpec)
    )


def plugins_block() -> str:
    """One section per plugin class: names registered for the same class (a source kept under its old
    name for existing configs) share it, so its params table is not printed twice."""
    from mission.perception_plugins import registry

    names_of: dict[str, list[str]] = {}  # "module:Class" → its entry-point names, sorted
    for info in registry.describe():
        names_of.setdefault(info.target, []).append(info.name)
    parts = []
    for name, *aliases in names_of.values():
        cls = registry.load_class(name)
        params = _params_model(cls)
        also = f" (also `{'`, `'.join(aliases)}`: the same source)" if aliases else ""
        parts.append(f"#### `{name}`{also}\n\n{getattr(cls, 'description', '')}\n\n")
        parts.append(model_table(params) if params is not None else "(no params)\n")
        parts.append("\n")
    return "".join(parts).rstrip("\n") + "\n"


def _params_model(cls: type) -> type[BaseModel] | None:
    module = sys.modules[cls.__module__]
    models = [
        v
        for k, v in vars(module).items()
        if k.endswith("Params") and isinstance(v, type) and issubclass(v, BaseModel) and v.__module__ == module.__name__
    ]
    return models[0] if len(models) == 1 else None


def scenario_block() -> str:
    from mission.sim import scenario as sc

    items = []
    lists = (
        ("Each of `obstacles` / `unknown_obstacles`", sc.Obstacle),
        ("Each of `target.markers`", sc.Marker),
        ("Each of `target.waypoints`", sc.Waypoint),
    )
    for label, model in lists:
        items.append(f"\n{label}:\n\n" + model_table(model))
    return model_table(sc.Scenario) + "".join(items)


def ros_block() -> str:
    from mission.ros.node import PARAMETERS

    return _table(
        ("parameter", "default", "meaning"), [(f"`{k}`", f"`{d!r}`", doc) for k, (d, doc) in PARAMETERS.items()]
    )


def behaviours_block() -> str:
    from mission.trees.factory import shipped_factory

    rows = []
    for node in shipped_factory().behaviours():
        cells = [_port_cell(n, p) + (f" — {p.doc}" if p.doc else "") for n, p in node.ports.items()]
        rows.append((f"`{node.tag}`", node.kind, "<br>".join(cells) or "—", node.doc))
    return _table(("tag", "type", "ports (type = default — meaning)", "what it does"), rows)


def _port_cell(name: str, port: Any) -> str:
    if port.direction == "output":
        return f"`{name}`: {port.type_name} (output)"
    return f"`{name}`: {port.type_name} = " + ("*required*" if port.required else f"`{port.default!r}`")


def builtins_block() -> str:
    """BT.CPP's node library as this loader has it (trees/builtins.py)."""
    from mission.trees.builtins import BUILTINS

    rows = [
        (f"`{m.tag}`", m.kind, "<br>".join(_port_cell(n, p) for n, p in m.ports.items()) or "—", m.doc)
        for m in BUILTINS.values()
    ]
    return _table(("node", "kind", "ports", "what it does"), rows)


def blackboard_block() -> str:
    """The mission's blackboard keys with the names tree files use for them (trees/scopes.py)."""
    from mission.core import blackboard as bbk
    from mission.trees.scopes import bt_name

    def cell(text: str) -> str:
        return text.replace("|", "\\|")

    rows = [(f"`{k.path}`", f"`{bt_name(k)}`", cell(k.type), cell(k.doc)) for k in bbk.ALL_KEYS]
    return _table(("py_trees key", "in a tree file", "holds", "meaning"), rows)


def _arguments_table(p: argparse.ArgumentParser) -> str | None:
    """A parser's arguments as a markdown table (its sub-commands are not rows: they get their own tables)."""
    rows = []
    for action in p._actions:
        if isinstance(action, argparse._HelpAction | argparse._SubParsersAction):
            continue
        flag = ", ".join(action.option_strings) or action.metavar or action.dest
        if action.option_strings and action.nargs != 0:
            metavar = action.metavar or action.dest.upper()
            value = " ".join(metavar) if isinstance(metavar, tuple) else metavar  # nargs=2: "A B"
            flag += f" [{value}]" if action.nargs == "?" else f" {value}"  # an optional value, as --help shows it
        default = "" if action.default in (None, False, argparse.SUPPRESS, []) else f"`{action.default}`"
        rows.append((f"`{flag}`", default, (action.help or "").replace("|", "\\|")))
    return _table(("argument", "default", "meaning"), rows) if rows else None


def cli_block() -> str:
    from bench.command import build_parser as bench_parser
    from mission.cli import FORWARDING, VERBS, build_parser

    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    forwarded_to = {"bench": bench_parser()}  # `mission bench` hands its arguments to `python -m bench`
    assert set(forwarded_to) == FORWARDING
    parts = []
    for verb, help_text in VERBS.items():
        p = forwarded_to.get(verb) or sub.choices[verb]
        parts.append(f"#### `mission {verb}` — {help_text}\n\n")
        table = _arguments_table(p)
        nested = next((a for a in p._actions if isinstance(a, argparse._SubParsersAction)), None)
        if table or nested is None:
            parts.append(table or "(no arguments)\n")
        if nested is not None:  # `mission task dock|undock|follow`: a heading and a table per sub-command
            helps = {a.dest: a.help for a in nested._choices_actions}
            blocks = [
                f"##### `mission {verb} {name}` — {helps.get(name, '')}\n\n"
                + (_arguments_table(child) or "(no arguments)\n")
                for name, child in nested.choices.items()
            ]
            parts.append(("\n" if table else "") + "\n".join(blocks))
        if p.epilog:
            parts.append(f"\n{p.epilog}\n")
        parts.append("\n")
    return "".join(parts).rstrip("\n") + "\n"


BLOCKS: dict[str, Callable[[], str]] = {
    "cli": cli_block,
    "config": config_block,
    "plugins": plugins_block,
    "scenario": scenario_block,
    "behaviours": behaviours_block,
    "builtins": builtins_block,
    "blackboard": blackboard_block,
    "ros-parameters": ros_block,
}


def render(text: str) -> str:
    """`text` with every reference block regenerated (unknown block names are an error)."""

    def fill(m: re.Match[str]) -> str:
        name = m.group("name")
        if name not in BLOCKS:
            raise KeyError(f"unknown reference block {name!r}; known: {', '.join(BLOCKS)}")
        return m.group(1) + "\n" + BLOCKS[name]() + "\n" + m.group(3)

    return _BLOCK.sub(fill, text)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description="Regenerate the docs' reference tables from the code.")
    parser.add_argument("--check", action="store_true", help="report stale pages, change nothing (exit 1)")
    parser.add_argument("paths", nargs="*", help="pages to regenerate (default: README.md and docs/**/*.md)")
    args = parser.parse_args(argv)
    stale = 0
    for path in [Path(p) for p in args.paths] or pages():
        text = path.read_text(encoding="utf-8")
        new = render(text)
        if new == text:
            continue
        if args.check:
            print(f"{path}: reference tables are stale; run `python -m tools.reference_tables`", file=sys.stderr)
            stale += 1
            continue
        atomic_write_text(path, new)  # never left half-written
        print(f"{path}: reference tables regenerated")
    return 1 if stale else 0


if __name__ == "__main__":
    sys.exit(main())
