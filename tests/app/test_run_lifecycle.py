"""A run's lifecycle in the one loop, with real processes and real signals: Ctrl-C or a SIGTERM stops a
simulated mission (or a replay) cleanly — the report is written and marked interrupted with what was
measured so far, recordings are finalized, and the exit code is the shell's 128 + signal."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import imageio.v3 as iio
import pytest

from mission.ros.bag_record import BagRecorder
from mission.sim.scenario import load_scenario
from mission.sim.sim_adapter import SimAdapter

MISSION = [sys.executable, "-m", "mission"]
PYTHON_ENV = {**os.environ, "PYTHONUNBUFFERED": "1"}


class Run:
    """A `mission …` process whose output lines are collected as they come (stdout and stderr merged)."""

    def __init__(self, args: list[str], cwd: Path) -> None:
        self.proc = subprocess.Popen(
            [*MISSION, *args],
            cwd=cwd,
            env=PYTHON_ENV,
            stdin=subprocess.DEVNULL,
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            text=True,
        )
        self.lines: list[str] = []
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self) -> None:
        assert self.proc.stdout is not None
        for line in self.proc.stdout:
            self.lines.append(line.rstrip("\n"))

    def wait_for(self, words: str, timeout: float = 120.0) -> None:
        deadline = time.monotonic() + timeout
        while not any(words in line for line in self.lines):
            if self.proc.poll() is not None or time.monotonic() > deadline:
                raise AssertionError(f"never printed {words!r}; output:\n" + "\n".join(self.lines))
            time.sleep(0.05)

    def finish(self, timeout: float = 120.0) -> int:
        code = self.proc.wait(timeout=timeout)
        self._reader.join(timeout=5)
        return code


@pytest.mark.parametrize(("sig", "code", "name"), [(signal.SIGINT, 130, "SIGINT"), (signal.SIGTERM, 143, "SIGTERM")])
def test_a_signal_mid_mission_writes_the_report_marked_interrupted_and_finalizes_the_recording(
    tmp_path, sig, code, name
):
    report, gif = tmp_path / "report", tmp_path / "run.gif"
    run = Run(
        [
            "run",
            "--scenario",
            "follow_open",
            "--seed",
            "2",
            "--max-duration",
            "600",
            "--report",
            str(report),
            "--record",
            str(gif),
        ],
        tmp_path,
    )
    run.wait_for("FOLLOW")  # the live status line: the mission is ticking
    time.sleep(1.0)  # a few simulated seconds more
    run.proc.send_signal(sig)
    assert run.finish() == code, "\n".join(run.lines)
    assert any(line.startswith("INTERRUPTED: follow_open seed 2: interrupted by " + name) for line in run.lines)

    outcome = json.loads((report / "report.json").read_text())
    assert outcome["interrupted"] is True and outcome["stop_signal"] == name and outcome["success"] is False
    assert 0 < outcome["sim_time_s"] < 600 and outcome["ticks"] > 0
    assert outcome["metrics"]["state_transitions"], "what was measured so far is in the report"
    made_by = outcome["provenance"]  # and what produced it, as for any run
    assert made_by["seed"] == 2 and made_by["scenario"] == "follow_open"
    assert made_by["tree_file"]["path"].endswith("follow.xml") and made_by["config"]["run"]["tick_hz"] > 0
    assert [p["name"] for p in made_by["perception_plugins"]] == ["aruco"] and made_by["packages"]["py_trees"]
    assert (report / "trajectories.png").stat().st_size > 0 and (report / "timeline.png").stat().st_size > 0
    frames = iio.imread(gif, index=None)  # a complete GIF, not a 0-byte file
    assert len(frames) >= 2


def test_ctrl_c_twice_stops_at_once(tmp_path):
    run = Run(["run", "--scenario", "follow_open", "--max-duration", "600", "--serve", "--port", "0"], tmp_path)
    run.wait_for("FOLLOW")
    run.proc.send_signal(signal.SIGINT)
    run.proc.send_signal(signal.SIGINT)
    assert run.finish(timeout=60) == 130


@pytest.fixture(scope="module")
def long_bag(tmp_path_factory) -> Path:
    """Ten simulated seconds of follow_open recorded as a rosbag2 (15 Hz camera)."""
    bag = tmp_path_factory.mktemp("bags") / "ten_seconds"
    world = SimAdapter(load_scenario("follow_open"), seed=0)
    world.setup()
    try:
        with BagRecorder(bag) as rec:
            for _ in range(150):
                frame = world.capture()
                rec.record(frame=frame, state=None, scan=None)
                world.advance(1.0 / 15.0)
    finally:
        world.close()
    return bag


def test_a_replay_at_the_recorded_rate_stops_on_sigint_with_what_it_replayed(tmp_path, long_bag):
    run = Run(["replay", str(long_bag), "--rate", "1.0", "--json"], tmp_path)
    run.wait_for('"detections"')  # frames are coming out
    run.proc.send_signal(signal.SIGINT)
    assert run.finish(timeout=60) == 130, "\n".join(run.lines)
    summary = next(line for line in run.lines if line.startswith("interrupted: replayed"))
    frames = [line for line in run.lines if line.startswith("{")]
    assert 0 < len(frames) < 150 and f"{len(frames)} frames processed" in summary
    assert not any("Traceback" in line for line in run.lines)
