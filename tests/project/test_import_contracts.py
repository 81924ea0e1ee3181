"""Floors: who may import whom (docs/architecture.md), as import-linter contracts in pyproject.toml.

    application  mission.app : ros : viz : commands : cli   (may import each other)
    mission.trees
    mission.behaviours | mission.perception_plugins | mission.sim   (independent of each other)
    mission.core                                                    (imports nothing else of ours)

The contracts are checked on a copy of the package in its installed layout (tools/import_contracts.py):
trees/, behaviours/, perception_plugins/ and sim/ live outside mission/ on disk, where import-linter
would not find them. Bad imports are planted in that copy, never in the sources, to show that each kind
of violation fails the check.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from tools.import_contracts import PYPROJECT, declared_packages, import_tree, lint_imports

ROOT = PYPROJECT.parent

FLOORS = "floors, bottom to top (docs/architecture.md)"
CORE = "mission.core imports nothing else of ours"
CORE_ROOT = "mission.core does not import the top-level mission module"


@pytest.fixture
def tree(tmp_path: Path) -> Path:
    """A fresh copy of every listed package at its installed place (tmp/mission/trees/…)."""
    return import_tree(tmp_path)


def plant(tree: Path, module: str, line: str) -> None:
    """Append an import to `module` (dotted name) in the copy."""
    path = tree.joinpath(*module.split(".")).with_suffix(".py")
    assert path.is_file(), f"{module} is not in the copy"
    with path.open("a", encoding="utf-8") as f:
        f.write(f"\n{line}\n")


def contract_lines(output: str) -> dict[str, str]:
    """Contract name → KEPT / BROKEN, from lint-imports' summary."""
    out = {}
    for line in output.splitlines():
        for status in ("KEPT", "BROKEN"):
            if line.endswith(f" {status}"):
                out[line[: -len(status) - 1]] = status
    return out


def test_the_copy_holds_every_listed_package_at_its_installed_place(tree):
    for package in declared_packages():
        assert (tree.joinpath(*package.split(".")) / "__init__.py").is_file(), package
    assert (tree / "mission" / "trees" / "loader.py").is_file()
    assert (tree / "mission" / "sim" / "scene.py").is_file()
    assert (tree / "mission" / "core" / "se3.py").is_file()  # core/ installs as mission.core


def test_the_sources_keep_both_contracts(tree):
    proc = lint_imports(tree)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert contract_lines(proc.stdout) == {FLOORS: "KEPT", CORE: "KEPT", CORE_ROOT: "KEPT"}
    # the graph includes the mapped packages (a walk of mission/ alone would not)
    assert "Analyzed" in proc.stdout


@pytest.mark.parametrize(
    ("module", "line", "broken", "words"),
    [
        # upward: a behaviour reaching into the application
        ("mission.behaviours.leaf", "import mission.app.runner", {FLOORS},
         "mission.behaviours is not allowed to import mission.app"),
        # upward from the middle floor to trees
        ("mission.perception_plugins.registry", "from mission.trees import loader", {FLOORS},
         "mission.perception_plugins is not allowed to import mission.trees"),
        # sideways: the sim knows markers as textures, not as perception plugins
        ("mission.sim.markers", "import mission.perception_plugins.aruco", {FLOORS},
         "mission.sim is not allowed to import mission.perception_plugins"),
        # core importing a floor above it breaks both
        ("mission.core.types", "import mission.viz", {FLOORS, CORE}, "mission.core is not allowed to import"),
        # core importing the top-level module (outside every floor), even from a nested module
        ("mission.core.se3", "import mission", {CORE_ROOT}, "mission.core.se3 is not allowed to import mission"),
        # trees importing the application
        ("mission.trees.loader", "from mission.commands import run", {FLOORS},
         "mission.trees is not allowed to import mission.commands"),
    ],
)  # fmt: skip
def test_a_planted_bad_import_fails_the_check(tree, module, line, broken, words):
    plant(tree, module, line)
    proc = lint_imports(tree)
    assert proc.returncode != 0, proc.stdout
    statuses = contract_lines(proc.stdout)
    assert {name for name, s in statuses.items() if s == "BROKEN"} == broken, proc.stdout
    assert words in proc.stdout
    assert module in proc.stdout, "the report names the importing module"


@pytest.mark.parametrize(
    ("module", "line", "words"),
    [
        # the run floor knows no ROS: bags are recorded by mission.ros.bag_record, an observer from above
        ("mission.app.metrics", "import mission.ros.dds", "mission.app is not allowed to import mission.ros"),
        # run reports are pictures: they live in viz, and the run does not import them
        ("mission.app.runner", "import mission.viz.style", "mission.app is not allowed to import mission.viz"),
        # Groot2's monitor watches runs; it draws nothing
        ("mission.groot.publisher", "import mission.viz.web", "mission.groot is not allowed to import mission.viz"),
        # the ROS node and the sweep are independent programs of the same floor
        ("mission.sweep.task", "import mission.ros.node", "mission.sweep is not allowed to import mission.ros"),
        ("mission.ros.node", "import mission.sweep.engine", "mission.ros is not allowed to import mission.sweep"),
        # no floor imports a verb
        ("mission.viz.run_report", "from mission.commands import run",
         "mission.viz is not allowed to import mission.commands"),
    ],
)  # fmt: skip
def test_an_application_floor_importing_upward_or_sideways_fails_the_check(tree, module, line, words):
    plant(tree, module, line)
    proc = lint_imports(tree)
    assert proc.returncode != 0, proc.stdout
    assert contract_lines(proc.stdout)[FLOORS] == "BROKEN"
    assert words in proc.stdout


def test_each_application_floor_may_import_every_floor_below_it(tree):
    plant(tree, "mission.viz.text", "import mission.app.runner")
    plant(tree, "mission.viz.text", "import mission.groot.btlog")
    plant(tree, "mission.ros.node", "import mission.viz.web")
    plant(tree, "mission.sweep.task", "import mission.viz.run_report")
    plant(tree, "mission.commands.run", "import mission.sweep.engine")
    plant(tree, "mission.trees.loader", "import mission.core.types")
    proc = lint_imports(tree)
    assert proc.returncode == 0, proc.stdout + proc.stderr


def test_no_two_modules_of_the_package_import_each_other_at_run_time():
    """Layers forbid cycles between floors; this forbids them inside one (an import made only for type hints
    is allowed: it never runs)."""
    from tools.import_graph import analyse

    data = analyse()
    assert data["floor_cycles"] == []
    assert data["module_cycles"] == []
    assert data["outside_imports"] == []  # bench/ and tools/ are never installed: the package never imports them


def test_a_new_subpackage_without_a_floor_fails_the_check(tree):
    (tree / "mission" / "extras").mkdir()
    (tree / "mission" / "extras" / "__init__.py").write_text('"""a subpackage nobody placed on a floor"""\n')
    proc = lint_imports(tree)
    assert proc.returncode != 0, proc.stdout
    assert "mission.extras" in proc.stdout + proc.stderr


def test_every_installed_module_is_used_by_the_package_itself():
    """What only tests, bench or tools import does not ship (tools/synthetic_views.py, tools/browser.py): every
    module of the package is reached from an entry point (`mission`, `python -m mission`, a verb, a plugin in
    pyproject.toml's entry points) through the package's own imports, or names itself as a package."""
    import re

    from tools.import_graph import build_graph

    graph = build_graph()
    edges: dict[str, set[str]] = {}
    for (importer, imported), edge in graph.edges.items():
        if edge.runtime:
            edges.setdefault(importer, set()).add(imported)
    pyproject = (ROOT / "pyproject.toml").read_text(encoding="utf-8")
    plugins = set(re.findall(r'^\S+ = "(mission\.[\w.]+):', pyproject, flags=re.MULTILINE))
    verbs = {m for m in graph.modules if m.startswith("mission.commands.")}  # mission.cli imports them by name
    reached: set[str] = set()
    todo = ["mission.cli", "mission.__main__", *verbs, *plugins]
    while todo:
        module = todo.pop()
        if module not in reached:
            reached.add(module)
            todo += edges.get(module, ())
    packages = {m for m, info in graph.modules.items() if info.path.name == "__init__.py"}
    assert sorted(set(graph.modules) - reached - packages) == []
