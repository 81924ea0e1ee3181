"""Recording every tick (`mission run --log`), reading it back (`mission viz --log --tick N`), and the report's
trees at each state transition — on a real tree run with real perception (tests/helpers/viz_world.py)."""

from __future__ import annotations

import json
import xml.etree.ElementTree as ET

import pytest

from mission.cli import main
from mission.core.errors import MissionError
from mission.viz.report_trees import TransitionTrees
from mission.viz.tick_log import TickLog, read_log
from tests.helpers.viz_world import WATCH_NODES, step, watch_runner

SVG = "{http://www.w3.org/2000/svg}"
TICKS = 8  # 3 ticks seeing the marker (FOLLOW), then SEARCH until the 0.35 s sweep fails at tick 8


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    """One run of the watch tree with a tick log and the report trees; the files it left."""
    tmp = tmp_path_factory.mktemp("run")
    import py_trees

    py_trees.blackboard.Blackboard.clear()
    runner, world = watch_runner(tmp)
    log, trees = TickLog(tmp / "run.jsonl"), TransitionTrees(tmp / "report")
    observers = [log, trees]
    try:
        for o in observers:
            runner.attach(o)
        step(runner, world, TICKS)
        runner.finish({"scenario": "watch", "success": False, "reason": "search timed out"})
    finally:
        runner.close()
        py_trees.blackboard.Blackboard.clear()
    return tmp


def test_log_has_a_header_one_line_per_tick_and_an_end(recorded):
    lines = (recorded / "run.jsonl").read_text().splitlines()
    assert len(lines) == 1 + TICKS + 1
    header = json.loads(lines[0])
    assert header["kind"] == "header" and header["nodes"] == len(WATCH_NODES)
    assert header["tree"]["type"] == "ReactiveFallback"  # XML tags, not py_trees classes
    assert header["map"]["width"] > 0 and len(header["map"]["affine"]) == 2
    assert json.loads(lines[-1])["kind"] == "end"


def test_each_tick_records_statuses_feedback_timing_and_blackboard_use(recorded):
    log = read_log(recorded / "run.jsonl")
    assert log.tick_numbers() == list(range(1, TICKS + 1))
    first, searching, last = log.record(1), log.record(5), log.record(TICKS)
    sweep, follow = WATCH_NODES.index("SearchSweep"), WATCH_NODES.index("FollowTarget")
    assert first["state"] == "FOLLOW" and first["nodes"][follow][0] == "RUNNING"
    assert "following target" in first["nodes"][follow][1]
    assert searching["state"] == "SEARCH" and searching["nodes"][sweep][0] == "RUNNING"
    assert last["status"] == "FAILURE" and last["nodes"][sweep][0] == "FAILURE"
    # own tick time for ticked nodes, null for nodes the tick did not reach
    assert first["nodes"][follow][2] > 0 and first["nodes"][sweep][2] is None
    # blackboard keys by node id: FollowTarget writes the nav goal, SearchSweep the twist
    assert "/goal/nav_goal" in first["bb"]["write"][str(follow)]
    assert "/goal/twist" in searching["bb"]["write"][str(sweep)]
    assert "/target/tracks" in first["bb"]["read"][str(WATCH_NODES.index("IsTargetVisible"))]
    # what the camera saw, in pixels, for overlays
    assert first["detections"][0]["id"] == 7 and len(first["detections"][0]["corners"]) == 4
    assert first["robot"] == [0.0, 0.0, 0.0] and first["truth"]["distance"] == pytest.approx(1.0)


def test_viz_log_tick_renders_the_tree_as_it_was(recorded, tmp_path, capsys):
    out = tmp_path / "t5.svg"
    assert main(["viz", "--log", str(recorded / "run.jsonl"), "--tick", "5", "--format", "svg", "-o", str(out)]) == 0
    groups = {
        g.get("data-name"): g.get("class").split()
        for g in ET.parse(out).getroot().iter(f"{SVG}g")
        if "node" in g.get("class", "").split()
    }
    assert list(groups) == WATCH_NODES
    assert "st-RUNNING" in groups["SearchSweep"] and "st-FAILURE" in groups["IsTargetVisible"]
    assert "st-INVALID" in groups["FollowTarget"]
    assert main(["viz", "--log", str(recorded / "run.jsonl"), "--tick", "1", "--format", "unicode"]) == 0
    text = capsys.readouterr().out
    assert "● FollowTarget" in text and "following target" in text and "· SearchSweep" in text


def test_viz_log_asks_for_a_tick_that_exists(recorded, capsys):
    assert main(["viz", "--log", str(recorded / "run.jsonl"), "--tick", "99"]) == 2
    assert "no tick 99; the log has ticks 1..8" in capsys.readouterr().err


def test_a_cut_off_log_is_read_up_to_its_last_whole_line_and_a_bad_line_is_named(recorded, tmp_path):
    text = (recorded / "run.jsonl").read_text()
    cut = tmp_path / "cut.jsonl"
    cut.write_text(text[: text.rindex('{"tick":5') + 40])  # the run died while writing tick 5
    assert read_log(cut).tick_numbers() == [1, 2, 3, 4]
    bad = tmp_path / "bad.jsonl"
    lines = text.splitlines()
    bad.write_text("\n".join([*lines[:3], "{not json", *lines[3:]]) + "\n")
    with pytest.raises(MissionError, match=r"bad\.jsonl:4: not JSON"):
        read_log(bad)


def test_garbage_given_as_a_log_says_what_it_is_not_and_what_was_expected(tmp_path, capsys):
    garbage = bytes(range(128, 256)) * 3
    (tmp_path / "x.btlog").write_bytes(garbage)
    (tmp_path / "x.jsonl").write_bytes(garbage)
    assert main(["viz", "--log", str(tmp_path / "x.btlog")]) == 2
    assert main(["viz", "--log", str(tmp_path / "x.jsonl")]) == 2
    err = capsys.readouterr().err.splitlines()
    assert err == [
        f"mission: error: {tmp_path / 'x.btlog'}: not a Groot2 .btlog (it does not start with the log's header); "
        "expected a log written by `mission run --btlog` or BT.CPP's Groot2 file logger",
        f"mission: error: {tmp_path / 'x.jsonl'}: not a tick log (binary data at byte 0); expected the JSON lines "
        "`mission run --log` writes, or a Groot2 .btlog",
    ]


def test_report_has_the_tree_at_each_state_transition(recorded):
    report = recorded / "report"
    svgs = sorted(p.name for p in (report / "trees").glob("*.svg"))
    # start (→ FOLLOW), FOLLOW → SEARCH, and the final tick
    assert [s.split("_", 2)[2] for s in svgs] == ["follow.svg", "search.svg", "search.svg"]
    titles = [
        next(t for t in ET.parse(report / "trees" / s).getroot().iter(f"{SVG}text") if t.get("class") == "title").text
        for s in svgs
    ]
    assert "start → FOLLOW" in titles[0] and "FOLLOW → SEARCH" in titles[1] and "final tick" in titles[2]
    page = (report / "report.html").read_text()
    assert all(f"trees/{s}" in page for s in svgs) and "trajectories.png" in page


def test_a_btlog_asked_for_a_tick_it_does_not_have_says_it_counts_changes_not_ticks(tmp_path, capsys):
    """A run of 45 ticks whose tree stays RUNNING after the first: its .btlog has one timestamp, and asking for
    tick 30 says why, rather than "ticks 1..1" for a 45-tick run."""
    log = tmp_path / "run.btlog"
    assert main(["run", "--scenario", "explore_dock", "--max-duration", "3", "--btlog", str(log)]) == 1
    capsys.readouterr()
    assert main(["viz", "--log", str(log), "--tick", "30"]) == 2
    err = capsys.readouterr().err.strip()
    assert "no timestamp 30; this .btlog has 1 (1..1): a .btlog records status changes, not ticks" in err


def test_the_first_line_of_a_log_says_what_ran_tree_config_and_perception(tmp_path, capsys):
    log = tmp_path / "run.jsonl"
    assert main(["run", "--scenario", "explore_dock", "--max-duration", "0.3", "--log", str(log)]) == 1
    first = read_log(log).header
    assert first["tree_file"].endswith("explore_dock.xml") and first["scenario"] == "explore_dock"
    assert first["config_file"].endswith("sim_aruco.yaml")  # the shipped config a run without --config uses
    assert first["perception"] == [{"name": "aruco", "plugin": "aruco"}]
