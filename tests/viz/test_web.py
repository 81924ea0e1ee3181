"""The live web view (`mission run --serve`) and the recorded-log page, in a real headless Chromium.

A real tree runs with real perception (tests/helpers/viz_world.py) while the test ticks it; the browser must show
every node, follow the statuses as the tree ticks, show the camera with overlays and the map, and let a
person scrub back through ticks — live and from a recorded log opened as a file.
"""

from __future__ import annotations

import json
import urllib.error
import urllib.request

import pytest

from mission.cli import main
from mission.core.errors import MissionError
from mission.viz.tick_log import TickLog
from mission.viz.web import LiveView
from tests.helpers.viz_world import WATCH_NODES, step, watch_runner
from tools.browser import HeadlessChromium

STATUSES_JS = """Object.fromEntries(Array.from(document.querySelectorAll('#tree .node')).map(
    g => [g.dataset.name, g.getAttribute('class').match(/st-(\\w+)/)[1]]))"""
STROKE_JS = """getComputedStyle(Array.from(document.querySelectorAll('#tree .node'))
    .find(g => g.dataset.name === '%s').querySelector('.frame')).stroke"""


def scrub_to(browser: HeadlessChromium, index: int) -> None:
    browser.evaluate(
        f"(() => {{ const s = document.getElementById('slider'); s.value = {index};"
        " s.dispatchEvent(new Event('input')); return true; })()"
    )


def test_live_page_follows_the_tree_and_a_recorded_log_can_be_scrubbed(tmp_path):
    runner, world = watch_runner(tmp_path)
    view = LiveView(0, close_at_end=False, quiet=True)
    observers = [view, TickLog(tmp_path / "run.jsonl")]
    try:
        with HeadlessChromium() as browser:
            # opened before the run starts: it waits, then reloads itself when the run begins
            browser.open(view.url, width=1280, height=800)
            browser.wait_for("document.body && document.body.textContent.includes('waiting for the run')")
            for o in observers:
                runner.attach(o)
            step(runner, world, 1)
            browser.wait_for("document.body && document.body.dataset.tick === '1'")

            names = browser.evaluate("Array.from(document.querySelectorAll('#tree .node')).map(g => g.dataset.name)")
            assert names == WATCH_NODES
            shown = browser.evaluate("document.getElementById('tree').textContent")
            assert all(name in shown for name in WATCH_NODES)
            following = browser.evaluate(STATUSES_JS)
            assert following["FollowTarget"] == "RUNNING" and following["SearchSweep"] == "INVALID"
            assert browser.evaluate("document.getElementById('state-pill').textContent") == "FOLLOW"
            amber = browser.evaluate(STROKE_JS % "FollowTarget")
            browser.wait_for("document.getElementById('camera').naturalWidth === 320")  # JPEG with overlays
            assert browser.evaluate("document.querySelectorAll('#m-robot circle').length") == 1

            step(runner, world, 4)  # the marker is gone: SEARCH
            browser.wait_for("document.body.dataset.tick === '5'")
            searching = browser.evaluate(STATUSES_JS)
            assert searching["SearchSweep"] == "RUNNING" and searching["IsTargetVisible"] == "FAILURE"
            assert searching["FollowTarget"] == "INVALID"
            assert browser.evaluate("document.getElementById('state-pill').textContent") == "SEARCH"
            assert browser.evaluate(STROKE_JS % "IsTargetVisible") != browser.evaluate(STROKE_JS % "SearchSweep")
            assert browser.evaluate(STROKE_JS % "SearchSweep") == amber  # running looks the same everywhere

            scrub_to(browser, 0)  # back in time, while live
            assert browser.evaluate(STATUSES_JS) == following
            assert browser.evaluate("document.getElementById('follow').checked") is False

            step(runner, world, 3)  # the sweep times out: the tree fails
            runner.finish({"success": False})
            browser.wait_for("document.getElementById('conn').textContent === 'run finished'")
            assert browser.console_errors() == []

            # the recorded log as a page of its own (file://, no server), scrubbed with the slider
            page = tmp_path / "run.html"
            assert main(["viz", "--log", str(tmp_path / "run.jsonl"), "--format", "html", "-o", str(page)]) == 0
            browser.open(page.as_uri(), width=1280, height=800)
            browser.wait_for("document.body.dataset.ready === '1'")
            assert browser.evaluate("document.getElementById('slider').max") == "7"
            assert browser.evaluate(STATUSES_JS)["Watch"] == "FAILURE"  # opens at the last tick
            scrub_to(browser, 0)
            assert browser.evaluate(STATUSES_JS) == following
            assert browser.evaluate("document.body.dataset.tick") == "1"
            assert browser.console_errors() == []
            shot = browser.screenshot(tmp_path / "page.png")
            assert shot.stat().st_size > 10_000
    finally:
        view.close()
        runner.close()


def test_server_answers_on_localhost_and_a_busy_port_is_one_clear_error(tmp_path):
    runner, world = watch_runner(tmp_path)
    view = LiveView(0, close_at_end=False, quiet=True)
    try:
        assert view.url.startswith("http://127.0.0.1:")
        with pytest.raises(urllib.error.HTTPError) as err:
            urllib.request.urlopen(view.url + "camera.jpg", timeout=5)
        assert err.value.code == 404  # no frame yet
        runner.attach(view)
        step(runner, world, 2)
        with urllib.request.urlopen(view.url + "camera.jpg", timeout=5) as r:
            assert r.headers["Content-Type"] == "image/jpeg" and r.read(2) == b"\xff\xd8"
        with urllib.request.urlopen(view.url + "api/history?after=1", timeout=5) as r:
            assert [rec["tick"] for rec in json.load(r)] == [2]
        tree = json.dumps(view.header()["tree"]).encode()
        with urllib.request.urlopen(urllib.request.Request(view.url + "api/tree.svg", data=tree), timeout=5) as r:
            assert b'data-name="SearchSweep"' in r.read()
        with pytest.raises(MissionError, match=rf"--port {view.port}: 127\.0\.0\.1:{view.port} is already in use"):
            LiveView(view.port, quiet=True)
    finally:
        view.close()
        runner.close()
