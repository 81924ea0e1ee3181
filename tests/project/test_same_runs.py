"""tools/same_runs.py, the run-by-run check a refactor's sweeps are held to (issue 31): two sweeps are the same
when every run ends the same way, for the same reason, with every metric equal; wall-clock fields do not count."""

from __future__ import annotations

import json

from tools.same_runs import main

ROW = {
    "run_id": "explore_dock/seed-0003",
    "success": True,
    "reason": "docked within tolerance",
    "ticks": 812,
    "wall_time_s": 31.2,
    "worker": "vm:1",
    "metrics": {"dock": {"lateral_m": 0.0071}, "transitions": [0.0, 9.4]},
}


def write(path, *rows):
    path.write_text("".join(json.dumps(r) + "\n" for r in rows))
    return path


def test_the_same_runs_on_another_machine_are_identical(tmp_path, capsys):
    other = {**ROW, "wall_time_s": 55.0, "worker": "ci:7"}
    assert main([str(write(tmp_path / "a", ROW)), str(write(tmp_path / "b", other))]) == 0
    assert (
        capsys.readouterr().out.strip()
        == "1 of 1 runs identical (outcome, reason, every metric); 1 with the same outcome"
    )


def test_one_metric_moved_deep_inside_a_run_is_named(tmp_path, capsys):
    moved = {**ROW, "metrics": {"dock": {"lateral_m": 0.0072}, "transitions": [0.0, 9.4]}}
    assert main([str(write(tmp_path / "a", ROW)), str(write(tmp_path / "b", moved))]) == 1
    out = capsys.readouterr().out.splitlines()
    assert out[0] == "explore_dock/seed-0003: metrics.dock.lateral_m: 0.0071 != 0.0072"
    assert out[-1] == "0 of 1 runs identical (outcome, reason, every metric); 1 with the same outcome"


def test_a_run_missing_after_is_a_difference(tmp_path, capsys):
    second = {**ROW, "run_id": "explore_dock/seed-0004"}
    assert main([str(write(tmp_path / "a", ROW, second)), str(write(tmp_path / "b", ROW))]) == 1
    assert "explore_dock/seed-0004: missing in B" in capsys.readouterr().out
