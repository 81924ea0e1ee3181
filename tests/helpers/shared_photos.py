"""The real ChArUco photos in ../shared/data/real-aruco, for tests that measure against their board's truth."""

from __future__ import annotations

from pathlib import Path

import pytest

from bench.real_images import shared_data_dir
from mission.core.errors import MissionError


def real_aruco_photo(name: str) -> Path:
    """The path of photo `name`; the test is skipped when ../shared/data is not beside the checkout (CI has it)."""
    try:
        path = shared_data_dir() / "real-aruco" / name
    except MissionError as err:
        pytest.skip(str(err))
    if not path.is_file():
        pytest.skip(f"{path} not present (../shared/data)")
    return path
