"""Finding ``tf2_msgs`` so the node can publish ``/tf`` — on a robot it is installed; here it is built.

tf2_msgs is not on PyPI. On a ROS machine it is on the Python path already (``source
/opt/ros/jazzy/setup.bash``). In this repo ``scripts/build_ros`` builds it into ``install/tf2_msgs``.
Either way a message package needs its C type-support libraries, which rclpy's middleware opens **by
name**; the dynamic loader only looks them up on LD_LIBRARY_PATH as it was when the process started.
Loading them by absolute path first (RTLD_GLOBAL) makes the later by-name open find them, so the node
works whether or not the workspace's setup script was sourced.
"""

from __future__ import annotations

import ctypes
import importlib
import os
import sys
from dataclasses import dataclass
from pathlib import Path

REPO_INSTALL = Path(__file__).resolve().parents[2] / "install"


@dataclass(frozen=True)
class TfSupport:
    """The TFMessage class when /tf can be published, else None and why not."""

    message: type | None
    detail: str


def _site_packages(prefix: Path) -> Path:
    return prefix / "lib" / f"python{sys.version_info[0]}.{sys.version_info[1]}" / "site-packages"


def _candidate_prefixes() -> list[Path]:
    out = [Path(p) for p in os.environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep) if p]
    out.append(REPO_INSTALL / "tf2_msgs")
    return out


def _preload(prefix: Path) -> None:
    libs = sorted((prefix / "lib").glob("libtf2_msgs__*.so"))
    # generator_c first: the type-support libraries link against it.
    libs.sort(key=lambda p: (0 if "generator_c" in p.name else 1, p.name))
    for lib in libs:
        ctypes.CDLL(str(lib), mode=ctypes.RTLD_GLOBAL)


def load_tf_message() -> TfSupport:
    """Import tf2_msgs.msg.TFMessage from the environment or the repo's colcon install."""
    try:
        mod = importlib.import_module("tf2_msgs.msg")
    except ImportError:
        mod = None
        for prefix in _candidate_prefixes():
            site = _site_packages(prefix)
            if (site / "tf2_msgs" / "__init__.py").is_file():
                sys.path.append(str(site))
                importlib.invalidate_caches()
                try:
                    mod = importlib.import_module("tf2_msgs.msg")
                except ImportError as err:
                    return TfSupport(None, f"tf2_msgs under {prefix} does not import: {err}")
                break
        if mod is None:
            return TfSupport(None, "tf2_msgs is not importable (run scripts/build_ros, or source a ROS install)")
    # <prefix>/lib/pythonX.Y/site-packages/tf2_msgs/msg/__init__.py; not resolve(): a symlink install points into build/
    prefix = Path(os.path.abspath(mod.__file__)).parents[5]
    try:
        _preload(prefix)
    except OSError as err:
        return TfSupport(None, f"tf2_msgs libraries under {prefix / 'lib'} do not load: {err}")
    return TfSupport(mod.TFMessage, f"tf2_msgs from {prefix}")
