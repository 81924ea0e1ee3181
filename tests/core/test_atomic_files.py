"""State on disk (issue 9): whole files are replaced atomically, so a crash mid-write leaves the previous
file intact; append-only tick logs are read up to a torn last line, which is skipped with a warning."""

from __future__ import annotations

import json
import logging
import os
import signal
import stat
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

from mission.core.files import atomic_path, atomic_write_bytes, atomic_write_text
from mission.perception_plugins.vlm.quota import QuotaStore
from mission.viz.run_report import write_json
from mission.viz.tick_log import read_log

ROOT = Path(__file__).resolve().parents[2]
T0 = 1_700_000_000.0


def leftovers(directory: Path, keep: str) -> list[str]:
    return sorted(p.name for p in directory.iterdir() if p.name != keep)


# -- a failure inside the write ----------------------------------------------------------------------------


def test_an_exception_while_writing_leaves_the_previous_file_and_no_temp_file(tmp_path):
    path = atomic_write_text(tmp_path / "report.json", '{"outcome": "success"}\n')
    with pytest.raises(RuntimeError, match="renderer crashed"), atomic_path(path) as tmp:
        tmp.write_text('{"outco')  # half of the new content is on disk…
        raise RuntimeError("renderer crashed")  # …when the writer fails
    assert path.read_text() == '{"outcome": "success"}\n'
    assert leftovers(tmp_path, "report.json") == []


def test_a_value_that_cannot_be_serialised_leaves_the_previous_report(tmp_path):
    path = tmp_path / "report.json"
    write_json(path, {"outcome": "success"})
    with pytest.raises(TypeError, match="not JSON-serialisable: object"):
        write_json(path, {"outcome": object()})
    assert json.loads(path.read_text()) == {"outcome": "success"}


# -- a process killed mid-write ----------------------------------------------------------------------------

SLOW_WRITER = textwrap.dedent(
    """
    import sys, time
    from mission.core.files import atomic_path
    with atomic_path(sys.argv[1]) as tmp, open(tmp, "wb") as fh:
        fh.write(b"NEW" * 100_000)
        fh.flush()
        print("half written", flush=True)
        time.sleep(60)
        fh.write(b"END")
    """
)


def test_a_process_killed_mid_write_leaves_the_previous_file_intact(tmp_path):
    path = atomic_write_bytes(tmp_path / "picture.png", b"OLD PICTURE")
    proc = subprocess.Popen([sys.executable, "-c", SLOW_WRITER, str(path)], stdout=subprocess.PIPE, text=True, cwd=ROOT)
    try:
        assert proc.stdout is not None and proc.stdout.readline().strip() == "half written"
    finally:
        proc.kill()
        proc.wait(timeout=10)
    assert proc.returncode == -signal.SIGKILL
    assert path.read_bytes() == b"OLD PICTURE"
    # the dead writer's temp file is a hidden sibling, never the target
    [tmp] = leftovers(tmp_path, "picture.png")
    assert tmp.startswith(".picture.") and tmp.endswith(".tmp.png")


QUOTA_LOOP = textwrap.dedent(
    """
    import sys
    from mission.perception_plugins.vlm.quota import QuotaStore
    store = QuotaStore(__import__("pathlib").Path(sys.argv[1]), daily_quota=10**9, min_interval_s=0.0)
    k = store.state.calls_today
    print("recording", flush=True)
    while True:
        k += 1
        store.record_call(float(sys.argv[2]) + k * 1e-3)
    """
)


def test_the_vlm_quota_survives_the_node_being_killed_while_recording_calls(tmp_path, caplog):
    """A node killed at arbitrary moments while it records calls: every restart reads a whole state file
    whose count only grows — never a torn file that would silently reset the day's budget."""
    path = tmp_path / "vlm_quota.json"
    seen = 0
    for delay in (0.15, 0.05, 0.3):
        proc = subprocess.Popen(
            [sys.executable, "-c", QUOTA_LOOP, str(path), str(T0)], stdout=subprocess.PIPE, text=True, cwd=ROOT
        )
        try:
            assert proc.stdout is not None and proc.stdout.readline().strip() == "recording"
            time.sleep(delay)
        finally:
            proc.send_signal(signal.SIGKILL)
            proc.wait(timeout=10)
        with caplog.at_level(logging.WARNING, logger="mission.perception_plugins.vlm.quota"):
            restarted = QuotaStore(path, daily_quota=10**9, min_interval_s=0.0)
        assert caplog.records == [], "the state file was unreadable after a kill"
        count = restarted.calls_today(T0 + 1)
        assert count >= seen and count == json.loads(path.read_text())["calls_today"]
        seen = count
    assert seen > 0


# -- file modes --------------------------------------------------------------------------------------------


def test_a_new_file_gets_the_mode_a_plain_write_would_give_not_0600(tmp_path):
    old = os.umask(0o022)
    try:
        path = atomic_write_text(tmp_path / "trajectory.svg", "<svg/>")
        plain = tmp_path / "plain.txt"
        plain.write_text("x")
    finally:
        os.umask(old)
    assert stat.S_IMODE(path.stat().st_mode) == stat.S_IMODE(plain.stat().st_mode) == 0o644


@pytest.mark.parametrize("mode", [0o600, 0o640, 0o664])
def test_replacing_a_file_keeps_its_mode(tmp_path, mode):
    path = atomic_write_text(tmp_path / "vlm_quota.json", "{}")
    path.chmod(mode)
    atomic_write_text(path, '{"calls_today": 1}')
    assert stat.S_IMODE(path.stat().st_mode) == mode and path.read_text() == '{"calls_today": 1}'


def test_parents_are_created_and_the_temp_file_lives_beside_the_target(tmp_path):
    target = tmp_path / "a" / "b" / "run.gif"
    with atomic_path(target) as tmp:
        assert tmp.parent == target.parent and tmp.suffix == ".gif"  # savefig / PIL pick the format by suffix
        tmp.write_bytes(b"GIF89a")
    assert target.read_bytes() == b"GIF89a" and leftovers(target.parent, "run.gif") == []


# -- append-only tick logs ---------------------------------------------------------------------------------


def _log_lines(ticks: int) -> list[str]:
    header = {"kind": "header", "version": 1, "tree": {"name": "T", "kind": "Action", "children": []}}
    return [json.dumps(header)] + [json.dumps({"tick": t, "nodes": {}}) for t in range(1, ticks + 1)]


def test_a_torn_last_line_is_skipped_with_a_warning_naming_it(tmp_path, caplog):
    lines = _log_lines(4)
    path = tmp_path / "run.jsonl"
    path.write_text("\n".join(lines[:4]) + "\n" + lines[4][:9])  # killed while writing tick 4
    with caplog.at_level(logging.WARNING, logger="mission.viz.tick_log"):
        data = read_log(path)
    assert data.tick_numbers() == [1, 2, 3] and data.end is None and data.torn_line == 5
    [warning] = [r.getMessage() for r in caplog.records]
    assert (
        warning
        == f"{path}:5: last line cut off mid-write (the run was interrupted); skipped it, read 3 ticks before it"
    )


def test_a_whole_log_has_no_torn_line_and_no_warning(tmp_path, caplog):
    path = tmp_path / "run.jsonl"
    path.write_text("\n".join(_log_lines(2)) + "\n")
    with caplog.at_level(logging.WARNING, logger="mission.viz.tick_log"):
        assert read_log(path).torn_line is None
    assert caplog.records == []
