"""The code is ruff-clean, as the standards ask: lint and format, with the one ruff version pyproject pins.

Without a check the format drifted: a newer ruff splits long f-strings differently, and 59 files were left in
another version's format, so every contributor's `ruff format` rewrote lines they never touched."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
RUFF = [sys.executable, "-m", "ruff"]


def _ruff(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([*RUFF, *args], cwd=ROOT, capture_output=True, text=True, check=False)


def test_ruff_finds_nothing_to_lint() -> None:
    result = _ruff("check", "--quiet", ".")
    assert result.returncode == 0, f"ruff check . fails; run `.venv/bin/ruff check --fix .`:\n{result.stdout}"


def test_every_file_is_in_ruffs_format() -> None:
    result = _ruff("format", "--check", "--quiet", ".")
    assert result.returncode == 0, f"files not in ruff's format; run `.venv/bin/ruff format .`:\n{result.stdout}"
