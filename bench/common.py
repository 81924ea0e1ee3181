"""What every benchmark shares: the figure format (a value beside its named baseline), stats, the machine.

A benchmark's ``run(quick, out)`` returns a dict with at least::

    {"title": str, "figures": [Figure as dict, ...], "details": {...}, "plots": [file names in out]}

Every figure names the baseline it is compared with, measured in the same run where it is a speed, so
a number read on a loaded machine still means something (the ratio, not the absolute time, is what we
quote).
"""

from __future__ import annotations

import os
import platform
import sys
from dataclasses import asdict, dataclass
from importlib import metadata
from pathlib import Path
from typing import Any

import numpy as np

from mission.core.files import atomic_path


@dataclass
class Figure:
    """One quoted number, the baseline it is measured against, and (if any) the target it must meet."""

    label: str
    value: float | str | None
    unit: str
    baseline: str  # what it is compared with, in words ("raw cv2 ArucoDetector.detectMarkers …")
    baseline_value: float | str | None = None
    ratio: float | None = None  # value / baseline_value where that means something
    target: str | None = None  # e.g. "ratio ≤ 1.10"
    meets_target: bool | None = None

    def to_json(self) -> dict[str, Any]:
        return asdict(self)


def ratio(a: float | None, b: float | None, nd: int = 3) -> float | None:
    if a is None or b is None or b == 0 or not np.isfinite(a) or not np.isfinite(b):
        return None
    return round(float(a) / float(b), nd)


def pct(values: list[float] | np.ndarray, q: float, nd: int = 3) -> float | None:
    """The q-th percentile (None for no values)."""
    if len(values) == 0:
        return None
    return round(float(np.percentile(np.asarray(values, dtype=np.float64), q)), nd)


def load_average() -> float | None:
    try:
        return round(os.getloadavg()[0], 2)
    except OSError:  # pragma: no cover - not on Linux
        return None


def _version(dist: str) -> str | None:
    try:
        return metadata.version(dist)
    except metadata.PackageNotFoundError:
        return None


def cpu_model() -> str:
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def machine_info() -> dict[str, Any]:
    """Where the figures were measured: CPU, cores, OS, Python and the libraries that set the speed."""
    import cv2

    return {
        "cpu": cpu_model(),
        "cores": os.cpu_count(),
        "os": f"{platform.system()} {platform.release()}",
        "python": sys.version.split()[0],
        "opencv": cv2.__version__,
        "pybullet": _version("pybullet"),
        "pupil_apriltags": _version("pupil-apriltags"),
        "py_trees": _version("py_trees"),
        "numpy": np.__version__,
        "load_average_1min": load_average(),
    }


def progress(msg: str) -> None:
    """A progress line on stderr (stdout stays machine-readable under --json)."""
    print(f"bench: {msg}", file=sys.stderr, flush=True)


def save_figure(fig: Any, path: Path, dpi: int = 110) -> None:
    """Write a matplotlib figure to `path` atomically (core/files.py) and close it.

    A benchmark interrupted while plotting, or a reader of bench/results/ during a run, then sees the
    previous picture or the new one, never a truncated PNG; the figure is closed even when saving fails.
    """
    import matplotlib.pyplot as plt

    try:
        with atomic_path(path) as tmp:
            fig.savefig(tmp, dpi=dpi)
    finally:
        plt.close(fig)


def plot_cdf(series: dict[str, Any], title: str, path: Path, fontsize: int = 8) -> str:
    """Latency CDFs, one line per labelled series of ms values (empty series are left out); returns the file name."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.5, 3.8))
    for label, values in series.items():
        v = np.sort(np.asarray(values, dtype=float))
        if len(v):
            ax.plot(v, np.arange(1, len(v) + 1) / len(v), label=label)
    ax.set(xlabel="ms", ylabel="fraction of frames", title=title)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=fontsize)
    fig.tight_layout()
    save_figure(fig, path)
    return path.name
