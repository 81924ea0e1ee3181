"""Every tick as a JSON line (`mission run --log run.jsonl`), and the reader behind `mission viz --log`.

File format (one JSON object per line, version 1):

* line 1, ``{"kind": "header", ...}``: the tree's structure (``tree``: nested name/type/kind/ports/children,
  node ids are pre-order indices), the tree file, the map (PNG background + affine map→pixel transform);
* one line per tick: ``tick``, ``t`` (sim or ROS time), ``state``, ``reason``, ``status`` (the root's),
  ``tick_us``, ``active`` (names down the running branch), ``nodes`` (per node id:
  ``[status, feedback, own_us]``, ``own_us`` null when the node was not ticked), ``bb`` (keys read and
  written per node id, or per client name for the world adapter), ``robot``/``goal`` (x, y, yaw),
  ``twist``, ``tracks``, ``detections`` (id, label, distance, corners) and ``truth`` when simulated;
* a last ``{"kind": "end", "outcome": {...}}`` line when the run finished normally.

Lines are flushed as they are written, so a log of a crashed run is readable up to its last tick.
"""

from __future__ import annotations

import json
import logging
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from mission.core import blackboard as bbk
from mission.core.errors import MissionError
from mission.core.files import StreamedFile
from mission.core.observers import RunObserver, Tick
from mission.viz.model import VizNode, apply_tick, count, from_snapshot, to_dict
from mission.viz.probe import TickProbe, probe_for, release_probe

log = logging.getLogger(__name__)

LOG_VERSION = 1


def _dumps(obj: Any) -> str:
    return json.dumps(obj, separators=(",", ":"), ensure_ascii=False, default=_default)


def _default(o: Any) -> Any:
    if hasattr(o, "item"):
        return o.item()
    if hasattr(o, "tolist"):
        return o.tolist()
    if hasattr(o, "to_json"):
        return o.to_json()
    return str(o)


def map_info(runner: Any, adapter: Any) -> dict[str, Any] | None:
    """The map for viewers: the adapter's occupancy grid, else the blackboard's MAP, else None."""
    from mission.viz.topdown import MapView

    grid = getattr(adapter, "occupancy_grid", None)
    if grid is None:
        grid = runner.get(bbk.MAP)
    return None if grid is None else MapView(grid).info()


def header(runner: Any, adapter: Any, probe: Any, **extra: Any) -> dict[str, Any]:
    """The first line of a log (and what the live page is sent first). `probe` None: a run with no tree
    (the live page of an action server waiting for its first goal): ``tree`` is then None."""
    tree_path = getattr(runner, "tree_path", None) if probe is not None else None
    scenario = getattr(getattr(adapter, "scenario", None), "name", None)
    return {
        "kind": "header",
        "version": LOG_VERSION,
        "created": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
        "tree_file": None if tree_path is None else str(tree_path),
        "scenario": scenario,
        # what ran, on the first line: the config (None: the built-in one) and the perception plugins
        "config_file": None if getattr(runner, "config_file", None) is None else str(runner.config_file),
        "perception": _plugins(runner),
        "nodes": 0 if probe is None else count(probe.static),
        "tree": None if probe is None else to_dict(probe.static),
        "map": map_info(runner, adapter),
        **extra,
    }


def _plugins(runner: Any) -> list[dict[str, str]]:
    """The perception sources the run's config names: instance name and plugin."""
    config = getattr(runner, "config", None)
    sources = getattr(getattr(config, "perception", None), "sources", None) or []
    return [{"name": c.name or c.plugin, "plugin": c.plugin} for c in sources]


class TickLog(RunObserver):
    """A run observer writing a JSON-lines tick log to `path` (every `every`-th tick).

    A log holds one tree (its header): in a run whose trees come and go (an action server's goals,
    ``on_tree``) it is the first tree the run has; its ticks end when that tree stops or is replaced, and
    later trees are not logged (said once)."""

    def __init__(self, path: str | Path, every: int = 1) -> None:
        self.path = Path(path)
        self.every = max(1, int(every))
        self._probe: TickProbe | None = None
        self._logged = False  # the header (one tree) is written
        self.lines = 0
        # fails before the (slow) simulation when it cannot be opened
        self._file = StreamedFile(self.path, "--log", warn=log.warning)

    def on_start(self, runner: Any) -> None:
        if runner.tree is not None:  # none: an action server's run before its first goal (on_tree brings it)
            self._watch(runner)

    def on_tree(self, runner: Any) -> None:
        if not self._logged:
            if runner.tree is not None:
                self._watch(runner)
            return
        if self._probe is not None:
            release_probe(self._probe)
            self._probe = None
            log.warning("--log %s: a tick log holds one tree; the run's later trees are not logged", self.path)

    def _watch(self, runner: Any) -> None:
        self._probe = probe_for(runner)
        self._logged = True
        self._write(header(runner, runner.world, self._probe))

    def on_tick(self, runner: Any, tick: Tick) -> None:
        ground_truth = tick.ground_truth
        if self._probe is not None and runner.ticks % self.every == 0:
            self._write(self._probe.record(runner, ground_truth))

    def on_end(self, runner: Any, outcome: Any) -> None:
        if self._logged:
            out = outcome.to_json() if hasattr(outcome, "to_json") else outcome
            self._write({"kind": "end", "outcome": out})
        if self._probe is not None:
            release_probe(self._probe)
            self._probe = None
        self.close()

    def _write(self, obj: dict[str, Any]) -> None:
        if self._file.write(_dumps(obj) + "\n"):
            self.lines += 1

    def close(self) -> None:
        self._file.close()


@dataclass
class TickLogData:
    """A tick log read back: header, tick records (in order) and the end record (None if the run died)."""

    path: Path
    header: dict[str, Any]
    ticks: list[dict[str, Any]] = field(default_factory=list)
    end: dict[str, Any] | None = None
    torn_line: int | None = None  # the line number of a last line cut off mid-write (skipped), if any

    def tree(self) -> VizNode:
        """The tree's structure, all nodes not ticked."""
        return from_snapshot(self.header["tree"])

    def tick_numbers(self) -> list[int]:
        return [int(t["tick"]) for t in self.ticks]

    def record(self, tick: int) -> dict[str, Any]:
        """The record of tick `tick` (MissionError naming the range when it is not in the log)."""
        for rec in self.ticks:
            if int(rec["tick"]) == tick:
                return rec
        if not self.ticks:
            raise MissionError(f"{self.path}: the log has no ticks")
        first, last = self.ticks[0]["tick"], self.ticks[-1]["tick"]
        if self.header.get("format") == "btlog":  # its steps are the moments something changed, not ticks
            raise MissionError(
                f"{self.path}: no timestamp {tick}; this .btlog has {len(self.ticks)} (1..{last}): a .btlog records "
                "status changes, not ticks, and a tree that stays RUNNING adds none"
            )
        raise MissionError(f"{self.path}: no tick {tick}; the log has ticks {first}..{last}")

    def tree_at(self, tick: int) -> VizNode:
        """The tree with statuses, feedback and timings as they were after tick `tick`."""
        return apply_tick(self.tree(), self.record(tick)["nodes"])


def read_log(path: str | Path) -> TickLogData:
    """Read a tick log; a bad line is a MissionError naming the file and line.

    The log is append-only, so a run killed mid-write leaves a torn last line: that one is skipped with a
    warning naming it (and recorded in ``torn_line``), and everything before it is read."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise MissionError(f"{path}: no such tick log (write one with `mission run --log {path}`)") from None
    except UnicodeDecodeError as err:
        raise MissionError(
            f"{path}: not a tick log (binary data at byte {err.start}); expected the JSON lines `mission run --log` "
            "writes, or a Groot2 .btlog"
        ) from None
    except OSError as err:
        raise MissionError(f"{path}: cannot read tick log ({err.strerror or err})") from err
    lines = text.splitlines()
    data: TickLogData | None = None
    torn: int | None = None
    for i, line in enumerate(lines, start=1):
        if not line.strip():
            continue
        try:
            obj = json.loads(line)
        except json.JSONDecodeError as err:
            if i == len(lines) and not text.endswith("\n"):
                torn = i  # the run was cut off mid-line: keep what was complete
                break
            raise MissionError(f"{path}:{i}: not JSON ({err.msg}); expected one JSON object per line") from None
        if not isinstance(obj, dict):
            raise MissionError(f"{path}:{i}: expected a JSON object, got {type(obj).__name__}")
        if data is None:
            if obj.get("kind") != "header" or "tree" not in obj:
                raise MissionError(f"{path}:{i}: expected the header line (kind=header with the tree) first")
            if int(obj.get("version", 0)) > LOG_VERSION:
                raise MissionError(f"{path}:{i}: log version {obj['version']} is newer than this build reads")
            data = TickLogData(path=path, header=obj)
        elif obj.get("kind") == "end":
            data.end = obj
        elif obj.get("kind") == "header":  # a second run appended: keep the first, say so
            raise MissionError(f"{path}:{i}: a second header; expected one run per log file")
        else:
            if "tick" not in obj or "nodes" not in obj:
                raise MissionError(f"{path}:{i}: a tick line needs `tick` and `nodes`")
            data.ticks.append(obj)
    if data is None:
        raise MissionError(f"{path}: empty tick log; expected a header line")
    if torn is not None:
        data.torn_line = torn
        log.warning(
            "%s:%d: last line cut off mid-write (the run was interrupted); skipped it, read %d ticks before it",
            path,
            torn,
            len(data.ticks),
        )
    return data
