"""Finding the interface packages PyPI lacks — ``tf2_msgs`` (/tf) and ``nav2_msgs`` (navigate_to_pose,
behavior_tree_log) — on a robot they are installed; here scripts/build_ros builds them into ``install/``.

On a ROS machine they are on the Python path already (``source /opt/ros/jazzy/setup.bash``). Either way a
message package needs its C type-support libraries, which rclpy's middleware opens **by name**; the dynamic
loader only looks them up on LD_LIBRARY_PATH as it was when the process started. Loading them by absolute
path first (RTLD_GLOBAL) makes the later by-name open find them, so the node works whether or not the
workspace's setup script was sourced.
"""

from __future__ import annotations

import ctypes
import importlib
import os
import sys
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType

REPO_INSTALL = Path(__file__).resolve().parents[2] / "install"


@dataclass(frozen=True)
class TfSupport:
    """The TFMessage class when /tf can be published, else None and why not."""

    message: type | None
    detail: str


@dataclass(frozen=True)
class Interfaces:
    """An interface package's Python modules (``msg``, ``action``) when it imports, else why not."""

    package: str
    modules: dict[str, ModuleType]
    detail: str

    @property
    def ok(self) -> bool:
        return bool(self.modules)

    def get(self, kind: str, name: str) -> type:
        return getattr(self.modules[kind], name)


def _site_packages(prefix: Path) -> Path:
    return prefix / "lib" / f"python{sys.version_info[0]}.{sys.version_info[1]}" / "site-packages"


def _candidate_prefixes(package: str) -> list[Path]:
    out = [Path(p) for p in os.environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep) if p]
    out.append(REPO_INSTALL / package)
    return out


def _preload(prefix: Path, package: str) -> None:
    libs = sorted((prefix / "lib").glob(f"lib{package}__*.so"))
    # generator_c first: the type-support libraries link against it.
    libs.sort(key=lambda p: (0 if "generator_c" in p.name else 1, p.name))
    for lib in libs:
        ctypes.CDLL(str(lib), mode=ctypes.RTLD_GLOBAL)


def load_interfaces(package: str, kinds: tuple[str, ...] = ("msg",)) -> Interfaces:
    """Import ``<package>.<kind>`` for each kind, from the environment or the repo's colcon install."""
    first = f"{package}.{kinds[0]}"
    try:
        mod = importlib.import_module(first)
    except ImportError:
        mod = None
        for prefix in _candidate_prefixes(package):
            site = _site_packages(prefix)
            if (site / package / "__init__.py").is_file():
                if str(site) not in sys.path:
                    sys.path.append(str(site))
                importlib.invalidate_caches()
                try:
                    mod = importlib.import_module(first)
                except ImportError as err:
                    return Interfaces(package, {}, f"{package} under {prefix} does not import: {err}")
                break
        if mod is None:
            why = "is not importable (run scripts/build_ros, or source a ROS install)"
            return Interfaces(package, {}, f"{package} {why}")
    # <prefix>/lib/pythonX.Y/site-packages/<pkg>/<kind>/__init__.py; not resolve(): a symlink install points into build/
    prefix = Path(os.path.abspath(mod.__file__)).parents[5]
    try:
        _preload(prefix, package)
        modules = {kind: importlib.import_module(f"{package}.{kind}") for kind in kinds}
    except (OSError, ImportError) as err:
        return Interfaces(package, {}, f"{package} libraries under {prefix / 'lib'} do not load: {err}")
    return Interfaces(package, modules, f"{package} from {prefix}")


def load_tf_message() -> TfSupport:
    """tf2_msgs.msg.TFMessage from the environment or the repo's colcon install."""
    tf = load_interfaces("tf2_msgs")
    return TfSupport(tf.get("msg", "TFMessage") if tf.ok else None, tf.detail)


def load_nav2() -> Interfaces:
    """nav2_msgs (msg: BehaviorTreeLog, BehaviorTreeStatusChange; action: NavigateToPose)."""
    return load_interfaces("nav2_msgs", ("msg", "action"))
