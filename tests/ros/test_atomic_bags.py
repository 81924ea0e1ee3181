"""State on disk (issue 9): a rosbag2 recording is moved into place only when it is closed, so a run
killed mid-recording never leaves a bag without metadata at the path asked for, and both the recorder
and replay say where the interrupted rest is and how it may be recovered."""

from __future__ import annotations

import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from mission.core.config import MissionConfig
from mission.core.errors import MissionError
from mission.core.types import CameraIntrinsics, Frame
from mission.ros.bag_record import BagRecorder
from mission.ros.bag_replay import replay

pytestmark = pytest.mark.ros

ROOT = Path(__file__).resolve().parents[2]


RECORDER = textwrap.dedent(
    """
    import sys, time
    import numpy as np
    from mission.ros.bag_record import BagRecorder
    from mission.core.types import CameraIntrinsics, Frame
    k = CameraIntrinsics(50.0, 50.0, 32.0, 24.0, 64, 48)
    rec = BagRecorder(sys.argv[1]).open()
    for i in range(5):
        rec.write_frame(Frame(np.full((48, 64, 3), i, np.uint8), 1.0 + i / 15, intrinsics=k))
    print("recording", flush=True)
    time.sleep(60)
    """
)


def test_a_recording_killed_mid_run_leaves_no_broken_bag_at_its_path_and_says_where_the_rest_is(tmp_path):
    bag = tmp_path / "run"
    proc = subprocess.Popen([sys.executable, "-c", RECORDER, str(bag)], stdout=subprocess.PIPE, text=True, cwd=ROOT)
    try:
        assert proc.stdout is not None and proc.stdout.readline().strip() == "recording"
    finally:
        proc.kill()
        proc.wait(timeout=10)
    assert not bag.exists()  # never a bag without metadata at the path the user asked for
    partial = tmp_path / "run.partial" / "run"
    assert partial.is_dir() and not (partial / "metadata.yaml").exists()

    with pytest.raises(MissionError) as err:
        BagRecorder(bag).open()
    assert str(err.value) == (
        f"{tmp_path / 'run.partial'}: an interrupted recording to {bag} is in the way "
        f"(`ros2 bag reindex {partial}` may recover it); move or delete it to record again"
    )
    # replay reads a bag without metadata.yaml as far as its data goes (tests/ros/test_replay_real_bags.py); killed
    # before its first write, this one has none
    with pytest.raises(MissionError) as err:
        replay(partial, MissionConfig())
    empty = "empty: the recording was cut off before anything was written to it"
    assert str(err.value) == f"{partial / 'run.mcap'}: {empty}"


def test_a_closed_recording_is_moved_into_place_whole(tmp_path):
    k = CameraIntrinsics(50.0, 50.0, 32.0, 24.0, 64, 48)
    with BagRecorder(tmp_path / "run.mcap") as rec:
        rec.write_frame(Frame(np.zeros((48, 64, 3), np.uint8), 1.0, intrinsics=k))
        assert not (tmp_path / "run").exists()  # still growing under run.partial/
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run"]
    assert sorted(p.name for p in (tmp_path / "run").iterdir()) == ["metadata.yaml", "run.mcap"]


def test_a_bag_path_that_cannot_be_created_is_one_line(tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("not a directory")
    with pytest.raises(MissionError) as err:
        BagRecorder(blocker / "run").open()
    assert str(err.value) == f"{blocker / 'run'}: cannot create it: {blocker} is a file, not a directory"
