"""Writing pictures and pages: atomically (a temp file renamed into place), readable like any new file."""

from __future__ import annotations

import os
from pathlib import Path

from mission.core.errors import MissionError
from mission.report import atomic_write_bytes


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def write_output(path: str | Path, data: bytes) -> Path:
    """Write `data` to `path` (parents created); a MissionError names the path when it cannot be written."""
    path = Path(path)
    try:
        atomic_write_bytes(path, data)
        os.chmod(path, 0o666 & ~_umask())  # mkstemp's 0600 is right for temp files, not for a user's picture
    except OSError as err:
        raise MissionError(f"{path}: cannot write ({err.strerror or err})") from err
    return path
