"""Recordings (`mission run --record`): camera with marker overlays beside the top-down map, under the state
banner — one frame per 1/fps simulated seconds, as GIF or MP4."""

from __future__ import annotations

import imageio.v3 as iio
import numpy as np
import pytest

from mission.core.errors import MissionError
from mission.core.types import CameraIntrinsics, Detection
from mission.viz.overlay import OUTLINE_BGR, draw_detections
from mission.viz.recording import BANNER_H, Recorder
from tests.helpers.viz_world import HEIGHT, WIDTH, step, watch_runner


def record(tmp_path, name: str, ticks: int, **kw) -> Recorder:
    runner, world = watch_runner(tmp_path)
    rec = Recorder(tmp_path / name, **kw)
    try:
        runner.attach(rec)
        step(runner, world, ticks)
        runner.finish(None)
    finally:
        runner.close()
    return rec


def test_gif_has_one_frame_per_tick_at_the_tick_rate_and_the_expected_size(tmp_path):
    rec = record(tmp_path, "run.gif", ticks=6, fps=10.0, height=240)  # the world ticks at 10 Hz
    frames = iio.imread(tmp_path / "run.gif", index=None)
    cam_w = WIDTH * 240 // HEIGHT
    map_w = 240  # the world's map is square
    assert frames.shape == (6, BANNER_H + 240, cam_w + 4 + map_w, 3)
    assert rec.frame_count == 6

    # the camera half shows the marker outline (green) while the marker is seen: first frame yes, last no
    def green(frame):
        cam = frame[BANNER_H:, :cam_w].astype(int)
        b, g, r = OUTLINE_BGR
        return int((np.abs(cam - (r, g, b)).sum(axis=2) < 60).sum())

    assert green(frames[0]) > 100 and green(frames[-1]) < 10


def test_gif_frame_rate_follows_simulated_time_not_ticks(tmp_path):
    record(tmp_path, "slow.gif", ticks=8, fps=5.0, height=120)  # 0.8 s simulated at 5 frames/s
    assert len(iio.imread(tmp_path / "slow.gif", index=None)) == 4


def test_a_long_gif_keeps_the_whole_run_by_halving_its_frame_rate(tmp_path):
    record(tmp_path, "long.gif", ticks=8, fps=10.0, height=120, max_frames=4)  # 0.8 s simulated
    frames = iio.imread(tmp_path / "long.gif", index=None)
    ms_per_frame = iio.immeta(tmp_path / "long.gif", index=0)["duration"]
    assert len(frames) == 4 and ms_per_frame == 200  # every other frame, each shown twice as long
    assert len(frames) * ms_per_frame == 800


def test_mp4_is_h264_with_every_frame(tmp_path):
    record(tmp_path, "run.mp4", ticks=5, fps=10.0, height=120)
    import imageio.v2 as iio2

    reader = iio2.get_reader(tmp_path / "run.mp4", format="FFMPEG")
    try:
        meta = reader.get_meta_data()
        frames = [f for f in reader]
    finally:
        reader.close()
    assert meta["codec"] == "h264" and len(frames) == 5
    assert frames[0].shape[0] == BANNER_H + 120


def test_record_refuses_other_extensions_before_the_run(tmp_path):
    with pytest.raises(MissionError, match=r"--record .*run\.avi: expected a \.gif or \.mp4"):
        Recorder(tmp_path / "run.avi")


def test_overlay_draws_outline_axes_and_id_and_survives_odd_detections():
    img = np.full((240, 320), 90, np.uint8)  # mono input is fine
    k = CameraIntrinsics.from_vertical_fov(320, 240, 45.0)
    corners = np.array([[120, 80], [200, 80], [200, 160], [120, 160]], float)
    good = Detection("aruco", 7, None, corners, np.array([0.0, 0.0, 1.0]), np.array([1.0, 0, 0, 0]), 1.0, 0.1, 0.0, "c")
    nan3 = np.array([np.nan] * 3)
    no_corners = Detection("vlm", None, "person", None, nan3, np.array([0, 0, 0, 1.0]), 0.5, 0, 0, "c")
    behind = Detection("aruco", 3, None, corners + 50, np.array([0, 0, -1.0]), np.array([0, 0, 0, 1.0]), 1, 0, 0, "c")
    out = draw_detections(img, [good, no_corners, behind], k)
    assert out.shape == (240, 320, 3) and img.shape == (240, 320)  # a copy, input untouched
    assert np.abs(out[80, 140].astype(int) - OUTLINE_BGR).sum() < 60  # on the top edge of the outline
    centre = out[120, 160].astype(int)
    assert centre.tolist() != [90, 90, 90]  # the axes start at the marker centre
    assert (out[0:40, 0:160] != 90).any()  # the label of the detection without corners, top left
