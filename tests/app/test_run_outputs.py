"""`mission run`'s output paths are checked before the simulation starts, not after minutes of it.

A `--report DIR` that is a file, lies under a file or cannot be written, a `--log` / `--record` file that
cannot be created, a `--record-bag` path that is taken: one usage line naming the option, the path and what
was expected; exit 2; no simulation (it would run for minutes: the scenario is mission_full, 600 s).
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

import mission.commands.run as run_command
from mission.cli import main

ROOT = Path(__file__).resolve().parents[2]
LONG_RUN = ["run", "--scenario", "mission_full", "--max-duration", "600", "--quiet"]


@pytest.fixture
def no_simulation(monkeypatch):
    """Fail the test if the simulation is started."""

    def started(*args, **kwargs):
        raise AssertionError("the simulation started")

    monkeypatch.setattr(run_command, "run_scenario", started)


@pytest.fixture
def a_file(tmp_path) -> Path:
    path = tmp_path / "notes.txt"
    path.write_text("a file, not a directory\n")
    return path


def test_a_report_dir_that_is_a_file_is_a_usage_error_before_the_simulation(a_file):
    proc = subprocess.run(
        [sys.executable, "-m", "mission", *LONG_RUN, "--report", str(a_file)],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert proc.returncode == 2
    assert proc.stdout == ""  # no result line: nothing ran
    assert proc.stderr.splitlines() == [f"mission: error: --report {a_file}: expected a directory, but it is a file"]
    assert a_file.read_text() == "a file, not a directory\n"


@pytest.mark.parametrize(
    ("option", "path", "expected"),
    [
        ("--report", "{file}/run1", "cannot create it: {file} is a file, not a directory"),
        ("--report", "{file}/deeper/run1", "cannot create it: {file} is a file, not a directory"),
        ("--report", "/proc/mission-report", "cannot write ("),  # the kernel refuses everyone, root too
        ("--report", "/proc", "cannot write ("),  # a directory that exists but takes no files
        ("--log", "{file}/run.jsonl", "cannot create it: {file} is a file, not a directory"),
        ("--log", "{dir}", "expected a file, but it is a directory"),
        ("--record", "{file}/run.gif", "cannot create it: {file} is a file, not a directory"),
        ("--record-bag", "{file}/bag", "cannot create it: {file} is a file, not a directory"),
        ("--record-bag", "{dir}", "exists already; a bag is never overwritten"),
    ],
)
def test_an_output_that_cannot_be_written_is_one_line_naming_option_path_and_why(
    no_simulation, capsys, tmp_path, a_file, option, path, expected
):
    path = path.format(file=a_file, dir=tmp_path)
    assert main([*LONG_RUN, option, path]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    [line] = captured.err.splitlines()
    assert line.startswith(f"mission: error: {option} {path}: {expected.format(file=a_file)}"), line


def test_a_report_dir_that_does_not_exist_yet_is_made_before_the_simulation(no_simulation, tmp_path):
    report = tmp_path / "runs" / "today" / "run1"
    with pytest.raises(AssertionError, match="the simulation started"):
        main([*LONG_RUN, "--report", str(report)])
    assert report.is_dir() and list(report.iterdir()) == []  # made, probed, nothing left behind
