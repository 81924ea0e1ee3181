"""Pictures and the JSON of a run: what a person looks at after `mission run --report DIR`.

:func:`report_observers` (attached before the run) and :func:`write_report` (after it) are the whole of
``--report``: `mission run` and each run of `mission sweep` call both, so a sweep keeps for every run
exactly what `mission run --report` writes — report.json, trajectories.png, timeline.png, the tree at
each state transition (trees/*.svg) and report.html.

Files are written atomically (mission.core.files), so a crash mid-write leaves the previous file intact.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.collections import LineCollection
from matplotlib.patches import Patch

from mission.app.metrics import MetricsRecorder
from mission.core.files import atomic_path, atomic_write_text
from mission.core.observers import RunObserver
from mission.core.types import OccupancyGrid
from mission.viz.style import STATE_COLOURS

NO_STATE = "#c7c7c7"  # ticks before the mission state is first written
TARGET = "#1f77b4"  # the target: its path and where it ended


def report_observers(out: str | Path) -> list[RunObserver]:
    """What watches a run for its report: the tree at every state transition (written with report.html
    into `out` when the run ends)."""
    from mission.viz.report_trees import TransitionTrees

    return [TransitionTrees(out)]


def verdict(outcome: Any) -> str:
    """SUCCESS, FAILURE or INTERRUPTED: the word a run's result line and pictures lead with."""
    return "INTERRUPTED" if outcome.interrupted else ("SUCCESS" if outcome.success else "FAILURE")


def write_report(out: str | Path, outcome: Any, recorder: MetricsRecorder, adapter: Any) -> None:
    """report.json and the pictures of a finished run (a RunOutcome, its recorder and its world)."""
    out = Path(out)
    write_json(out / "report.json", outcome.to_json())
    title = f"{outcome.scenario} seed {outcome.seed}: {verdict(outcome)}"
    grid = getattr(adapter, "occupancy_grid", None)
    plot_trajectories(recorder, grid, out / "trajectories.png", title, getattr(adapter, "dock_xy", None))
    plot_timeline(recorder, out / "timeline.png", title)


def write_json(path: str | Path, data: Any) -> None:
    atomic_write_text(path, json.dumps(data, indent=2, default=_json_default) + "\n")


def _json_default(o: Any) -> Any:
    if isinstance(o, np.generic):
        return o.item()
    if isinstance(o, np.ndarray):
        return o.tolist()
    raise TypeError(f"not JSON-serialisable: {type(o).__name__}")


def save_figure(fig: plt.Figure, path: Path) -> None:
    """Write `fig` to `path` atomically and close it (a reader sees the old picture or the new one)."""
    try:
        with atomic_path(path) as tmp:
            fig.savefig(tmp, dpi=110, bbox_inches="tight")
    finally:
        plt.close(fig)


def plot_trajectories(
    rec: MetricsRecorder,
    grid: OccupancyGrid | None,
    path: Path,
    title: str = "",
    dock_xy: tuple[float, float] | None = None,
) -> list[str]:
    """Top-down map: static obstacles, the target's path, the robot's path coloured by mission state; returns
    what its key says (beside the map, so it hides no obstacle)."""
    fig, ax = plt.subplots(figsize=(7, 7))
    if grid is not None:
        h, w = grid.data.shape
        x0, y0, res = grid.origin.x, grid.origin.y, grid.resolution
        extent = (x0, x0 + w * res, y0, y0 + h * res)
        img = np.where(grid.data >= 50, 0.15, np.where(grid.data < 0, 0.7, 1.0))
        ax.imshow(img, cmap="gray", vmin=0, vmax=1, origin="lower", extent=extent, interpolation="nearest")
    tgt = rec.target_xy
    tgt = tgt[~np.isnan(tgt[:, 0])]
    if len(tgt):
        ax.plot(tgt[:, 0], tgt[:, 1], "--", color=TARGET, lw=1.5, label="target (truth)")
        ax.plot(*tgt[-1], "s", color=TARGET, mec="black", ms=8, label="target end")  # not SEARCH's red
    xy = rec.robot_xy
    if len(xy) > 1:
        segs = np.stack([xy[:-1], xy[1:]], axis=1)
        colours = [STATE_COLOURS.get(s, NO_STATE) for s in rec.states[1:]]
        ax.add_collection(LineCollection(segs, colors=colours, linewidths=2.5))
        ax.plot(*xy[0], "o", color="black", ms=6, label="robot start")
        ax.plot(*xy[-1], "^", color="black", ms=8, label="robot end")
    if dock_xy is not None:
        ax.plot(*dock_xy, "P", color="#9467bd", ms=11, label="dock tag")
    for state in dict.fromkeys(rec.states):
        if state:
            ax.plot([], [], color=STATE_COLOURS.get(state, NO_STATE), lw=3, label=state)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title(title or "trajectories")
    legend = ax.legend(loc="upper left", bbox_to_anchor=(1.02, 1.0), fontsize=8, frameon=False)  # beside the map
    labels = [text.get_text() for text in legend.get_texts()]
    save_figure(fig, path)
    return labels


def _stretches(values: list[str], end: int) -> list[tuple[int, int, str]]:
    """(first index, index after the stretch, value) of each run of equal values in values[:end]."""
    out: list[tuple[int, int, str]] = []
    start = 0
    for i in range(1, end + 1):
        if i == end or values[i] != values[start]:
            out.append((start, i, values[start]))
            start = i
    return out


def plot_timeline(rec: MetricsRecorder, path: Path, title: str = "") -> list[str]:
    """Mission state over time above the ground truth it reacts to (line of sight, field of view, range);
    returns what its colour key says."""
    t = np.array(rec.times, dtype=float)
    labels: list[str] = []
    fig, (ax_s, ax_d) = plt.subplots(2, 1, figsize=(10, 4.2), sharex=True, height_ratios=[1.2, 1])
    if len(t) > 1:
        d = np.array(rec.target_distance, dtype=float)
        has_target = bool(np.isfinite(d).any())
        rows = {"state": [STATE_COLOURS.get(s, NO_STATE) for s in rec.states]}
        if has_target:
            rows["line of sight"] = ["#2ca02c" if v else "#d62728" for v in rec.los]
            rows["in view"] = ["#2ca02c" if v else "#d9d9d9" for v in rec.fov]
        ys = (2.0, 1.0, 0.0)[: len(rows)]
        for y, colours in zip(ys, rows.values(), strict=True):
            # one bar per stretch of equal colour: a 30-minute run is a few hundred bars, not 27 000
            for a, b, colour in _stretches(colours, len(t) - 1):
                ax_s.barh(y, t[b] - t[a], left=t[a], height=0.8, color=colour)
        ax_s.set_yticks(list(ys), list(rows))
        ax_s.set_ylim(ys[-1] - 0.5, ys[0] + 0.5)
        key = [Patch(color=STATE_COLOURS.get(st, NO_STATE), label=st) for st in dict.fromkeys(rec.states) if st]
        if has_target:
            key += [
                Patch(color="#2ca02c", label="in sight / in view"),
                Patch(color="#d62728", label="line of sight blocked"),
                Patch(color="#d9d9d9", label="not in view"),
            ]
        ax_s.legend(handles=key, loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=7, frameon=False)
        labels = [str(k.get_label()) for k in key]
        last_label = -np.inf
        for tt, s in rec.transitions:
            if s and tt - last_label >= (t[-1] - t[0]) / 25:  # flickers would print on top of each other
                ax_s.annotate(s, (tt, ys[0] + 0.45), fontsize=7, rotation=30, annotation_clip=False)
                last_label = tt
        if has_target:
            ax_d.plot(t, d, color="#1f77b4")
            ax_d.set_ylabel("robot–target (m)")
        else:
            ax_d.text(0.5, 0.5, "no target in this scenario", ha="center", va="center", transform=ax_d.transAxes)
            ax_d.set_yticks([])
    ax_d.set_xlabel("sim time (s)")
    ax_s.set_title(title or "timeline", pad=22)  # above the state labels, not on them
    save_figure(fig, path)
    return labels
