"""A sweep's matrix: scenarios × seeds × the values of each ``--set`` key, and the name of every run.

A run is named by what decides its outcome — scenario, parameter values, seed — as a path under the
sweep directory (``runs/follow_open__SearchSweep.angular_speed=0.6/seed-0007``). The name is the run's
identity everywhere: the key of its Dask task, the row of the results table, the folder of its report.
That is what makes a sweep resumable (a name already in the table is not run again) and a retried run
count once (a second result under a name already recorded is dropped).
"""

from __future__ import annotations

import hashlib
import itertools
import re
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

from mission.app.overrides import RunOverrides, Setting, parse_settings
from mission.app.provenance import file_record, source_fingerprint
from mission.app.sim_run import check_prepared, prepare_run, unused_ports
from mission.core.errors import ConfigError, MissionError

Pictures = Literal["all", "failed", "none"]
MAX_SEEDS = 1_000_000
MAX_DIR_NAME = 96  # longer cell names are cut and given a hash, so paths stay usable on every filesystem
_UNSAFE = re.compile(r"[^A-Za-z0-9._=+-]+")


def parse_seeds(text: str) -> tuple[int, ...]:
    """``0-999``, ``7``, ``0-9,20,30-35`` → the seeds in order, each once; ConfigError naming --seeds."""
    seeds: list[int] = []
    for part in (p.strip() for p in str(text).split(",")):
        first, dash, last = part.partition("-")
        try:
            lo = int(first)
            hi = int(last) if dash else lo
        except ValueError:
            lo = hi = -1
        if lo < 0 or hi < lo:
            raise ConfigError(
                f"expected seeds as A-B, N or a comma-separated list of them (e.g. 0-999), got {part!r}", key="--seeds"
            )
        if hi - lo >= MAX_SEEDS:
            raise ConfigError(f"{part}: at most {MAX_SEEDS} seeds in one range", key="--seeds")
        seeds += range(lo, hi + 1)
    return tuple(dict.fromkeys(seeds))


def parse_scenarios(text: str) -> tuple[str, ...]:
    names = tuple(dict.fromkeys(s.strip() for s in str(text).split(",") if s.strip()))
    if not names:
        raise ConfigError("expected scenario names or YAML paths, comma-separated", key="--scenarios")
    return names


@dataclass(frozen=True)
class RunSpec:
    """One run of the matrix: everything a worker needs to run it as ``mission run`` would."""

    scenario: str  # shipped name or YAML path, as given
    seed: int
    overrides: RunOverrides = field(default_factory=RunOverrides)
    config_file: str | None = None
    tree: str | None = None
    max_duration: float | None = None
    pictures: Pictures = "all"

    @property
    def cell(self) -> str:
        """The matrix cell (scenario and parameter values) for tables: ``follow_open run.tick_hz=10``."""
        return " ".join(p for p in (scenario_label(self.scenario), self.overrides.label) if p)

    @property
    def run_id(self) -> str:
        """``<cell folder>/seed-NNNN``: the run's name in the table, in Dask and on disk."""
        return f"{cell_dir(self.scenario, self.overrides)}/seed-{self.seed:04d}"

    def command(self) -> str:
        """The `mission run` command that reproduces this run (same seed, same outcome)."""
        parts = ["mission", "run", "--scenario", self.scenario, "--seed", str(self.seed)]
        if self.config_file:
            parts += ["--config", self.config_file]
        if self.tree:
            parts += ["--tree", self.tree]
        if self.max_duration:
            parts += ["--max-duration", f"{self.max_duration:g}"]
        for s in self.overrides.settings:
            parts += ["--set", _quoted(s.text)]
        return " ".join(parts)


def scenario_label(scenario: str) -> str:
    return Path(scenario).stem if scenario.endswith((".yaml", ".yml")) else scenario


def cell_dir(scenario: str, overrides: RunOverrides) -> str:
    """A folder name for a cell: readable, filesystem-safe, unique (a hash when it had to be cut)."""
    name = "__".join([scenario_label(scenario), *(s.text for s in overrides.settings)])
    safe = _UNSAFE.sub("_", name).strip("._") or "cell"
    if safe != name or len(safe) > MAX_DIR_NAME:  # cut or rewritten: the hash keeps two cells apart
        digest = hashlib.sha256(name.encode("utf-8")).hexdigest()[:8]
        safe = f"{safe[: MAX_DIR_NAME - 9]}-{digest}"
    return safe


def _quoted(text: str) -> str:
    return text if re.fullmatch(r"[A-Za-z0-9._=+,:/-]+", text) else "'" + text.replace("'", "'\\''") + "'"


@dataclass(frozen=True)
class SweepPlan:
    """Scenarios × seeds × every combination of the axes' values (each axis one ``--set`` key)."""

    scenarios: tuple[str, ...]
    seeds: tuple[int, ...]
    axes: tuple[tuple[str, tuple[Setting, ...]], ...] = ()
    config_file: str | None = None
    tree: str | None = None
    max_duration: float | None = None
    pictures: Pictures = "all"

    @classmethod
    def from_args(
        cls,
        scenarios: str | Sequence[str],
        seeds: str | Sequence[int],
        sets: Sequence[str] = (),
        **fixed: Any,
    ) -> SweepPlan:
        """The plan from command-line spellings (``"follow_open,explore_dock"``, ``"0-19"``, ``["K=V1,V2"]``)."""
        names = parse_scenarios(scenarios) if isinstance(scenarios, str) else tuple(scenarios)
        seed_list = parse_seeds(seeds) if isinstance(seeds, str) else tuple(int(s) for s in seeds)
        axes = tuple((key, tuple(values)) for key, values in parse_settings(sets, many=True))
        return cls(names, seed_list, axes, **fixed)

    def cells(self) -> list[RunOverrides]:
        """Every combination of the axes' values, the first axis slowest (none: one cell, no overrides)."""
        return [RunOverrides(tuple(combo)) for combo in itertools.product(*(values for _, values in self.axes))]

    def runs(self) -> list[RunSpec]:
        """Every run, seed-major: a sweep cut short has the same seeds in every cell, not whole cells."""
        cells = self.cells()
        return [
            RunSpec(scenario, seed, cell, self.config_file, self.tree, self.max_duration, self.pictures)
            for seed in self.seeds
            for scenario in self.scenarios
            for cell in cells
        ]

    def identity(self) -> dict[str, Any]:
        """What a run's outcome depends on beyond its name: a sweep directory resumes only with the same —
        the same config and tree (by content), --max-duration, and mission source (provenance.source_fingerprint:
        a run of other code would not be the same run)."""
        config = file_record(self.config_file) if self.config_file else None
        tree = file_record(self.tree)["sha256"] if self.tree else None
        return {
            "config": config,
            "tree": self.tree,
            "tree_sha256": tree,
            "max_duration_s": self.max_duration,
            "source": source_fingerprint(),
        }

    def check(self) -> None:
        """Every cell's config, scenario and tree checked as its runs' set-up will check them, before anything
        runs; a MissionError names the scenario, the key and what was expected (one line per problem)."""
        tags: set[str] = set()
        trees: set[str] = set()
        for scenario in self.scenarios:
            for cell in self.cells():
                try:
                    prepared = prepare_run(scenario, config_file=self.config_file, tree=self.tree, overrides=cell)
                    tags |= check_prepared(prepared)
                except MissionError as err:
                    where = f"{scenario_label(scenario)}" + (f" with {cell.label}" if cell else "")
                    if isinstance(err, ConfigError) and err.file != "--set" and not cell:
                        raise  # a problem of the files themselves: the run would say the same
                    raise type(err)("\n".join(f"{line} ({where})" for line in str(err).splitlines())) from None
                trees.add(Path(prepared.tree).name)
        for _key, values in self.axes:
            unused_ports(RunOverrides(values[:1]), tags, ", ".join(sorted(trees)))

    def describe(self) -> dict[str, Any]:
        """The plan as plain data (sweep.json)."""
        return {
            "scenarios": list(self.scenarios),
            "seeds": _seed_ranges(self.seeds),
            "set": {key: [s.value for s in values] for key, values in self.axes},
            "config_file": self.config_file,
            "tree": self.tree,
            "max_duration_s": self.max_duration,
            "pictures": self.pictures,
            "runs": len(self.scenarios) * len(self.seeds) * len(self.cells()),
        }


def _seed_ranges(seeds: Sequence[int]) -> str:
    """(0, 1, 2, 5, 7, 8) → ``0-2,5,7-8`` (how --seeds spells them)."""
    out: list[str] = []
    ordered = sorted(seeds)
    for _, group in itertools.groupby(enumerate(ordered), key=lambda p: p[1] - p[0]):
        run = [s for _, s in group]
        out.append(str(run[0]) if len(run) == 1 else f"{run[0]}-{run[-1]}")
    return ",".join(out)
