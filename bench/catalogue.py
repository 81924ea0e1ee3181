"""The benchmarks `mission bench` knows: name, what it measures, which runs include it, and where figures go.

Each entry points at a module ``bench/<module>.py`` with ``run(quick: bool, out: pathlib.Path) -> dict``.
Modules are imported only when their benchmark runs, so a missing optional one (``soak``, written
separately) fails with a clear message and never stops the others.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from mission.core.errors import MissionError

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "bench" / "results"  # the committed figures of full runs; BENCHMARKS.md is made from these
QUICK_RESULTS = ROOT / "out" / "bench-quick"  # quick runs (gitignored): never mixed into the committed figures


def default_output(quick: bool) -> Path:
    """Where a run's figures go unless told: quick runs never overwrite the committed full-run results."""
    return QUICK_RESULTS if quick else RESULTS


def is_committed_results(path: Path) -> bool:
    """Is `path` the committed results directory (bench/results, however it is spelt)?"""
    return path.resolve() == RESULTS.resolve()


@dataclass(frozen=True)
class Benchmark:
    name: str
    module: str  # bench.<module>
    description: str
    in_quick: bool = True  # part of `mission bench --quick`
    in_full: bool = True  # part of `mission bench` without --only

    def load(self) -> Callable[[bool, Path], dict[str, Any]]:
        """The module's ``run`` function; a MissionError naming the file when it does not exist."""
        try:
            mod = importlib.import_module(f"bench.{self.module}")
        except ModuleNotFoundError as err:
            if err.name == f"bench.{self.module}":
                raise MissionError(
                    f"benchmark {self.name!r} is not available: bench/{self.module}.py does not exist in this checkout"
                ) from None
            raise
        run = getattr(mod, "run", None)
        if not callable(run):
            raise MissionError(f"benchmark {self.name!r}: bench/{self.module}.py has no run(quick, out) function")
        return run  # type: ignore[no-any-return]


BENCHMARKS: tuple[Benchmark, ...] = (
    Benchmark(
        "perception", "perception_bench", "frames/s of the aruco/apriltag sources vs the raw library calls they wrap"
    ),
    Benchmark("pose", "pose_accuracy", "pose error by range × angle vs the raw library's naive IPPE pose"),
    Benchmark("real_images", "real_images", "recall and corners on photographs vs the raw libraries at their settings"),
    Benchmark(
        "apriltag_backends", "apriltag_backends_bench", "AprilTag 3 (pupil) vs OpenCV backend: accuracy and speed"
    ),
    Benchmark("tree", "tree_tick", "µs per tick of mission.xml on scripted inputs vs a bare py_trees tree"),
    Benchmark("groot", "groot_monitor", "µs per step with --btlog / --groot (a client polling STATUS) vs none"),
    Benchmark("latency", "latency", "frame → command on the blackboard, p50/p99, vs the detector alone"),
    Benchmark("sim", "sim_bench", "render ms/frame per resolution/renderer; closed-loop sim-s per wall-s"),
    Benchmark("missions", "missions", "mission outcomes over many seeds per scenario vs the design targets"),
    Benchmark(
        "search",
        "search_bench",
        "finding the target again: the search ladder vs the in-place sweep vs a ±90° "
        "rotation, same scenarios and seeds (only with --only search)",
        in_quick=False,
        in_full=False,
    ),
    Benchmark(
        "robustness",
        "robustness",
        "missions under a real robot's senses: every scenario × ideal / typical / "
        "harsh, then one factor at a time at three levels (only with --only robustness)",
        in_quick=False,
        in_full=False,
    ),
    Benchmark(
        "sweep",
        "sweep_scaling",
        "mission sweep: 1 vs 2 workers, per-run overhead vs mission run, 1,000 seeds",
        in_quick=False,
    ),  # quick figures would be start-up costs only; `--quick --only sweep` smoke-tests it
    Benchmark("ros", "ros_transport", "image → /detected_aruco_pose latency over shared-memory DDS at 30 Hz"),
    Benchmark(
        "ros_missions",
        "ros_missions",
        "the mission over ROS (sim-robot + node) vs in process, same seeds (only with --only ros_missions)",
        in_quick=False,
        in_full=False,
    ),
    Benchmark(
        "nav2_actions",
        "nav2_actions",
        "Nav2's dock_robot / follow_object served by our trees (three "
        "processes over DDS) vs the same trees in process, same seeds (only with --only nav2_actions)",
        in_quick=False,
        in_full=False,
    ),
    Benchmark("soak", "soak", "long-running soak test (only with --only soak)", in_quick=False, in_full=False),
)

BY_NAME = {b.name: b for b in BENCHMARKS}


def select(only: str | None, quick: bool) -> list[Benchmark]:
    """The benchmarks to run: the named ones (in registry order), else the default set for the mode.

    An unknown name is a MissionError listing the known ones.
    """
    if only:
        names = [n.strip() for n in only.split(",") if n.strip()]
        unknown = [n for n in names if n not in BY_NAME]
        if unknown:
            raise MissionError(f"unknown benchmark {', '.join(repr(n) for n in unknown)}; known: {', '.join(BY_NAME)}")
        return [b for b in BENCHMARKS if b.name in names]
    return [b for b in BENCHMARKS if (b.in_quick if quick else b.in_full)]
