"""The viewers of a run whose trees come and go (issue 32: an action server's goals).

A real run in the simulation (tests/helpers/goal_runs.py) starts with no tree; the test starts a goal tree,
stops it, starts another, stepping the real loop between. The live view is read as a browser does: real HTTP
GETs to 127.0.0.1 (the page, /api/header, /api/history, /tree.svg, the server-sent events), and in a real
headless Chromium. The tick log and the report's trees hold one tree: the first.
"""

from __future__ import annotations

import json
import logging
import urllib.error
import urllib.request

import pytest

from mission.viz.report_trees import TransitionTrees
from mission.viz.tick_log import TickLog, read_log
from mission.viz.web import NO_GOAL, STOPPED, LiveView
from tests.helpers.goal_runs import DOCK_ROOT, DOCK_TREE, EXPLORE_ROOT, EXPLORE_TREE, GOAL, STAGING, goal_runner, steps


def get(url: str) -> bytes:
    with urllib.request.urlopen(url, timeout=5) as r:
        return r.read()


def get_json(url: str):
    return json.loads(get(url))


def names(node: dict) -> list[str]:
    return [node["name"], *(n for c in node.get("children", []) for n in names(c))]


def header_event(url: str, after: int) -> dict:
    """The first event the stream sends a page that connects (the header it must be showing)."""
    with urllib.request.urlopen(f"{url}events?after={after}", timeout=5) as r:
        lines = iter(r.readline, b"")
        for line in lines:
            if line == b"event: header\n":
                return json.loads(next(lines).decode().removeprefix("data: "))
    raise AssertionError("the stream ended before its header event")


def test_the_live_view_waits_for_a_goal_shows_each_tree_and_keeps_a_stopped_one():
    view = LiveView(0, close_at_end=False, quiet=True)
    runner = goal_runner(view)
    url = view.url
    try:
        # no goal yet: a page that says so, no tree, no ticks; the camera goes on
        steps(runner, 3)
        waiting = get_json(url + "api/header")
        assert waiting["tree"] is None and waiting["running"] is False and waiting["notice"] == NO_GOAL
        page = get(url).decode()
        assert NO_GOAL in page and 'class="node' not in page
        assert get_json(url + "api/history") == []
        with pytest.raises(urllib.error.HTTPError) as err:
            get(url + "tree.svg")
        assert err.value.code == 404
        assert get(url + "camera.jpg")[:2] == b"\xff\xd8"

        # a goal: its tree, from its first tick
        runner.start_tree(DOCK_TREE, GOAL)
        steps(runner, 5)
        docking = get_json(url + "api/header")
        assert docking["tree"]["name"] == DOCK_ROOT and docking["running"] is True and not docking["notice"]
        assert docking["tree_file"].endswith(DOCK_TREE) and docking["generation"] > waiting["generation"]
        dock_nodes = names(docking["tree"])
        history = get_json(url + "api/history")
        assert [r["tick"] for r in history] == [4, 5, 6, 7, 8]
        last = history[-1]
        assert len(last["nodes"]) == len(dock_nodes) == docking["nodes"]
        assert last["nodes"][dock_nodes.index(STAGING)][0] == "RUNNING"
        page = get(url).decode()
        assert f'data-name="{STAGING}"' in page and NO_GOAL not in page
        assert f'data-name="{STAGING}"' in get(url + "tree.svg").decode()
        assert header_event(url, 8)["generation"] == docking["generation"]  # an open page keeps this tree

        # the goal ends: the tree stays with its final statuses, and the page says no tree runs
        dock = runner.tree
        runner.stop_tree()
        steps(runner, 3)
        stopped = get_json(url + "api/header")
        assert stopped["tree"] == docking["tree"] and stopped["running"] is False and stopped["notice"] == STOPPED
        assert get_json(url + "api/history") == history  # nothing more: no tree ticked
        page = get(url).decode()
        assert STOPPED in page and f'data-name="{STAGING}"' in page
        assert "no tree runs" in get(url + "tree.svg").decode()
        assert header_event(url, 8)["generation"] == stopped["generation"] > docking["generation"]  # pages reload
        assert dock.pre_tick_handlers == dock.post_tick_handlers == []  # the old tree's instrumentation is gone

        # the next goal, another tree: only it is shown, its ticks from the first
        runner.start_tree(EXPLORE_TREE)
        steps(runner, 2)
        exploring = get_json(url + "api/header")
        assert exploring["tree"]["name"] == EXPLORE_ROOT and exploring["running"] is True
        assert exploring["generation"] > stopped["generation"]
        history = get_json(url + "api/history")
        assert [r["tick"] for r in history] == [12, 13]
        assert all(len(r["nodes"]) == exploring["nodes"] == len(names(exploring["tree"])) for r in history)
        page = get(url).decode()
        assert f'data-name="{EXPLORE_ROOT}"' in page and STAGING not in page and STOPPED not in page
    finally:
        view.close()
        runner.close()


NODE_NAMES_JS = "Array.from(document.querySelectorAll('#tree .node')).map(g => g.dataset.name)"


def test_an_open_page_follows_the_goals_in_a_real_browser():
    from tools.browser import HeadlessChromium

    view = LiveView(0, close_at_end=False, quiet=True)
    runner = goal_runner(view)
    try:
        with HeadlessChromium() as browser:
            steps(runner, 2)
            browser.open(view.url, width=1280, height=800)
            browser.wait_for(f"document.body && document.body.textContent.includes('{NO_GOAL}')")
            runner.start_tree(DOCK_TREE, GOAL)
            steps(runner, 3)  # the page reloads itself on the new header and follows the ticks
            browser.wait_for("document.body && document.body.dataset.tick === '5'")
            assert DOCK_ROOT in browser.evaluate(NODE_NAMES_JS) and STAGING in browser.evaluate(NODE_NAMES_JS)
            assert browser.evaluate("document.getElementById('notice').hidden") is True
            runner.stop_tree()
            steps(runner, 1)
            browser.wait_for("document.getElementById('notice') && !document.getElementById('notice').hidden")
            assert browser.evaluate("document.getElementById('notice').textContent") == STOPPED
            assert browser.evaluate("document.body.dataset.tick") == "5"  # the last tree's last tick stays
            runner.start_tree(EXPLORE_TREE)
            steps(runner, 2)
            browser.wait_for("document.body && document.body.dataset.tick === '8'")
            assert browser.evaluate(NODE_NAMES_JS)[0] == EXPLORE_ROOT
            assert browser.evaluate("document.getElementById('notice').hidden") is True
            assert browser.console_errors() == []
    finally:
        view.close()
        runner.close()


def test_the_tick_log_and_the_report_hold_the_first_goal_tree_and_the_live_view_goes_on(tmp_path, caplog):
    view = LiveView(0, close_at_end=False, quiet=True)
    tick_log = TickLog(tmp_path / "run.jsonl")
    report = TransitionTrees(tmp_path / "report")
    runner = goal_runner(tick_log, report, view)  # the three share each tree's probe
    try:
        steps(runner, 2)
        runner.start_tree(DOCK_TREE, GOAL)
        steps(runner, 4)
        dock = runner.tree
        with caplog.at_level(logging.WARNING):
            runner.start_tree(EXPLORE_TREE)  # preempted: the log and the report end with the first tree
        assert "a tick log holds one tree" in caplog.text
        assert dock.post_tick_handlers == []
        steps(runner, 3)
        explore = get_json(view.url + "api/history")
        assert [r["tick"] for r in explore] == [7, 8, 9] and {r["status"] for r in explore} == {"RUNNING"}
        runner.finish({"success": True})
    finally:
        view.close()
        runner.close()
    logged = read_log(tmp_path / "run.jsonl")
    assert logged.tree().name == DOCK_ROOT and logged.header["tree_file"].endswith(DOCK_TREE)
    assert logged.tick_numbers() == [3, 4, 5, 6] and logged.end == {"kind": "end", "outcome": {"success": True}}
    assert len(logged.record(6)["nodes"]) == logged.header["nodes"]
    svgs = sorted((tmp_path / "report" / "trees").glob("*.svg"))
    assert svgs and all(f'data-name="{STAGING}"' in svg.read_text() for svg in svgs)
    assert all(EXPLORE_ROOT not in svg.read_text() for svg in svgs)
