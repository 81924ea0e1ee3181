"""The installed layout of `mission`, rebuilt from pyproject.toml, and the import contracts checked on it.

pyproject.toml installs the top-level folders trees/, behaviours/, perception_plugins/ and sim/ as
``mission.trees`` … ``mission.sim`` (setuptools ``package-dir``). On disk they are not inside mission/,
so a tool that finds subpackages by walking ``mission/`` — import-linter's grimp does — sees only half
of the package, and the editable install resolves the rest with a meta-path finder grimp never asks.

:func:`import_tree` copies every listed package's ``*.py`` files to where the wheel puts them
(``DEST/mission/trees/loader.py`` …); :func:`lint_imports` runs ``lint-imports`` with the
``[tool.importlinter]`` contracts of pyproject.toml on that copy. ``python -m tools.import_contracts``
does both (tests/project/test_import_contracts.py runs it). The copy is also where a test may plant a bad
import without touching the sources.

:func:`declared_packages` and :func:`package_folders` are the two sides of "every package folder is
listed in pyproject.toml" (tests/project/test_wheel_install.py).
"""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib

ROOT = Path(__file__).resolve().parents[1]
PYPROJECT = ROOT / "pyproject.toml"
SKIP_DIRS = {"__pycache__"}


def setuptools_table(pyproject: Path = PYPROJECT) -> dict[str, Any]:
    """pyproject.toml's ``[tool.setuptools]`` (packages, package-dir, package-data)."""
    return tomllib.loads(pyproject.read_text(encoding="utf-8"))["tool"]["setuptools"]


def declared_packages(pyproject: Path = PYPROJECT) -> list[str]:
    """The explicit ``packages`` list: what the wheel contains."""
    return list(setuptools_table(pyproject)["packages"])


def package_dir(package: str, pyproject: Path = PYPROJECT) -> Path:
    """The folder setuptools takes `package` from: its nearest mapped ancestor in ``package-dir`` (or the
    project root, as setuptools does when nothing is mapped), then one folder per remaining name."""
    mapping: dict[str, str] = setuptools_table(pyproject).get("package-dir", {})
    root = pyproject.parent
    parts = package.split(".")
    for n in range(len(parts), -1, -1):
        prefix = ".".join(parts[:n])
        if prefix in mapping:
            return root.joinpath(mapping[prefix], *parts[n:])
    return root.joinpath(*parts)


def mapped_roots(pyproject: Path = PYPROJECT) -> dict[str, Path]:
    """Each top of an installed tree → its folder: the packages mapped in ``package-dir`` plus the
    top-level packages of the list (``mission`` → mission/, ``mission.sim`` → sim/ …)."""
    table = setuptools_table(pyproject)
    names = set(table.get("package-dir", {})) - {""}
    names |= {p for p in table["packages"] if "." not in p}
    return {name: package_dir(name, pyproject) for name in sorted(names)}


def package_folders(pyproject: Path = PYPROJECT) -> set[str]:
    """Every package on disk under the mapped roots, by installed name: a folder with ``__init__.py``
    whose parents up to the root are packages too (as setuptools' find_packages walks)."""
    found: set[str] = set()
    for name, folder in mapped_roots(pyproject).items():
        if not (folder / "__init__.py").is_file():
            continue
        for dirpath, dirnames, _files in os.walk(folder):
            here = Path(dirpath)
            dirnames[:] = sorted(d for d in dirnames if d not in SKIP_DIRS and (here / d / "__init__.py").is_file())
            rel = here.relative_to(folder).parts
            found.add(".".join((name, *rel)))
    return found


def import_tree(dest: Path, pyproject: Path = PYPROJECT) -> Path:
    """Copy every listed package's modules to their installed place under `dest`; returns `dest`.

    Only ``*.py`` files: the import graph needs nothing else. Subfolders that are packages are copied by
    their own entry in the list, so a package missing from the list is missing here too.
    """
    for package in declared_packages(pyproject):
        src = package_dir(package, pyproject)
        out = dest.joinpath(*package.split("."))
        out.mkdir(parents=True, exist_ok=True)
        for module in sorted(src.glob("*.py")):
            shutil.copy2(module, out / module.name)
    return dest


def lint_imports(tree: Path, pyproject: Path = PYPROJECT) -> subprocess.CompletedProcess[str]:
    """Run ``lint-imports`` (this interpreter's) with `pyproject`'s contracts on the copy at `tree`.

    `pyproject` is copied beside the packages, where lint-imports looks for its configuration. The copy
    comes first on the import path (cwd and PYTHONPATH), ahead of the editable install's meta-path
    finder, and the cache is off: the graph is built from these files every time.
    """
    shutil.copy2(pyproject, tree / "pyproject.toml")  # found in cwd by every import-linter 2.x
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    env["PYTHONPATH"] = str(tree)
    exe = Path(sys.executable).with_name("lint-imports")
    return subprocess.run(
        [str(exe), "--no-cache"], cwd=tree, env=env, capture_output=True, text=True, check=False, timeout=300
    )


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m tools.import_contracts", description=__doc__.split("\n")[0])
    parser.add_argument("--keep", metavar="DIR", default=None, help="build the copy in DIR and keep it")
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory(prefix="mission-imports-") as tmp:
        tree = import_tree(Path(args.keep) if args.keep else Path(tmp))
        proc = lint_imports(tree)
    sys.stdout.write(proc.stdout)
    sys.stderr.write(proc.stderr)
    return proc.returncode


if __name__ == "__main__":
    sys.exit(main())
