"""Issue 36, bad input: outputs that cannot be written — a full disk, `> /dev/full`, a file size limit — and
files nested too deeply to read. Each is one line naming the culprit and a clean exit; a streamed log that
fails mid-run is removed rather than left looking whole, and the run goes on."""

from __future__ import annotations

import os
import resource
import signal
import stat
import subprocess
import sys
from pathlib import Path

import pytest

MISSION = [sys.executable, "-m", "mission"]


def mission(*argv: str, stdout=subprocess.PIPE, preexec=None) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [*MISSION, *argv],
        stdout=stdout,
        stderr=subprocess.PIPE,
        text=True,
        timeout=300,
        env=dict(os.environ),
        preexec_fn=preexec,
    )


def no_traceback(err: str) -> bool:
    return "Traceback" not in err


@pytest.mark.skipif(not Path("/dev/full").exists(), reason="needs /dev/full")
def test_stdout_on_a_full_device_is_one_line_and_exit_74():
    with open("/dev/full", "w") as full:
        out = mission("plugins", stdout=full)
    assert out.returncode == 74
    assert out.stderr.strip().splitlines() == [
        "mission: error: cannot write the output (stdout): No space left on device"
    ]


@pytest.mark.skipif(not Path("/dev/full").exists(), reason="needs /dev/full")
def test_an_output_file_on_a_full_device_is_named_and_the_device_stays_a_device():
    out = mission("viz", "follow.xml", "-o", "/dev/full")
    assert out.returncode == 2 and no_traceback(out.stderr)
    assert out.stderr.strip().splitlines()[-1] == "mission: error: /dev/full: cannot write (No space left on device)"
    assert stat.S_ISCHR(os.stat("/dev/full").st_mode)  # written through, never renamed over (as root it could be)


def _limit_files_to(size: int):
    def limit() -> None:
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # a write past the limit then fails with EFBIG, as on a full disk
        resource.setrlimit(resource.RLIMIT_FSIZE, (size, size))

    return limit


def test_a_tick_log_that_fills_the_disk_mid_run_is_removed_and_the_run_goes_on(tmp_path):
    log = tmp_path / "run.jsonl"
    out = mission(
        "run", "--scenario", "explore_dock", "--max-duration", "3", "--log", str(log), preexec=_limit_files_to(40_000)
    )
    assert out.returncode == 1 and no_traceback(out.stderr)  # the run went on to its own end: never docked in 3 s
    said = [line for line in out.stderr.splitlines() if line.startswith(f"--log {log}: cannot write")]
    assert len(said) == 1 and "stopped and removed; the run goes on" in said[0]
    assert not log.exists()  # no half log that looks whole
    assert "FAILURE: explore_dock seed 0: never docked" in out.stdout


def test_a_config_nested_thousands_deep_is_one_line_not_a_recursion_traceback(tmp_path):
    config = tmp_path / "deep.yaml"
    config.write_text("a: " + "{b: " * 3000 + "1" + "}" * 3000 + "\n")
    out = mission("run", "--config", str(config), "--max-duration", "0.1")
    assert out.returncode == 2 and no_traceback(out.stderr)
    assert out.stderr.strip().splitlines() == [
        f"mission: error: {config}: nests too deeply to read (thousands of levels of [ or {{); "
        "expected a file a few levels deep"
    ]
