"""The terminal status of a running mission (`mission run` without --quiet): in a log, one line per state
change with sim time, state, target distance, the active branch and a progress bar of the run's length."""

from __future__ import annotations

import io

from mission.app.live_status import LiveStatus
from tests.helpers.viz_world import step, watch_runner


def test_a_log_gets_a_line_per_state_change_with_progress_distance_and_branch(tmp_path):
    runner, world = watch_runner(tmp_path)
    out = io.StringIO()  # not a terminal: plain lines, no redraw
    status = LiveStatus("watch", stream=out, every_s=100.0, total_s=0.8)
    try:
        runner.attach(status)
        step(runner, world, 5)  # FOLLOW for 3 ticks, then SEARCH
        runner.finish(None)
    finally:
        runner.close()
    lines = out.getvalue().splitlines()
    assert len(lines) == 2
    assert "FOLLOW" in lines[0] and "target  1.0 m" in lines[0] and "FOLLOW › FollowTarget" in lines[0]
    assert "▕░░░░░░░░░░░░░░░░▏  0%" in lines[0]
    assert "SEARCH" in lines[1] and "Watch › SearchSweep" in lines[1]
    assert "▕██████░░░░░░░░░░▏ 38%" in lines[1]  # 0.3 s of 0.8 s
