"""The run's own observers — the terminal status and the metrics — in a run whose trees come and go (issue 32:
an action server's goals): a real run in the simulation (tests/helpers/goal_runs.py) with no tree, then a goal
tree, then none, then another."""

from __future__ import annotations

import io

from mission.app.live_status import LiveStatus
from mission.app.metrics import MetricsRecorder
from tests.helpers.goal_runs import DOCK_TREE, EXPLORE_TREE, GOAL, STAGING, goal_runner, steps


def test_the_terminal_status_says_no_tree_and_gets_a_line_at_each_change_and_metrics_go_on():
    out = io.StringIO()  # not a terminal: a line per change
    status = LiveStatus("dock", stream=out, every_s=1000.0)
    metrics = MetricsRecorder()
    runner = goal_runner(status, metrics)
    try:
        steps(runner, 3)
        runner.start_tree(DOCK_TREE, GOAL)
        steps(runner, 3)
        runner.stop_tree()
        steps(runner, 3)
        runner.start_tree(EXPLORE_TREE)
        steps(runner, 3)
        runner.finish(None)
    finally:
        runner.close()
    lines = out.getvalue().splitlines()
    assert len(lines) == 4, lines  # the first tick, then the first tick after each change
    assert lines[0].endswith("no tree")
    assert lines[1].endswith(f"staged › {STAGING}")  # the last three of the active branch
    assert lines[2].endswith("no tree")
    assert " › " in lines[3] and STAGING not in lines[3]
    assert len(metrics.times) == 12  # ground truth every step, with a tree or without
