"""Output piped into a reader that stops early (`mission detect --json IMG... | head -1`) ends quietly.

As for `cat` or `yes` in the same place: no traceback, no "Exception ignored", and exit status 141
(128 + SIGPIPE, what a shell reports for a tool its pipe reader left). Real processes and real pipes: `head`
reads the first line and exits while `mission` is still writing; or stdout is a pipe nobody reads from the start.
Both with Python's default block-buffered stdout and with PYTHONUNBUFFERED=1 (a different place fails: the
print itself, or the final flush at exit).
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest

from tools import synthetic_views as sv

ROOT = Path(__file__).resolve().parents[2]
SIGPIPE_STATUS = 141
BUFFERING = {"buffered": {}, "unbuffered": {"PYTHONUNBUFFERED": "1"}}


def _env(buffering: str) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if k != "PYTHONUNBUFFERED"}
    return {**env, **BUFFERING[buffering]}


@pytest.fixture(scope="module")
def marker_image(tmp_path_factory) -> Path:
    view = sv.render_sequence(1.5, 30, 1, np.random.default_rng(3), marker_size_m=0.2)[0]
    path = tmp_path_factory.mktemp("pipe") / "marker.png"
    cv2.imwrite(str(path), view.image)
    return path


def _quiet(stderr: str) -> bool:
    return "Traceback" not in stderr and "Exception ignored" not in stderr and "BrokenPipeError" not in stderr


@pytest.mark.parametrize("buffering", BUFFERING)
def test_detect_json_into_head_1_prints_one_line_and_ends_as_cat_does(marker_image, buffering):
    # 150 JSON lines (~0.8 kB each) are more than the pipe holds: mission is still writing when head exits.
    detect = subprocess.Popen(
        [sys.executable, "-m", "mission", "detect", *[str(marker_image)] * 150, "--json"],
        cwd=ROOT,
        env=_env(buffering),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    head = subprocess.Popen(
        [shutil.which("head") or "head", "-1"], stdin=detect.stdout, stdout=subprocess.PIPE, text=True
    )
    assert detect.stdout is not None
    detect.stdout.close()  # only head reads the pipe now, as in a shell pipeline
    first, _ = head.communicate(timeout=120)
    _, stderr = detect.communicate(timeout=120)
    assert json.loads(first)["detections"][0]["marker_id"] == 7
    assert detect.returncode == SIGPIPE_STATUS, stderr[-2000:]
    assert _quiet(stderr), stderr[-2000:]


@pytest.mark.parametrize("buffering", BUFFERING)
@pytest.mark.parametrize(
    "argv",
    [["plugins"], ["viz", "mission.xml", "--format", "svg"], ["detect", "{image}"]],
    ids=["plugins", "viz", "detect-table"],
)
def test_every_verb_writing_to_a_pipe_nobody_reads_ends_quietly(marker_image, argv, buffering):
    read_end, write_end = os.pipe()
    os.close(read_end)  # the reader is gone before the first byte is written
    try:
        proc = subprocess.run(
            [sys.executable, "-m", "mission", *(a.format(image=marker_image) for a in argv)],
            cwd=ROOT,
            env=_env(buffering),
            stdout=write_end,
            stderr=subprocess.PIPE,
            text=True,
            timeout=120,
            check=False,
        )
    finally:
        os.close(write_end)
    assert proc.returncode == SIGPIPE_STATUS, proc.stderr[-2000:]
    assert _quiet(proc.stderr), proc.stderr[-2000:]
