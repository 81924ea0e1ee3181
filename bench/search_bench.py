"""Benchmark: finding the target again — the search ladder against two baselines, same scenarios, same seeds.

Three searches (issue 15), each the FOLLOW / LOST / SEARCH coordinator of trees/follow.xml with its SEARCH
(and LOST) swapped:

* ``ladder`` — the shipped follow.xml: PursueLastSeen (LOST that looks), then the SEARCH ladder
  (TurnToBearing → SearchBelief → CoverUnseen → GiveUpSearch);
* ``sweep`` — bench/search_variants/sweep.xml: the coordinator before the ladder (HoldLastGoal 3 s, then
  SearchSweep turning in place one way), kept as the baseline behaviour;
* ``rotate`` — bench/search_variants/rotate.xml: Nav2 opennav_following's search (hold 1 s, then rotate to
  ±90° of the heading, three rounds, then fail).

Each variant gets a copy of the shipped trees with its follow.xml in place (``<out>/search_trees/<variant>/``),
so the scenarios that run mission.xml (which includes follow.xml) search the variant's way too. The dock
scenario (explore_dock) has no SEARCH: it runs with the shipped trees only, on the ladder's seeds, to show nothing
else changed (20 seeds like every other scenario: the acceptance asks for at least 20 per scenario).
The runs are `mission sweep`s (one per variant and tree), so a row here is a row of ``mission sweep``.

Per variant and scenario: success rate (goals ≥ 99 % on the existing scenarios, ≥ 95 % on the new ones),
loss events recovered, re-acquisition time over every loss event (median, worst; goal ≤ 10 s), the tracking
fraction (time in FOLLOW with the target in view over the follow phase), and on target_gone the time from the
target leaving the map to the search giving up.

Knobs (environment): ``MISSION_BENCH_SEEDS`` (ladder seeds per scenario, default 20 — the acceptance run),
``MISSION_BENCH_BASELINE_SEEDS`` (the baselines', default the same), ``MISSION_BENCH_SCENARIOS``
(comma-separated; default all ten), ``MISSION_BENCH_SEARCHES`` (default ``ladder,sweep,rotate``),
``MISSION_BENCH_WORKERS`` (default one per core), ``MISSION_BENCH_BUDGET_S`` (stop starting runs after this
many wall seconds in all; what finished is reported). The full acceptance run is ``mission bench --only search``:
about 4 hours on two cores (560 runs, ~25 s each with two at a time), so it resumes — each sweep directory
keeps the runs it finished while the code (the installed mission's source, by content), the tree and the run
length stay the same, and starts afresh otherwise; run the same command again to go on.
"""

from __future__ import annotations

import json
import os
import shutil
import time
from pathlib import Path
from typing import Any

import numpy as np

from bench.common import Figure, pct, progress, save_figure
from bench.missions import aggregate
from mission.core.files import atomic_write_text
from mission.sweep.engine import run_sweep
from mission.sweep.plan import SweepPlan
from mission.sweep.store import SweepStore
from mission.sweep.table import read_jsonl
from mission.trees.loader import TREES_DIR

ROOT = Path(__file__).resolve().parents[1]
VARIANTS_DIR = ROOT / "bench" / "search_variants"
SEARCHES = ("ladder", "sweep", "rotate")
DESCRIBE = {
    "ladder": "LOST that looks + SEARCH ladder (shipped follow.xml)",
    "sweep": "hold 3 s + SearchSweep in place (the old coordinator)",
    "rotate": "hold 1 s + ±90° rotation ×3 (opennav_following)",
}
EXISTING = ("follow_open", "follow_occlusion", "search_corner", "explore_dock", "mission_full")
NEW = ("two_rooms", "hide_and_wait", "moving_occluder", "aisle", "target_gone")
DOCK_ONLY = ("explore_dock",)  # no FOLLOW phase: no SEARCH to compare
GOALS = {"existing": 0.99, "new": 0.95}
REACQUISITION_GOAL_S = 10.0
QUICK_SCENARIOS = ("two_rooms", "explore_dock")
QUICK_MAX_DURATION_S = 12.0
TYPICAL_SCENARIO = "two_rooms"  # the picture of a typical search: the same seed, each search


def variant_trees(variant: str, out: Path) -> Path:
    """A copy of the shipped trees with the variant's follow.xml in place (the ladder: the shipped trees)."""
    if variant == "ladder":
        return TREES_DIR
    dest = out / "search_trees" / variant
    shutil.rmtree(dest, ignore_errors=True)
    dest.mkdir(parents=True)
    for f in TREES_DIR.glob("*.xml"):
        shutil.copyfile(f, dest / f.name)
    shutil.copyfile(VARIANTS_DIR / f"{variant}.xml", dest / "follow.xml")
    return dest


def _tree_of(scenario: str) -> str:
    """The tree file a shipped scenario runs (its `tree:` key)."""
    from mission.sim.scenario import load_scenario

    return str(getattr(load_scenario(scenario), "tree", "") or "follow.xml")


def _groups(scenarios: tuple[str, ...]) -> dict[str, list[str]]:
    """Scenarios by the tree file they run, so each group is one sweep with that tree."""
    groups: dict[str, list[str]] = {}
    for s in scenarios:
        groups.setdefault(_tree_of(s), []).append(s)
    return groups


def sweeps(
    searches: tuple[str, ...],
    scenarios: tuple[str, ...],
    seeds: int,
    baseline_seeds: int,
    out: Path,
    workers: int,
    budget_s: float | None,
    max_duration: float | None,
) -> tuple[list[dict[str, Any]], list[str], int]:
    """Every run, each row tagged with its ``search``; the sweep directories, in the order they ran; and how many
    runs were planned (more than the rows when the budget cut the run short)."""
    rows: list[dict[str, Any]] = []
    dirs: list[str] = []
    searched = tuple(s for s in scenarios if s not in DOCK_ONLY)
    jobs: list[tuple[str, str, list[str], int]] = []  # (search, tree file, scenarios, seeds)
    for search in searches:
        n = seeds if search == "ladder" else baseline_seeds
        for tree, group in _groups(searched).items():
            jobs.append((search, tree, group, n))
    docks = [s for s in scenarios if s in DOCK_ONLY]
    if docks:
        jobs.append(("ladder", "explore_dock.xml", docks, seeds))  # the shipped trees only: no search in this tree
    planned = sum(len(group) * n for _, _, group, n in jobs)
    t0 = time.perf_counter()
    for search, tree, group, n in jobs:
        left = None if budget_s is None else budget_s - (time.perf_counter() - t0)
        if n <= 0 or (left is not None and left <= 0):
            continue
        trees = variant_trees(search, out)
        tree_path = None if search == "ladder" else _relative(trees / tree)
        sweep_dir = out / "search_sweeps" / f"{search}__{Path(tree).stem}"
        plan = SweepPlan(tuple(group), tuple(range(n)), tree=tree_path, max_duration=max_duration, pictures="all")
        kept = _resumable(sweep_dir, plan)
        progress(
            f"search: {search} on {', '.join(group)} × {n} seeds ({tree})"
            + (f"; {kept} runs of the same code finished before, kept" if kept else "")
        )
        outcome = run_sweep(plan, sweep_dir, workers=workers, progress=True, budget_s=left)
        dirs.append(sweep_dir.relative_to(out).as_posix())
        wanted = {r.run_id for r in plan.runs()}
        for r in outcome.rows:
            if r["run_id"] in wanted:
                rows.append({**r, "search": search, "sweep_dir": sweep_dir.relative_to(out).as_posix()})
    return rows, dirs, planned


def _relative(path: Path) -> str:
    """`path` relative to the working directory when it is under it: a sweep's identity holds the tree's path,
    and a checkout elsewhere (a fresh clone resuming committed rows) must give the same one."""
    try:
        return path.resolve().relative_to(Path.cwd().resolve()).as_posix()
    except ValueError:
        return str(path)


def _resumable(sweep_dir: Path, plan: SweepPlan) -> int:
    """How many runs `sweep_dir` holds that this plan can keep; a directory made by other code, another tree
    or another --max-duration is emptied first (a benchmark never mixes two versions of the code).

    The acceptance run is hours on two cores: it may be cut (MISSION_BENCH_BUDGET_S, a stopped session) and
    resumed, and each sweep directory's runs.jsonl and sweep.json may be committed to carry the finished rows
    to another checkout (bench/results/search_sweeps/*/runs/ — reports and pictures — is not committed)."""
    store = SweepStore(sweep_dir)
    if store.info().get("identity") != plan.identity():
        shutil.rmtree(sweep_dir, ignore_errors=True)
        return 0
    wanted = {r.run_id for r in plan.runs()}
    return sum(1 for r in read_jsonl(store.rows_path) if r.get("run_id") in wanted)


def summarise(name: str, runs: list[dict[str, Any]]) -> dict[str, Any]:
    """One (search, scenario) cell: the missions benchmark's figures plus every loss's re-acquisition time,
    the tracking fraction and the time to give up."""
    a = aggregate(name, runs)
    reacq = [float(t) for r in runs for t in (r.get("reacquisition_times_s") or [])]
    tracking = [
        float(v) for r in runs if isinstance(v := (r.get("metrics") or {}).get("tracking_fraction"), int | float)
    ]
    give_up = [
        float(v) for r in runs if isinstance(v := (r.get("metrics") or {}).get("give_up_after_gone_s"), int | float)
    ]
    over = sum(1 for t in reacq if t > REACQUISITION_GOAL_S)
    return {
        "runs": a["runs"],
        "seeds": a["seeds"],
        "success_rate": a["success_rate"],
        "loss_events": a["loss_events"],
        "loss_events_recovered": a["loss_events_recovered"],
        "loss_recovered_fraction": a["loss_recovered_fraction"],
        "reacquisition_s_median": pct(reacq, 50),
        "reacquisition_s_worst": round(max(reacq), 3) if reacq else None,
        "reacquisitions_over_10s": over,
        "tracking_fraction_median": pct(tracking, 50),
        "tracking_fraction_min": round(min(tracking), 3) if tracking else None,
        "give_up_after_gone_s_median": pct(give_up, 50),
        "give_up_after_gone_s_max": round(max(give_up), 3) if give_up else None,
        "collisions": a["collisions"],
        "failure_reasons": a["failure_reasons"],
    }


def _figures(search: str, scenario: str, c: dict[str, Any]) -> list[Figure]:
    kind = "existing" if scenario in EXISTING else "new"
    goal = GOALS[kind]
    base = f"{kind} scenario goal (issue 15)"
    f = [
        Figure(
            f"{search} / {scenario}: success rate ({c['runs']} seeds)",
            c["success_rate"],
            "fraction",
            baseline=base,
            baseline_value=goal,
            target=f"≥ {goal:g}",
            meets_target=None if c["success_rate"] is None else c["success_rate"] >= goal,
        )
    ]
    if c["loss_events"]:
        f.append(
            Figure(
                f"{search} / {scenario}: loss events recovered ({c['loss_events_recovered']}/{c['loss_events']})",
                c["loss_recovered_fraction"],
                "fraction",
                baseline="every loss recovered",
                baseline_value=1.0,
            )
        )
    if c["reacquisition_s_worst"] is not None:
        f.append(
            Figure(
                f"{search} / {scenario}: re-acquisition, worst loss (median {c['reacquisition_s_median']} s)",
                c["reacquisition_s_worst"],
                "s",
                baseline="design target",
                baseline_value=REACQUISITION_GOAL_S,
                target="≤ 10 s",
                meets_target=c["reacquisition_s_worst"] <= REACQUISITION_GOAL_S,
            )
        )
    if c["give_up_after_gone_s_max"] is not None:
        f.append(
            Figure(
                f"{search} / {scenario}: gave up after the target left, worst run (median "
                f"{c['give_up_after_gone_s_median']} s)",
                c["give_up_after_gone_s_max"],
                "s",
                baseline="scenario limit (success.give_up_within_s)",
                baseline_value=110.0,
                target="≤ 110 s",
                meets_target=c["give_up_after_gone_s_max"] <= 110.0,
            )
        )
    return f


def run(quick: bool, out: Path) -> dict[str, Any]:
    env = os.environ.get
    scenarios = tuple(s.strip() for s in env("MISSION_BENCH_SCENARIOS", "").split(",") if s.strip()) or (
        QUICK_SCENARIOS if quick else (*EXISTING, *NEW)
    )
    searches = tuple(s.strip() for s in env("MISSION_BENCH_SEARCHES", ",".join(SEARCHES)).split(",") if s.strip())
    unknown = [s for s in searches if s not in SEARCHES]
    if unknown:
        raise ValueError(f"MISSION_BENCH_SEARCHES: unknown search {', '.join(unknown)}; known: {', '.join(SEARCHES)}")
    seeds = int(env("MISSION_BENCH_SEEDS", "1" if quick else "20"))
    baseline_seeds = int(env("MISSION_BENCH_BASELINE_SEEDS", str(seeds)))
    workers = int(env("MISSION_BENCH_WORKERS", str(os.cpu_count() or 1)))
    budget = float(env("MISSION_BENCH_BUDGET_S")) if env("MISSION_BENCH_BUDGET_S") else None  # type: ignore[arg-type]
    max_duration = QUICK_MAX_DURATION_S if quick else None
    t0 = time.perf_counter()
    rows, dirs, planned = sweeps(searches, scenarios, seeds, baseline_seeds, out, workers, budget, max_duration)
    wall = time.perf_counter() - t0
    atomic_write_text(out / "search_runs.jsonl", "".join(json.dumps(r, default=str) + "\n" for r in rows))
    cells: dict[str, dict[str, Any]] = {}
    figures: list[Figure] = []
    for search in searches:
        for s in scenarios:
            runs = [r for r in rows if r["search"] == search and r["scenario"] == s]
            if runs:
                cells.setdefault(search, {})[s] = c = summarise(s, runs)
                figures += _figures(search, s, c)
    plots = [p for p in (_plot(cells, out), _typical(rows, out)) if p]
    reduced = seeds < 20 or baseline_seeds < 20 or set(scenarios) != {*EXISTING, *NEW}
    return {
        "title": "Finding the target again: the search ladder vs the in-place sweep vs a ±90° rotation, same seeds"
        + (" (QUICK: runs cut at 12 s simulated — a smoke test)" if quick else "")
        + (" — REDUCED run: fewer seeds than the acceptance's 20" if reduced and not quick else "")
        + (
            f" — CUT SHORT: {len(rows)} of {planned} runs finished (MISSION_BENCH_BUDGET_S); the same command goes on"
            if len(rows) < planned and not quick
            else ""
        ),
        "figures": [f.to_json() for f in figures],
        "details": {
            "searches": {s: DESCRIBE[s] for s in searches},
            "by_search": cells,
            "seeds_ladder": seeds,
            "seeds_baselines": baseline_seeds,
            "scenarios": list(scenarios),
            "runs_finished": len(rows),
            "runs_planned": planned,
            "workers": workers,
            "wall_s": round(wall, 1),
            "max_duration_s": max_duration,
            "reduced": reduced,
            "full_run": "mission bench --only search",
            "runs_log": "search_runs.jsonl",
            "sweep_dirs": dirs,
            "engine": "mission sweep (mission/sweep), Dask LocalCluster on 127.0.0.1",
        },
        "plots": plots,
    }


def _plot(cells: dict[str, dict[str, Any]], out: Path) -> str | None:
    """Success rate and worst re-acquisition per scenario, the searches side by side."""
    if not cells:
        return None
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = [s for s in (*EXISTING, *NEW) if any(s in c for c in cells.values())]
    searches = list(cells)
    fig, axes = plt.subplots(2, 1, figsize=(11, 7), sharex=True)
    x = np.arange(len(names))
    w = 0.8 / len(searches)
    for i, search in enumerate(searches):
        c = cells[search]
        at = x + (i - (len(searches) - 1) / 2) * w
        rate = [c[n]["success_rate"] if n in c else np.nan for n in names]
        worst = [(c[n]["reacquisition_s_worst"] or 0) if n in c else np.nan for n in names]
        bars = axes[0].bar(at, rate, w, label=f"{search}: {DESCRIBE[search]}")
        axes[1].bar(at, worst, w, color=bars.patches[0].get_facecolor())
        for xi, n in zip(at, names, strict=True):
            if n in c and c[n]["success_rate"] == 0:  # a bar of height 0 is invisible: say it
                axes[0].text(xi, 0.01, "0", ha="center", va="bottom", fontsize=7)
            if n in c and c[n]["loss_events"] and c[n]["reacquisition_s_worst"] is None:
                axes[1].text(xi, 0.1, "×", ha="center", va="bottom", fontsize=9)
    axes[0].set_ylim(0, 1.05)
    axes[0].set_ylabel("success rate")
    fig.legend(fontsize=8, loc="upper center", ncol=1, frameon=False)
    axes[1].axhline(REACQUISITION_GOAL_S, color="grey", ls="--", lw=0.8)
    axes[1].set_ylabel("worst re-acquisition (s)\n× = no loss recovered")
    runs = {n: max(cells[s][n]["runs"] for s in searches if n in cells[s]) for n in names}
    axes[1].set_xticks(x, [f"{n}\n(≤{runs[n]} seeds)" for n in names], fontsize=7, rotation=20)
    fig.tight_layout(rect=(0, 0, 1, 0.9))
    name = "search.png"
    save_figure(fig, out / name)
    return name


def _trajectories(row: dict[str, Any], search: str, out: Path) -> Path:
    """The run's trajectories picture; for a row carried over from another checkout (its report folder was
    not committed) the run is made again, into ``<out>/search_typical/`` — the simulation is deterministic
    per seed, and a run made again that ends otherwise than its row is an error (the rows are not of this
    code)."""
    picture = out / row["sweep_dir"] / row["report_dir"] / "trajectories.png"
    if picture.is_file():
        return picture
    tree = None if search == "ladder" else _relative(variant_trees(search, out) / _tree_of(row["scenario"]))
    plan = SweepPlan((row["scenario"],), (int(row["seed"]),), tree=tree, pictures="all")
    where = out / "search_typical" / search
    _resumable(where, plan)  # another code's or tree's picture run there: start afresh
    again = run_sweep(plan, where, workers=1, progress=False, summary=False)
    run_id = plan.runs()[0].run_id
    redo = next(r for r in again.rows if r["run_id"] == run_id)  # the directory may hold other seeds' runs
    picture = where / redo["report_dir"] / "trajectories.png"
    if redo["success"] != row["success"] or redo["reason"] != row["reason"]:
        raise RuntimeError(
            f"{search} {row['scenario']} seed {row['seed']}: made again, it gave '{redo['reason']}' "
            f"where the recorded row says '{row['reason']}' — the rows are not of this code"
        )
    return picture


def _typical(rows: list[dict[str, Any]], out: Path) -> str | None:
    """The trajectories of one run of TYPICAL_SCENARIO, a seed every search ran, side by side: the seed whose
    ladder re-acquisition time is the median of the ladder's runs (a typical search, not the best)."""
    ladder = [r for r in rows if r["search"] == "ladder" and r["scenario"] == TYPICAL_SCENARIO and r.get("pictures")]
    searches = sorted({r["search"] for r in rows}, key=SEARCHES.index)
    common = [
        r
        for r in ladder
        if all(
            any(
                o["search"] == s and o["scenario"] == TYPICAL_SCENARIO and o["seed"] == r["seed"] and o.get("pictures")
                for o in rows
            )
            for s in searches
        )
    ]
    if not common:
        return None
    common.sort(key=lambda r: r.get("reacquisition_max_s") or 0.0)
    seed = common[len(common) // 2]["seed"]
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(searches), figsize=(5.5 * len(searches), 3.8))
    for ax, search in zip(np.atleast_1d(axes), searches, strict=True):
        r = next(o for o in rows if o["search"] == search and o["scenario"] == TYPICAL_SCENARIO and o["seed"] == seed)
        ax.imshow(plt.imread(_trajectories(r, search, out)))
        ax.set_axis_off()
        verdict = "succeeded" if r["success"] else "failed"
        ax.set_title(f"{search}: {verdict}\n{str(r['reason'])[:70]}", fontsize=7)
    fig.tight_layout()
    name = "search_typical.png"
    save_figure(fig, out / name)
    return name
