"""Where a run's result came from: what a report records so the run can be told apart from others and redone.

:func:`run_provenance` gives, as plain JSON-ready data: the resolved config (every default filled in, as
the run used it), the config and tree files (path and SHA-256; the tree's includes too), the perception
plugins the config uses with the entry point and the distribution and version that provide each, the seed,
the Python and the versions of the packages that decide a run's behaviour (mission, py_trees, numpy, OpenCV,
pybullet, pydantic, rclpy). The source commit is recorded when mission runs from a git checkout.

Nothing here fails a run: a package that is not installed is ``None``, a plugin that is not installed has
no distribution, a file that cannot be read has no digest.
"""

from __future__ import annotations

import contextlib
import hashlib
import platform
import subprocess
import sys
from collections.abc import Iterable
from functools import lru_cache
from importlib import metadata
from importlib.util import find_spec
from pathlib import Path
from typing import Any
from xml.etree import ElementTree

from mission.core.config import MissionConfig, SourceConfig
from mission.core.errors import TreeError

# Report key → the distributions that provide it, the usual one first (OpenCV ships as four wheels; the
# contrib ones carry the aruco module), and the module to ask when no distribution is installed (a ROS
# install provides rclpy without pip metadata; OpenCV may be built from source).
KEY_PACKAGES: dict[str, tuple[tuple[str, ...], str]] = {
    "mission": (("mission",), "mission"),
    "py_trees": (("py_trees",), "py_trees"),
    "numpy": (("numpy",), "numpy"),
    "opencv": (
        ("opencv-contrib-python-headless", "opencv-contrib-python", "opencv-python-headless", "opencv-python"),
        "cv2",
    ),
    "pybullet": (("pybullet",), "pybullet"),
    "pydantic": (("pydantic",), "pydantic"),
    "rclpy": (("rclpy",), "rclpy"),
}


def run_provenance(
    config: MissionConfig,
    *,
    tree_file: str | Path,
    seed: int,
    config_file: str | Path | None = None,
    scenario: str | None = None,
) -> dict[str, Any]:
    """What produced a run: `config` as loaded (validated, defaults filled in) from `config_file` (None: the
    built-in defaults), the tree file the runner loaded (``runner.tree_path``), the `seed` and, for a
    simulated run, the `scenario` name."""
    return {
        "config": config.model_dump(mode="json"),
        "config_file": file_record(config_file) if config_file is not None else None,
        "tree_file": tree_record(tree_file),
        "perception_plugins": plugin_records(config.perception.sources),
        "seed": seed,
        "scenario": scenario,
        "python": {
            "version": platform.python_version(),
            "implementation": platform.python_implementation(),
            "executable": sys.executable,
        },
        "platform": platform.platform(),
        "packages": package_versions(),
        "source": source_revision(),
    }


# The packages whose source decides a run's outcome, and the files of theirs that are source.
SOURCE_PACKAGES = ("mission", "mission.behaviours", "mission.trees", "mission.perception_plugins", "mission.sim")
SOURCE_SUFFIXES = (".py", ".xml", ".yaml")


@lru_cache(maxsize=1)
def source_fingerprint() -> str:
    """SHA-256 over the source of the installed mission (every .py, .xml and .yaml of its packages, by path
    within its package): equal when the code that decides a run is the same, whatever commit holds it.

    The commit alone would not do: committing a sweep's finished rows makes a new commit of the same code,
    and a work tree with changes has the commit of other code."""
    roots: list[tuple[str, Path]] = []
    for name in SOURCE_PACKAGES:
        spec = find_spec(name)
        if spec is not None and spec.submodule_search_locations:
            roots += [(name, Path(root)) for root in spec.submodule_search_locations]
    return files_fingerprint(roots)


def files_fingerprint(roots: Iterable[tuple[str, Path]]) -> str:
    """SHA-256 over the source files (SOURCE_SUFFIXES) under each (label, directory): their paths within it,
    under its label, and their bytes."""
    digest = hashlib.sha256()
    for label, base in roots:
        files = sorted(f for f in base.rglob("*") if f.suffix in SOURCE_SUFFIXES and "__pycache__" not in f.parts)
        for f in files:
            digest.update(f"{label}/{f.relative_to(base).as_posix()}\0".encode())
            with contextlib.suppress(OSError):
                digest.update(hashlib.sha256(f.read_bytes()).digest())
    return digest.hexdigest()


def file_record(path: str | Path) -> dict[str, Any]:
    """A file's absolute path and the SHA-256 of its bytes (None when it cannot be read)."""
    p = Path(path)
    try:
        digest: str | None = hashlib.sha256(p.read_bytes()).hexdigest()
    except OSError:
        digest = None
    return {"path": str(p.resolve()), "sha256": digest}


def tree_record(path: str | Path) -> dict[str, Any]:
    """The tree file (a path, or a shipped tree's name), and every file it includes (a change to an include
    changes the tree)."""
    from mission.trees.loader import read_document, resolve_tree_path

    with contextlib.suppress(TreeError):  # gone since the run loaded it: record the path as given
        path = resolve_tree_path(path)
    record = file_record(path)
    try:
        files = read_document(path).files
    except Exception:  # a tree that no longer reads: its own digest says it changed
        files = []
    top = Path(record["path"])
    record["includes"] = [file_record(f) for f in files if Path(f).resolve() != top]
    return record


def plugin_records(sources: Iterable[SourceConfig]) -> list[dict[str, Any]]:
    """Each configured source: its instance name, plugin, entry point and the distribution providing it."""
    from mission.perception_plugins import registry

    out = []
    for source in sources:
        ep = registry.entry_point(source.plugin)
        dist = _distribution_of(ep) if ep is not None else None
        out.append(
            {
                "name": source.name or source.plugin,
                "plugin": source.plugin,
                "entry_point": ep.value if ep is not None else None,
                "distribution": dist.metadata["Name"] if dist is not None else None,
                "version": dist.version if dist is not None else None,
            }
        )
    return out


def _distribution_of(ep: metadata.EntryPoint) -> metadata.Distribution | None:
    dist = getattr(ep, "dist", None)  # set for entry points read from an installed distribution
    if dist is not None:
        return dist  # type: ignore[no-any-return]
    top = ep.value.split(":")[0].split(".")[0]
    for name in metadata.packages_distributions().get(top, []):
        try:
            return metadata.distribution(name)
        except metadata.PackageNotFoundError:
            continue
    return None


def package_versions() -> dict[str, dict[str, str | None] | None]:
    """Report key → {distribution, version} of each key package; None when it is not installed."""
    return {key: _package(dists, module) for key, (dists, module) in KEY_PACKAGES.items()}


def _package(distributions: tuple[str, ...], module: str) -> dict[str, str | None] | None:
    for name in distributions:
        try:
            return {"distribution": name, "version": metadata.version(name)}
        except metadata.PackageNotFoundError:
            continue
    try:
        spec = find_spec(module)
    except (ImportError, ValueError):
        spec = None
    if spec is None:
        return None
    loaded = sys.modules.get(module)  # never imported here just to be asked (rclpy, pybullet are heavy)
    version = getattr(loaded, "__version__", None) or _ros_package_version(spec.origin, module)
    return {"distribution": None, "version": str(version) if version is not None else None}


def _ros_package_version(origin: str | None, name: str) -> str | None:
    """A ROS install's package version: <prefix>/share/<name>/package.xml beside <prefix>/lib/pythonX/…/<name>."""
    if not origin:
        return None
    path = Path(origin)
    prefix = next((p.parent for p in path.parents if p.name == "lib"), None)
    if prefix is None:
        return None
    try:
        version = ElementTree.parse(prefix / "share" / name / "package.xml").getroot().findtext("version")
    except (OSError, ElementTree.ParseError):
        return None
    return version.strip() if version else None


def source_revision() -> dict[str, Any] | None:
    """The git commit mission runs from, and whether the work tree had changes; None outside a git checkout."""
    here = Path(__file__).resolve().parent

    def git(*args: str) -> str | None:
        try:
            proc = subprocess.run(
                ["git", "-C", str(here), *args], capture_output=True, text=True, timeout=5, check=False
            )
        except (OSError, subprocess.SubprocessError):
            return None
        return proc.stdout if proc.returncode == 0 else None

    commit = git("rev-parse", "HEAD")
    if not commit:
        return None
    status = git("status", "--porcelain", "--untracked-files=no")
    return {"commit": commit.strip(), "dirty": bool(status.strip()) if status is not None else None}
