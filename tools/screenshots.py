"""Regenerate the screenshots in ``docs/``: the live page during a simulated run, and a run report.

    python -m tools.screenshots docs/ [--live mission_full:30] [--report follow_occlusion:40]

Runs a scenario with the live view and photographs the page at the end, and runs another with the
report observers and photographs report.html, in headless Chromium (tools.browser). Needs Debian's
`chromium` (scripts/bootstrap installs it).
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

from tools.browser import HeadlessChromium


def _run(scenario: str, seconds: float, observers: list) -> Path:
    """Run `scenario` with `observers` and the report pictures; returns the report directory."""
    from mission.app.sim_run import run_scenario
    from mission.viz.report_trees import TransitionTrees
    from mission.viz.run_report import plot_timeline, plot_trajectories, write_json

    report = Path(tempfile.mkdtemp(prefix="mission-report-"))
    outcome, recorder, adapter = run_scenario(
        scenario, max_duration=seconds, observers=[*observers, TransitionTrees(report)]
    )
    write_json(report / "report.json", outcome.to_json())
    title = f"{outcome.scenario} seed {outcome.seed}: {'SUCCESS' if outcome.success else 'FAILURE'}"
    plot_trajectories(
        recorder,
        getattr(adapter, "occupancy_grid", None),
        report / "trajectories.png",
        title,
        getattr(adapter, "dock_xy", None),
    )
    plot_timeline(recorder, report / "timeline.png", title)
    return report


def live_view(out: Path, scenario: str, seconds: float, width: int = 1600, height: int = 860) -> Path:
    """The live page at the end of `seconds` of `scenario` (the page is opened after the run: same view)."""
    from mission.viz.web import LiveView

    view = LiveView(0, close_at_end=False, quiet=True)
    try:
        _run(scenario, seconds, [view])
        with HeadlessChromium() as browser:
            browser.open(view.url, width=width, height=height)
            browser.wait_for("document.body && document.body.dataset.ready === '1'")
            browser.wait_for("document.getElementById('camera').naturalWidth > 0")
            return browser.screenshot(out)
    finally:
        view.close()


def report_page(out: Path, scenario: str, seconds: float, width: int = 1400, height: int = 1000) -> Path:
    """The top of report.html of a run of `scenario`."""
    report = _run(scenario, seconds, [])
    with HeadlessChromium() as browser:
        browser.open((report / "report.html").as_uri(), width=width, height=height)
        browser.wait_for("Array.from(document.images).every(i => i.complete && i.naturalWidth > 0)")
        return browser.screenshot(out)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m tools.screenshots", description=__doc__.splitlines()[0])
    p.add_argument("out_dir", type=Path)
    p.add_argument("--live", default="mission_full:30", help="SCENARIO:SECONDS for the live page")
    p.add_argument("--report", default="follow_occlusion:40", help="SCENARIO:SECONDS for the report")
    args = p.parse_args(argv)
    live, live_s = args.live.rsplit(":", 1)
    rep, rep_s = args.report.rsplit(":", 1)
    print(live_view(args.out_dir / "live-view.png", live, float(live_s)))
    print(report_page(args.out_dir / "report.png", rep, float(rep_s)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
