"""`mission run` with every viewer at once, in the real pybullet simulation: a tick log, a GIF, the report
with the tree at each state transition, and the live view — all from one short run."""

from __future__ import annotations

import re

import imageio.v3 as iio

from mission.cli import main
from mission.viz.tick_log import read_log


def test_run_writes_log_recording_and_report_trees_and_serves_the_page(tmp_path, capsys):
    report, log, gif = tmp_path / "report", tmp_path / "run.jsonl", tmp_path / "run.gif"
    code = main(
        [
            "run",
            "--scenario",
            "follow_open",
            "--max-duration",
            "1.0",
            "--quiet",
            "--report",
            str(report),
            "--log",
            str(log),
            "--record",
            str(gif),
            "--serve",
            "--port",
            "0",
        ]
    )
    captured = capsys.readouterr()
    assert code == 0, captured.out + captured.err
    assert re.search(r"live view at http://127\.0\.0\.1:\d+/", captured.err)

    run = read_log(log)
    assert run.header["scenario"] == "follow_open" and run.end is not None
    assert len(run.ticks) == run.end["outcome"]["ticks"]
    assert run.ticks[-1]["state"] == "FOLLOW" and run.ticks[-1]["detections"]
    assert run.ticks[-1]["truth"]["distance"] > 0

    frames = iio.imread(gif, index=None)
    sim_time = run.end["outcome"]["sim_time_s"]
    assert len(frames) == int(sim_time * 5 + 1e-6) + 1  # 5 frames per simulated second, from t = 0
    assert frames.shape[1] == 40 + 300  # banner + 300 px views

    trees = sorted((report / "trees").glob("*.svg"))
    assert trees and trees[0].name.endswith("_follow.svg")
    page = (report / "report.html").read_text()
    assert "SUCCESS" in page and all(f"trees/{t.name}" in page for t in trees)
    assert (report / "report.json").is_file() and (report / "trajectories.png").is_file()


def test_bad_viewer_arguments_stop_before_the_simulation_starts(tmp_path, capsys):
    assert main(["run", "--scenario", "follow_open", "--record", str(tmp_path / "x.avi"), "--quiet"]) == 2
    assert "expected a .gif or .mp4" in capsys.readouterr().err


def test_a_report_folder_used_again_shows_only_the_second_runs_trees(tmp_path, capsys):
    report = tmp_path / "report"
    mission_run = ["run", "--max-duration", "0.5", "--report", str(report)]
    assert main([*mission_run, "--scenario", "explore_dock"]) == 1
    assert main([*mission_run, "--scenario", "follow_open"]) in (0, 1)
    trees = sorted(p.name for p in (report / "trees").glob("*.svg"))
    assert trees and all("explore" not in name for name in trees), trees  # explore_dock's moments are gone
    page = (report / "report.html").read_text()
    assert all(f"trees/{name}" in page for name in trees)
