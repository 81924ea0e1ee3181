"""tools/import_graph.py on a package small enough to count by hand: two floors, one cycle between them.

fake            fake/__init__.py
fake.low        low/  (mapped by package-dir, as trees/ … sim/ are)
    a.py        from ..high import b                  → fake.high.b   (the cycle's way up)
    c.py        import fake.low                       → within the floor: not counted
fake.high       fake/high/
    b.py        from fake.low import a, c             → fake.low.a, fake.low.c
    d.py        under TYPE_CHECKING: fake.low.c; in a function: from . import b; sys.path; bench
"""

from __future__ import annotations

from pathlib import Path

import pytest

from tools.import_graph import analyse, find_modules, floor_of, main, strongly_connected

PYPROJECT = """
[tool.setuptools]
packages = ["fake", "fake.low", "fake.high"]

[tool.setuptools.package-dir]
"fake.low" = "low"
"""

FILES = {
    "fake/__init__.py": "",
    "fake/high/__init__.py": "",
    "fake/high/b.py": "from fake.low import a, c\n",
    "fake/high/d.py": (
        "import sys\nfrom typing import TYPE_CHECKING\n\nimport bench.catalogue\n\n"
        "if TYPE_CHECKING:\n    from fake.low import c\n\nsys.path.append('x')\n\n\n"
        "def f():\n    from . import b\n\n    return b\n"
    ),
    "low/__init__.py": "",
    "low/a.py": "from ..high import b\n",
    "low/c.py": "import fake.low\n",
}


@pytest.fixture
def project(tmp_path: Path) -> Path:
    (tmp_path / "pyproject.toml").write_text(PYPROJECT, encoding="utf-8")
    for name, text in FILES.items():
        path = tmp_path / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text, encoding="utf-8")
    return tmp_path / "pyproject.toml"


def test_modules_are_found_at_their_installed_names(project):
    modules = find_modules(project)
    assert set(modules) == {"fake", "fake.high", "fake.high.b", "fake.high.d", "fake.low", "fake.low.a", "fake.low.c"}
    assert modules["fake.low.a"].path == project.parent / "low" / "a.py"
    assert floor_of("fake.low.a") == "fake.low"
    assert floor_of("fake") == "fake"


def test_floor_counts_cycles_and_findings(project):
    data = analyse(project, root="fake")
    assert data["floors"] == {"fake": 1, "fake.high": 3, "fake.low": 3}
    counts = {(r["from"], r["to"]): r["count"] for r in data["floor_edges"]}
    assert counts == {("fake.high", "fake.low"): 2, ("fake.low", "fake.high"): 1}  # c → fake.low is within its floor
    assert [(r["from"], r["to"], r["count"]) for r in data["floor_edges_type_checking"]] == [
        ("fake.high", "fake.low", 1)
    ]
    assert data["edges"] == {"runtime": 5, "type_checking_only": 1, "lazy": 1}  # d → b only inside f()

    [cycle] = data["floor_cycles"]
    assert cycle["floors"] == ["fake.high", "fake.low"]
    assert {(e["from"], e["to"]): e["count"] for e in cycle["edges"]} == counts

    [module_cycle] = data["module_cycles"]
    assert module_cycle["modules"] == ["fake.high.b", "fake.low.a"]
    assert {(e["from"], e["to"]) for e in module_cycle["edges"]} == {
        ("fake.high.b", "fake.low.a"),
        ("fake.low.a", "fake.high.b"),
    }

    assert [(r["module"], r["target"], r["kind"]) for r in data["outside_imports"]] == [
        ("fake.high.d", "bench.catalogue", "top")
    ]
    assert [(r["module"], r["line"]) for r in data["sys_path"]] == [("fake.high.d", 9)]
    assert data["unresolved"] == []


def test_text_output_names_the_cycle(project, capsys):
    assert main(["--pyproject", str(project), "--root", "fake"]) == 0
    out = capsys.readouterr().out
    assert "{fake.high, fake.low}" in out
    assert "fake.low.a → fake.high.b (line 1)" in out


def test_strongly_connected_components():
    pairs = [("a", "b"), ("b", "c"), ("c", "a"), ("c", "d"), ("e", "e")]
    assert strongly_connected("abcdef", pairs) == [["a", "b", "c"], ["e"]]
    assert strongly_connected("ab", [("a", "b")]) == []
