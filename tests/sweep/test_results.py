"""A sweep's matrix, its results table and the comparison of two sweeps, read as a user reads them."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from mission import cli
from mission.app.provenance import files_fingerprint, source_fingerprint
from mission.core.errors import ConfigError
from mission.sweep.compare import compare_sweeps
from mission.sweep.plan import SweepPlan, parse_seeds
from mission.sweep.stats import Rate, compare
from mission.sweep.store import SweepStore
from mission.sweep.table import outcome_row, read_jsonl, read_parquet
from mission.sweep.task import RunResult


def test_seeds_are_ranges_and_lists_each_once_in_order():
    assert parse_seeds("0-3") == (0, 1, 2, 3)
    assert parse_seeds("7") == (7,)
    assert parse_seeds("0-2,10,1,20-21") == (0, 1, 2, 10, 20, 21)
    for bad in ("3-1", "a-b", "-1", ""):
        with pytest.raises(ConfigError, match="--seeds"):
            parse_seeds(bad)


def test_the_matrix_is_every_combination_named_by_what_decides_the_outcome_seed_major():
    plan = SweepPlan.from_args(
        "follow_open,explore_dock", "0-1", ["SearchSweep.angular_speed=0.6,1.0", "run.tick_hz=10,15"]
    )
    runs = plan.runs()
    assert len(runs) == 2 * 2 * 2 * 2 and len({r.run_id for r in runs}) == len(runs)
    assert [r.seed for r in runs[:8]] == [0] * 8  # every cell's seed 0 before any seed 1
    first = runs[0]
    assert first.run_id == "follow_open__SearchSweep.angular_speed=0.6__run.tick_hz=10/seed-0000"
    assert first.cell == "follow_open SearchSweep.angular_speed=0.6 run.tick_hz=10"
    assert first.command() == (
        "mission run --scenario follow_open --seed 0 --set SearchSweep.angular_speed=0.6 --set run.tick_hz=10"
    )


def test_a_cell_name_that_is_not_a_safe_folder_name_is_rewritten_and_kept_apart_by_a_hash():
    plan = SweepPlan.from_args("follow_open", "0", ["camera={width: 320, height: 240},{width: 320, height: 480}"])
    a, b = (r.run_id for r in plan.runs())
    assert a != b and "/" not in a.split("/seed-")[0] and " " not in a


def _record(store: SweepStore, plan: SweepPlan, failing: set[int]) -> None:
    store.open(plan)
    for spec in plan.runs():
        ok = spec.seed not in failing
        reason = "followed the target to the end" if ok else "2 loss event(s) never recovered"
        outcome = {
            "success": ok,
            "reason": reason,
            "sim_time_s": 10.0,
            "wall_time_s": 4.2,
            "ticks": 150,
            "metrics": {
                "loss_events": 2,
                "loss_events_recovered": 2 if ok else 0,
                "collisions": 0,
                "reacquisition_time_s": {"n": 2, "max": 3.5} if ok else None,
                "dock": {
                    "lateral_m": 0.01 + 0.001 * spec.seed,
                    "distance_m": 0.02 if ok else 0.04,
                    "standoff_m": 0.3,
                    "skew_deg": 2.0,
                },
            },
        }
        row = outcome_row(spec, outcome, [1.2, 3.5] if ok else [], pictures=False, worker="here:1")
        store.record(RunResult(spec.run_id, row, {"report.json": b"{}"}))


def test_the_table_is_the_same_in_jsonl_and_parquet_and_a_result_recorded_twice_counts_once(tmp_path):
    plan = SweepPlan.from_args("follow_occlusion", "0-9", ["HoldLastGoal.timeout_s=2,3"])
    store = SweepStore(tmp_path / "a")
    _record(store, plan, failing={3})
    spec = plan.runs()[0]
    again = RunResult(spec.run_id, dict(store.rows[spec.run_id], worker="elsewhere:2"), {})
    assert store.record(again) is False and store.duplicates == 1
    store.write_table()
    jsonl = read_jsonl(tmp_path / "a" / "runs.jsonl")
    parquet = read_parquet(tmp_path / "a" / "results.parquet")
    assert len(jsonl) == len(parquet) == 20
    assert {r["run_id"]: (r["success"], r["params"], r["reacquisition_times_s"]) for r in jsonl} == {
        r["run_id"]: (r["success"], r["params"], r["reacquisition_times_s"]) for r in parquet
    }
    import pyarrow.parquet as pq

    columns = pq.read_schema(tmp_path / "a" / "results.parquet").names
    assert "set:HoldLastGoal.timeout_s" in columns and "metrics_json" in columns
    assert (tmp_path / "a" / "runs" / spec.run_id / "report.json").is_file()


def test_a_sweep_directory_resumes_only_with_what_its_outcomes_depend_on(tmp_path):
    SweepStore(tmp_path).open(SweepPlan.from_args("follow_open", "0-1", max_duration=5.0))
    SweepStore(tmp_path).open(SweepPlan.from_args("follow_open", "0-9", max_duration=5.0))  # more seeds: fine
    with pytest.raises(Exception, match=r"holds a sweep made with another max_duration_s .*5\.0.*this one.*None"):
        SweepStore(tmp_path).open(SweepPlan.from_args("follow_open", "0-1"))


def test_a_sweep_directory_made_by_other_code_is_not_resumed(tmp_path):
    plan = SweepPlan.from_args("follow_open", "0-1")
    SweepStore(tmp_path).open(plan)
    sweep = json.loads((tmp_path / "sweep.json").read_text())
    assert sweep["identity"]["source"] == source_fingerprint()
    sweep["identity"]["source"] = "0" * 64  # what another version of mission wrote
    (tmp_path / "sweep.json").write_text(json.dumps(sweep))
    with pytest.raises(Exception, match=r"holds a sweep made with another source"):
        SweepStore(tmp_path).open(plan)


def test_the_source_fingerprint_changes_with_the_code_and_only_with_the_code(tmp_path):
    pkg = tmp_path / "pkg"
    (pkg / "sub").mkdir(parents=True)
    (pkg / "a.py").write_text("x = 1\n")
    (pkg / "sub" / "t.xml").write_text("<root/>\n")
    first = files_fingerprint([("pkg", pkg)])
    (pkg / "notes.png").write_bytes(b"not source")
    assert files_fingerprint([("pkg", pkg)]) == first  # a picture is not code
    (pkg / "sub" / "t.xml").write_text("<root BTCPP_format='4'/>\n")
    assert files_fingerprint([("pkg", pkg)]) != first  # a tree is
    (pkg / "sub" / "t.xml").write_text("<root/>\n")
    assert files_fingerprint([("pkg", pkg)]) == first
    (pkg / "a.py").rename(pkg / "b.py")
    assert files_fingerprint([("pkg", pkg)]) != first  # the same bytes under another name are other code


def test_rates_carry_wilson_intervals_and_flipped_seeds_decide_a_paired_comparison():
    assert Rate(18, 20).text() == "18/20 = 90 % [70–97 %]"
    same = {s: s % 5 != 0 for s in range(20)}
    assert not compare(same, same).significant and compare(same, same).note().startswith("no difference")
    better = {s: True for s in range(20)}
    worse = {s: s >= 9 for s in range(20)}  # seeds 0-8 flip to failures
    c = compare(better, worse)
    assert c.test == "McNemar, paired on 20 seeds" and c.significant and "B worse by 45 points" in c.note()
    unpaired = compare(better, {s + 100: s >= 9 for s in range(20)})
    assert unpaired.test == "Fisher's exact" and unpaired.significant


def test_compare_puts_two_sweeps_side_by_side_with_a_significance_note(tmp_path, capsys):
    plan = SweepPlan.from_args("follow_occlusion,search_corner", "0-19")
    _record(SweepStore(tmp_path / "before"), plan, failing=set(range(10)))
    _record(SweepStore(tmp_path / "after"), plan, failing={0})
    rows, notes = compare_sweeps(tmp_path / "before", tmp_path / "after")
    assert [r.scenario for r in rows] == ["follow_occlusion", "search_corner"] and not notes
    assert all(r.comparison.significant and r.comparison.b.k == 19 for r in rows)
    page = tmp_path / "compare.html"
    assert cli.main(["sweep", "--compare", str(tmp_path / "before"), str(tmp_path / "after"), "-o", str(page)]) == 0
    out = capsys.readouterr().out
    assert "A 10/20 = 50 %" in out and "B better by 45 points, significant (p = " in out
    assert "McNemar, paired on 20 seeds" in page.read_text()


def test_compare_matches_scenarios_when_the_two_sweeps_tried_different_settings(tmp_path):
    _record(SweepStore(tmp_path / "base"), SweepPlan.from_args("follow_occlusion", "0-9"), failing={1})
    tuned = SweepPlan.from_args("follow_occlusion", "0-9", ["HoldLastGoal.timeout_s=5"])
    _record(SweepStore(tmp_path / "tuned"), tuned, failing=set())
    rows, notes = compare_sweeps(tmp_path / "base", tmp_path / "tuned")
    assert len(rows) == 1 and rows[0].b_set == "HoldLastGoal.timeout_s=5" and "scenarios matched" in notes[0]
    assert not rows[0].comparison.significant  # one flipped seed of ten proves nothing


def test_compare_of_a_folder_that_is_no_sweep_is_a_one_line_error(tmp_path, capsys):
    assert cli.main(["sweep", "--compare", str(tmp_path), str(Path(tmp_path) / "x")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "not a sweep directory" in err


def test_the_summary_draws_every_figure_it_has_data_for_and_links_every_failing_run(tmp_path):
    from mission.sweep.summary import write_summary

    store = SweepStore(tmp_path)
    _record(
        store,
        SweepPlan.from_args("follow_occlusion,mission_full", "0-9", ["HoldLastGoal.timeout_s=2,3"]),
        failing={2, 7},
    )
    page = write_summary(store).read_text()
    pictures = {p.name for p in (tmp_path / "summary").iterdir()}
    assert pictures == {
        "success_by_cell.png",
        "success_by_HoldLastGoal.timeout_s.png",
        "reacquisition_cdf.png",
        "dock_errors.png",
    }
    assert "16/20 = 80 %" not in page and "8/10 = 80 % [49–94 %]" in page  # per cell, with its interval
    failing = [r for r in store.rows.values() if not r["success"]]
    assert len(failing) == 8 and all(r["command"] in page for r in failing)
    assert "seeds 0-9 · --set HoldLastGoal.timeout_s=2,3" in page
