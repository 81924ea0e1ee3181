"""Writing pictures and pages: atomically (a temp file renamed into place), readable like any new file."""

from __future__ import annotations

from pathlib import Path

from mission.core.errors import MissionError
from mission.core.files import atomic_write_bytes


def write_output(path: str | Path, data: bytes) -> Path:
    """Write `data` to `path` (parents created); a MissionError names the path when it cannot be written."""
    path = Path(path)
    try:
        atomic_write_bytes(path, data)  # readable like any new file (not mkstemp's 0600)
    except OSError as err:
        raise MissionError(f"{path}: cannot write ({err.strerror or err})") from err
    return path
