"""The import graph of the installed `mission` package, floor by floor: counted, not imported.

Issue 31 ("The house reads as it runs") closes with the import graph before and after: floor → floor
counts and the cycles between floors. tools/import_contracts.py says whether the floors hold; this says
how much crosses each boundary, and where the package loops on itself, so a refactor can be measured.

The modules are found on disk in their installed layout (the ``package-dir`` mapping of pyproject.toml,
:func:`tools.import_contracts.package_folders`) and parsed with :mod:`ast`, never imported: nothing heavy
(pybullet, rclpy) is loaded and a module that does not import here is still counted. Every import
statement counts — at the top of a module, inside a function (lazy), or under ``if TYPE_CHECKING:``,
which is reported apart since it never runs. Relative imports are resolved. ``from a import b`` is an
edge to ``a.b`` when that is a module, else to ``a`` (as grimp counts them).

A floor is ``mission.core``, ``mission.behaviours``, ``mission.perception_plugins``, ``mission.sim``,
``mission.trees``, and each other first-level name of the package by itself (``mission.app``,
``mission.cli``, ``mission.__main__`` …); ``mission`` alone is the package's ``__init__``. Printed:
floor → floor counts (distinct module → module edges between two floors), cycles between floors (strongly
connected components of the floor graph, with the edges that make them), cycles between modules, and
what an installed module should not do: import ``bench`` or ``tools`` (never installed), touch
``sys.path``, or import by name at run time (``importlib.import_module``), which no static graph sees.

``python -m tools.import_graph`` prints text; ``--json`` the same as one JSON object.
"""

from __future__ import annotations

import argparse
import ast
import json
import re
import sys
from collections import defaultdict
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from tools.import_contracts import PYPROJECT, package_dir, package_folders

ROOT_PACKAGE = "mission"
OUTSIDE = ("bench", "tools")  # top-level folders of the checkout that are never installed
TOP, LAZY, TYPING = "top", "function", "type_checking"  # where an import statement sits
SYS_PATH = re.compile(r"\bsys\.path\b")


@dataclass(frozen=True)
class Module:
    name: str
    path: Path
    is_package: bool  # an __init__.py: relative imports start from the module itself


@dataclass(frozen=True)
class Statement:
    """One imported name of one import statement, as written (relative ones already resolved)."""

    importer: str
    target: str  # dotted name: ``a.b`` for ``import a.b``, ``a`` for ``from a import b``
    names: tuple[str, ...]  # ``b`` for ``from a import b``; empty for ``import a.b``
    line: int
    kind: str  # TOP | LAZY | TYPING


@dataclass
class Edge:
    importer: str
    imported: str
    lines: dict[int, str] = field(default_factory=dict)  # line → kind

    @property
    def kinds(self) -> set[str]:
        return set(self.lines.values())

    @property
    def runtime(self) -> bool:
        """Runs when the importer (or one of its functions) runs: not only under TYPE_CHECKING."""
        return bool(self.kinds - {TYPING})

    @property
    def lazy(self) -> bool:
        """Runtime, but only inside functions: not when the importer is imported."""
        return self.runtime and TOP not in self.kinds


@dataclass
class Graph:
    modules: dict[str, Module]
    edges: dict[tuple[str, str], Edge]
    unresolved: list[Statement]  # ``import mission.x`` where no module mission.x exists
    outside: list[Statement]  # imports of bench / tools
    sys_path: list[tuple[str, int, str]]  # module, line, source line
    dynamic: list[tuple[str, int, str]]  # importlib.import_module / __import__ calls


# --- modules ---------------------------------------------------------------------------------------------


def find_modules(pyproject: Path = PYPROJECT) -> dict[str, Module]:
    """Every module of the installed package, by installed name, from the package folders on disk."""
    modules: dict[str, Module] = {}
    for package in sorted(package_folders(pyproject)):
        for path in sorted(package_dir(package, pyproject).glob("*.py")):
            is_package = path.name == "__init__.py"
            name = package if is_package else f"{package}.{path.stem}"
            modules[name] = Module(name, path, is_package)
    return modules


def floor_of(module: str) -> str:
    """``mission.trees.loader`` → ``mission.trees``; ``mission`` → ``mission``."""
    return ".".join(module.split(".")[:2])


# --- statements ------------------------------------------------------------------------------------------


def _is_type_checking(test: ast.expr) -> bool:
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING"
    )


def _walk(node: ast.AST, kind: str) -> Iterator[tuple[ast.AST, str]]:
    """Every node below `node` with where it sits: TYPING wins over LAZY, LAZY over TOP."""
    for child in ast.iter_child_nodes(node):
        if isinstance(child, ast.If) and _is_type_checking(child.test):
            yield child.test, kind
            for stmt in child.body:
                yield stmt, TYPING
                yield from _walk(stmt, TYPING)
            for stmt in child.orelse:
                yield stmt, kind
                yield from _walk(stmt, kind)
            continue
        inner = kind
        if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda)) and kind == TOP:
            inner = LAZY
        yield child, inner
        yield from _walk(child, inner)


def _resolve_relative(module: Module, level: int, name: str | None) -> str | None:
    base = module.name.split(".") if module.is_package else module.name.split(".")[:-1]
    if level - 1 > len(base) - 1:
        return None  # beyond the top package
    parts = base[: len(base) - (level - 1)]
    if name:
        parts += name.split(".")
    return ".".join(parts)


def statements(module: Module) -> tuple[list[Statement], list[tuple[str, int, str]]]:
    """The import statements of `module` (every name of each), and its run-time imports by name."""
    source = module.path.read_text(encoding="utf-8")
    tree = ast.parse(source, filename=str(module.path))
    found: list[Statement] = []
    dynamic: list[tuple[str, int, str]] = []
    lines = source.splitlines()
    for node, kind in _walk(tree, TOP):
        if isinstance(node, ast.Import):
            found += [Statement(module.name, a.name, (), node.lineno, kind) for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            target = node.module if node.level == 0 else _resolve_relative(module, node.level, node.module)
            if target is None:
                continue
            found.append(Statement(module.name, target, tuple(a.name for a in node.names), node.lineno, kind))
        elif isinstance(node, ast.Call):
            func = node.func
            called = func.attr if isinstance(func, ast.Attribute) else func.id if isinstance(func, ast.Name) else ""
            if called in ("import_module", "__import__"):
                dynamic.append((module.name, node.lineno, lines[node.lineno - 1].strip()))
    return found, dynamic


def _longest_module(name: str, modules: dict[str, Module]) -> str | None:
    parts = name.split(".")
    for n in range(len(parts), 0, -1):
        candidate = ".".join(parts[:n])
        if candidate in modules:
            return candidate
    return None


def targets(stmt: Statement, modules: dict[str, Module]) -> list[str]:
    """The modules of the package `stmt` imports: ``a.b`` for ``from a import b`` when that is a module,
    else the nearest existing module named by the target."""
    out: list[str] = []
    rest = False
    for name in stmt.names:
        full = f"{stmt.target}.{name}"
        if name != "*" and full in modules:
            out.append(full)
        else:
            rest = True
    if not stmt.names or rest:
        found = _longest_module(stmt.target, modules)
        if found is not None:
            out.append(found)
    return out


def build_graph(pyproject: Path = PYPROJECT, root: str = ROOT_PACKAGE) -> Graph:
    modules = find_modules(pyproject)
    graph = Graph(modules, {}, [], [], [], [])
    for module in modules.values():
        found, dynamic = statements(module)
        graph.dynamic += dynamic
        for number, text in enumerate(module.path.read_text(encoding="utf-8").splitlines(), start=1):
            if SYS_PATH.search(text):
                graph.sys_path.append((module.name, number, text.strip()))
        for stmt in found:
            top = stmt.target.split(".")[0]
            if top in OUTSIDE:
                graph.outside.append(stmt)
            if top != root:
                continue
            if stmt.target not in modules:
                graph.unresolved.append(stmt)
            for imported in targets(stmt, modules):
                if imported == stmt.importer:
                    continue
                edge = graph.edges.setdefault((stmt.importer, imported), Edge(stmt.importer, imported))
                edge.lines[stmt.line] = stmt.kind
    return graph


# --- floors and cycles -----------------------------------------------------------------------------------


def strongly_connected(nodes: Iterable[str], pairs: Iterable[tuple[str, str]]) -> list[list[str]]:
    """Tarjan's strongly connected components of size > 1 (or with a self-loop), each sorted, sorted."""
    succ: dict[str, list[str]] = defaultdict(list)
    loops: set[str] = set()
    for a, b in pairs:
        succ[a].append(b)
        if a == b:
            loops.add(a)
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    out: list[list[str]] = []
    for start in sorted(set(nodes)):
        if start in index:
            continue
        work: list[tuple[str, Iterator[str]]] = [(start, iter(sorted(succ[start])))]
        index[start] = low[start] = len(index)
        stack.append(start)
        on_stack.add(start)
        while work:
            node, children = work[-1]
            for child in children:
                if child not in index:
                    index[child] = low[child] = len(index)
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(sorted(succ[child]))))
                    break
                if child in on_stack:
                    low[node] = min(low[node], index[child])
            else:
                work.pop()
                if work:
                    low[work[-1][0]] = min(low[work[-1][0]], low[node])
                if low[node] == index[node]:
                    component = []
                    while True:
                        member = stack.pop()
                        on_stack.discard(member)
                        component.append(member)
                        if member == node:
                            break
                    if len(component) > 1 or node in loops:
                        out.append(sorted(component))
    return sorted(out)


def select(graph: Graph, runtime: bool) -> list[Edge]:
    """The runtime edges, or the TYPE_CHECKING-only ones (runtime=False)."""
    return [e for _, e in sorted(graph.edges.items()) if e.runtime == runtime]


def floor_counts(edges: Iterable[Edge]) -> dict[tuple[str, str], list[Edge]]:
    """(floor, floor) → the module edges between two distinct floors."""
    out: dict[tuple[str, str], list[Edge]] = defaultdict(list)
    for e in edges:
        a, b = floor_of(e.importer), floor_of(e.imported)
        if a != b:
            out[(a, b)].append(e)
    return dict(sorted(out.items()))


def floor_cycles(edges: list[Edge], floors: list[str]) -> list[dict[str, Any]]:
    by_floor = floor_counts(edges)
    out = []
    for component in strongly_connected(floors, by_floor):
        inside = {pair: es for pair, es in by_floor.items() if pair[0] in component and pair[1] in component}
        out.append({"floors": component, "edges": inside})
    return out


def module_cycles(edges: list[Edge], modules: Iterable[str]) -> list[dict[str, Any]]:
    pairs = [(e.importer, e.imported) for e in edges]
    out = []
    for component in strongly_connected(modules, pairs):
        members = set(component)
        inside = [e for e in edges if e.importer in members and e.imported in members]
        out.append({"modules": component, "edges": inside})
    return out


def analyse(pyproject: Path = PYPROJECT, root: str = ROOT_PACKAGE) -> dict[str, Any]:
    """Everything printed, as plain data (what ``--json`` writes)."""
    graph = build_graph(pyproject, root)
    runtime, typing_only = select(graph, True), select(graph, False)
    every = runtime + typing_only
    floors = sorted({floor_of(m) for m in graph.modules})

    def edge(e: Edge) -> dict[str, Any]:
        return {"from": e.importer, "to": e.imported, "lines": sorted(e.lines), "kinds": sorted(e.kinds)}

    def counts(by_floor: dict[tuple[str, str], list[Edge]]) -> list[dict[str, Any]]:
        return [
            {"from": a, "to": b, "count": len(es), "lazy": sum(e.lazy for e in es)} for (a, b), es in by_floor.items()
        ]

    def floor_cycle_data(cycles: list[dict[str, Any]]) -> list[dict[str, Any]]:
        return [
            {
                "floors": c["floors"],
                "edges": [
                    {"from": a, "to": b, "count": len(es), "modules": [edge(e) for e in es]}
                    for (a, b), es in c["edges"].items()
                ],
            }
            for c in cycles
        ]

    def module_cycle_data(cycles: list[dict[str, Any]]) -> list[dict[str, Any]]:
        return [{"modules": c["modules"], "edges": [edge(e) for e in c["edges"]]} for c in cycles]

    def stmt(s: Statement) -> dict[str, Any]:
        return {"module": s.importer, "line": s.line, "target": s.target, "names": list(s.names), "kind": s.kind}

    return {
        "root": root,
        "modules": len(graph.modules),
        "floors": {f: sum(floor_of(m) == f for m in graph.modules) for f in floors},
        "edges": {
            "runtime": len(runtime),
            "type_checking_only": len(typing_only),
            "lazy": sum(e.lazy for e in runtime),
        },
        "floor_edges": counts(floor_counts(runtime)),
        "floor_edges_type_checking": counts(floor_counts(typing_only)),
        "floor_cycles": floor_cycle_data(floor_cycles(runtime, floors)),
        "floor_cycles_with_type_checking": floor_cycle_data(floor_cycles(every, floors)),
        "module_cycles": module_cycle_data(module_cycles(runtime, graph.modules)),
        "module_cycles_with_type_checking": module_cycle_data(module_cycles(every, graph.modules)),
        "outside_imports": [stmt(s) for s in graph.outside],
        "sys_path": [{"module": m, "line": n, "text": t} for m, n, t in graph.sys_path],
        "dynamic_imports": [{"module": m, "line": n, "text": t} for m, n, t in graph.dynamic],
        "unresolved": [stmt(s) for s in graph.unresolved],
    }


# --- text ------------------------------------------------------------------------------------------------


def _table(rows: list[dict[str, Any]]) -> list[str]:
    if not rows:
        return ["  (none)"]
    width = max(len(r["from"]) for r in rows)
    to_width = max(len(r["to"]) for r in rows)
    out = []
    for r in rows:
        lazy = f"  ({r['lazy']} only in functions)" if r["lazy"] else ""
        out.append(f"  {r['from']:<{width}} → {r['to']:<{to_width}} {r['count']:>4}{lazy}")
    out.append(f"  {'total':<{width + to_width + 3}} {sum(r['count'] for r in rows):>4}")
    return out


def _where(e: dict[str, Any]) -> str:
    kinds = "" if e["kinds"] == [TOP] else f" [{', '.join(e['kinds'])}]"
    return f"{e['from']} → {e['to']} (line {', '.join(map(str, e['lines']))}){kinds}"


def _floor_cycles(cycles: list[dict[str, Any]]) -> list[str]:
    if not cycles:
        return ["  0"]
    out = [f"  {len(cycles)}"]
    for c in cycles:
        out.append(f"  {{{', '.join(c['floors'])}}}")
        for fe in c["edges"]:
            out.append(f"    {fe['from']} → {fe['to']}: {fe['count']}")
            out += [f"      {_where(e)}" for e in fe["modules"]]
    return out


def _module_cycles(cycles: list[dict[str, Any]]) -> list[str]:
    if not cycles:
        return ["  0"]
    out = [f"  {len(cycles)}"]
    for c in cycles:
        out.append(f"  {{{', '.join(c['modules'])}}}")
        out += [f"    {_where(e)}" for e in c["edges"]]
    return out


def _findings(rows: list[dict[str, Any]], with_target: bool = False) -> list[str]:
    if not rows:
        return ["  (none)"]
    out = []
    for r in rows:
        if with_target:
            names = f" import {', '.join(r['names'])}" if r["names"] else ""
            what = f"{'from ' if r['names'] else 'import '}{r['target']}{names} [{r['kind']}]"
        else:
            what = r["text"]
        out.append(f"  {r['module']}:{r['line']}: {what}")
    return out


def render(data: dict[str, Any]) -> str:
    e = data["edges"]
    lines = [
        f"import graph of {data['root']}: {data['modules']} modules, {len(data['floors'])} floors, "
        f"{e['runtime']} module edges at run time ({e['lazy']} only inside functions), "
        f"{e['type_checking_only']} only under TYPE_CHECKING",
        "",
        "floors (modules): " + ", ".join(f"{f} ({n})" for f, n in data["floors"].items()),
        "",
        "(1) floor → floor: module edges between distinct floors, at run time",
        *_table(data["floor_edges"]),
        "",
        "    … and only under TYPE_CHECKING (not counted above)",
        *_table(data["floor_edges_type_checking"]),
        "",
        "(2) cycles between floors (run time)",
        *_floor_cycles(data["floor_cycles"]),
    ]
    if data["floor_cycles_with_type_checking"] != data["floor_cycles"]:
        lines += ["    … counting TYPE_CHECKING edges too", *_floor_cycles(data["floor_cycles_with_type_checking"])]
    lines += ["", "(3) cycles between modules (run time)", *_module_cycles(data["module_cycles"])]
    if data["module_cycles_with_type_checking"] != data["module_cycles"]:
        lines += ["    … counting TYPE_CHECKING edges too", *_module_cycles(data["module_cycles_with_type_checking"])]
    lines += [
        "",
        "(4) in installed modules",
        "  imports of bench / tools (never installed):",
        *[f"  {x}" for x in _findings(data["outside_imports"], with_target=True)],
        "  sys.path:",
        *[f"  {x}" for x in _findings(data["sys_path"])],
        "  imports by name at run time (not in the graph above):",
        *[f"  {x}" for x in _findings(data["dynamic_imports"])],
    ]
    if data["unresolved"]:
        lines += [
            "  imports of the package naming no module:",
            *[f"  {x}" for x in _findings(data["unresolved"], True)],
        ]
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m tools.import_graph", description=__doc__.split("\n")[0])
    parser.add_argument("--json", action="store_true", help="print one JSON object instead of text")
    parser.add_argument("--pyproject", type=Path, default=PYPROJECT, help="the project's pyproject.toml")
    parser.add_argument("--root", default=ROOT_PACKAGE, help="the top package (default: %(default)s)")
    args = parser.parse_args(argv)
    data = analyse(args.pyproject, args.root)
    sys.stdout.write(json.dumps(data, indent=2) + "\n" if args.json else render(data))
    return 0


if __name__ == "__main__":
    sys.exit(main())
