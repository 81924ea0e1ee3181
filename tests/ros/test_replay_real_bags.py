"""`mission replay` on bags the way robots leave them: compressed cameras, other topic names, ROS 1 `.bag`
files, a rosbag2 without metadata.yaml, files cut off mid-write. Each bag is recorded here (BagRecorder),
then compressed, renamed, converted to ROS 1 (rosbags' converter) or truncated, as a robot's would be."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from rosbags.convert.converter import convert
from rosbags.highlevel import AnyReader
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import Stores, get_typestore

from mission.core.config import MissionConfig, TopicsConfig
from mission.core.types import Frame, Pose2D, RobotState, Twist
from mission.ros.bag_record import BagRecorder
from mission.ros.bag_replay import BagWorld, replay
from tools import synthetic_views as sv

ROOT = Path(__file__).resolve().parents[2]
N_FRAMES = 12


def recorded_frames() -> list[tuple[Frame, RobotState]]:
    """A DICT_4X4_250 marker (id 7, 0.049 m: the aruco source's defaults) 0.6 m away, drifting over 12 frames
    at 15 Hz, with depth (the marker's plane) and odometry."""
    rng = np.random.default_rng(3)
    k = sv.default_intrinsics(640, 480)
    views = sv.render_sequence(0.6, 25.0, N_FRAMES, rng, marker_id=7, marker_size_m=0.049, intrinsics=k)
    out = []
    for i, v in enumerate(views):
        stamp = 100.0 + i / 15.0
        depth = np.full((480, 640), np.float32(v.distance))
        depth[:20] = np.nan  # no return at the top
        out.append(
            (
                Frame(v.image, stamp, "camera_optical_frame", k, depth=depth),
                RobotState(Pose2D(0.1 * i, 0.0, 0.0), Twist(0.1, 0.0), stamp),
            )
        )
    return out


def record(path: Path, frames: list[tuple[Frame, RobotState]], **kw) -> Path:
    with BagRecorder(path, **kw) as rec:
        for frame, state in frames:
            rec.record(frame=frame, state=state)
    return path


def renamed(src: Path, dst: Path, names: dict[str, str]) -> Path:
    """The bag at `src` rewritten with topics renamed (a robot's own camera names), as mcap."""
    store = get_typestore(Stores.ROS2_JAZZY)
    with (
        AnyReader([src], default_typestore=store) as reader,
        Writer(dst, version=9, storage_plugin=StoragePlugin.MCAP) as writer,
    ):
        conns = {
            c.id: writer.add_connection(names.get(c.topic, c.topic), c.msgtype, typestore=store)
            for c in reader.connections
        }
        for c, t, raw in reader.messages():
            writer.write(conns[c.id], t, raw)
    return dst


def to_ros1(src: Path, dst: Path) -> Path:
    """rosbags' converter, with the messages turned into ROS 1 Noetic types (CameraInfo's `K`, `D`, …)."""
    convert([src], dst, "mcap", 9, None, "file", None, get_typestore(Stores.ROS1_NOETIC), [], [], [], [])
    return dst


def truncated(src: Path, dst: Path, fraction: float) -> Path:
    """A copy of the bag with its (only) data file cut off at `fraction` of its length; metadata.yaml, if
    any, kept as it was."""
    if src.is_file():
        data = src.read_bytes()
        dst.write_bytes(data[: int(len(data) * fraction)])
        return dst
    shutil.copytree(src, dst)
    (data_file,) = [p for p in dst.iterdir() if p.suffix in (".mcap", ".db3")]
    data = data_file.read_bytes()
    data_file.write_bytes(data[: int(len(data) * fraction)])
    return dst


@pytest.fixture(scope="module")
def frames():
    return recorded_frames()


@pytest.fixture(scope="module")
def bags(tmp_path_factory, frames):
    d = tmp_path_factory.mktemp("bags")
    return {
        "raw": record(d / "raw", frames),
        "jpeg": record(d / "jpeg", frames, compression="jpeg"),
        "png": record(d / "png", frames, compression="png", storage="sqlite3"),
    }


def replayed(bag: Path, warnings: list[str] | None = None, **kw):
    return replay(bag, MissionConfig(), warn=(warnings.append if warnings is not None else lambda m: None), **kw)


def ids_and_positions(result) -> list[tuple[float, list[int], np.ndarray]]:
    return [
        (round(f.stamp, 3), [d.marker_id for d in f.detections], np.array([d.position for d in f.detections]))
        for f in result.frames
    ]


def test_a_raw_recording_replays_every_frame_with_its_marker(bags):
    result = replayed(bags["raw"])
    assert len(result.frames) == N_FRAMES
    assert all([d.marker_id for d in f.detections] == [7] for f in result.frames)
    assert result.stats["fallback_intrinsics"] == 0 and result.kind == "rosbag2 (mcap)"


@pytest.mark.parametrize("compression", ["jpeg", "png"])
def test_compressed_images_replay_like_the_raw_ones(bags, compression):
    raw, comp = ids_and_positions(replayed(bags["raw"])), ids_and_positions(replayed(bags[compression]))
    assert [(s, i) for s, i, _ in comp] == [(s, i) for s, i, _ in raw]
    tol = 0.004 if compression == "jpeg" else 1e-6  # PNG is lossless; JPEG moves a corner by a fraction of a px
    for (_, _, p_raw), (_, _, p_comp) in zip(raw, comp, strict=True):
        assert np.allclose(p_raw, p_comp, atol=tol)


def test_compressed_depth_arrives_in_metres_with_no_return_kept(bags, frames):
    world = BagWorld(bags["png"])
    world.setup()
    try:
        frame = world.cache.take_frame()
        assert world.read["image"] == "/camera/image_raw/compressed"
        assert world.read["depth"] == "/camera/depth/image_raw/compressedDepth"
        truth = frames[0][0].depth
        assert frame.depth is not None and np.isnan(frame.depth[:20]).all()
        assert np.allclose(frame.depth[20:], truth[20:], atol=0.0005)  # millimetres
    finally:
        world.close()


def test_topics_come_from_the_flags_and_from_the_config(bags, tmp_path):
    bag = renamed(
        bags["jpeg"],
        tmp_path / "robot",
        {
            "/camera/image_raw/compressed": "/front/image/compressed",
            "/camera/camera_info": "/front/camera_info",
            "/odom": "/wheel/odom",
        },
    )
    by_flag = replayed(
        bag,
        topics={
            "image_topic": "/front/image/compressed",
            "camera_info_topic": "/front/camera_info",
            "odom_topic": "/wheel/odom",
        },
    )
    assert len(by_flag.frames) == N_FRAMES and by_flag.stats["fallback_intrinsics"] == 0
    assert by_flag.read["odom"] == "/wheel/odom" and by_flag.stats["received"]["odom"] == N_FRAMES
    config = MissionConfig(topics=TopicsConfig(image_topic="/front/image", camera_info_topic="/front/camera_info"))
    by_config = replay(bag, config)  # /front/image is read from its /compressed twin
    assert len(by_config.frames) == N_FRAMES and by_config.read["image"] == "/front/image/compressed"


def test_without_the_default_the_only_image_topic_is_used_and_said(bags, tmp_path):
    bag = renamed(
        bags["raw"],
        tmp_path / "robot",
        {"/camera/image_raw": "/usb_cam/image_raw", "/camera/camera_info": "/usb_cam/camera_info"},
    )
    warnings: list[str] = []
    result = replayed(bag, warnings)
    assert len(result.frames) == N_FRAMES and result.stats["fallback_intrinsics"] == 0
    assert any("using /usb_cam/image_raw, its only image topic" in w for w in warnings)
    assert any("using /usb_cam/camera_info, its only camera info topic" in w for w in warnings)


def test_two_cameras_and_no_choice_is_an_error_naming_them(bags, tmp_path):
    src = renamed(bags["raw"], tmp_path / "left", {"/camera/image_raw": "/left/image_raw"})
    two = tmp_path / "two"
    store = get_typestore(Stores.ROS2_JAZZY)
    with (
        AnyReader([src], default_typestore=store) as reader,
        Writer(two, version=9, storage_plugin=StoragePlugin.MCAP) as writer,
    ):
        conns = {c.id: writer.add_connection(c.topic, c.msgtype, typestore=store) for c in reader.connections}
        right = writer.add_connection("/right/image_raw", "sensor_msgs/msg/Image", typestore=store)
        for c, t, raw in reader.messages():
            writer.write(conns[c.id], t, raw)
            if c.topic == "/left/image_raw":
                writer.write(right, t, raw)
    proc = subprocess.run(
        [sys.executable, "-m", "mission", "replay", str(two)], capture_output=True, text=True, timeout=120, cwd=ROOT
    )
    assert proc.returncode == 2
    assert "no image topic /camera/image_raw" in proc.stderr and "/left/image_raw, /right/image_raw" in proc.stderr
    assert "--image-topic" in proc.stderr and len(proc.stderr.strip().splitlines()) == 1
    chosen = replayed(two, topics={"image_topic": "/right/image_raw"})
    assert len(chosen.frames) == N_FRAMES


@pytest.mark.parametrize("source", ["raw", "jpeg"])
def test_a_ros1_bag_replays_like_the_rosbag2_it_was_converted_from(bags, tmp_path, source):
    bag = to_ros1(bags[source], tmp_path / f"{source}.bag")
    ros1, ros2 = replayed(bag), replayed(bags[source])
    assert ros1.kind == "rosbag1" and ros1.stats["fallback_intrinsics"] == 0  # CameraInfo's K and D read
    assert [(s, i) for s, i, _ in ids_and_positions(ros1)] == [(s, i) for s, i, _ in ids_and_positions(ros2)]
    for (_, _, a), (_, _, b) in zip(ids_and_positions(ros1), ids_and_positions(ros2), strict=True):
        assert np.allclose(a, b, atol=1e-9)


@pytest.mark.parametrize("storage", ["mcap", "sqlite3"])
def test_a_rosbag2_without_metadata_yaml_replays_and_says_so(frames, tmp_path, storage):
    bag = record(tmp_path / "unclosed", frames, storage=storage)
    (bag / "metadata.yaml").unlink()  # what a killed recorder leaves
    warnings: list[str] = []
    result = replayed(bag, warnings)
    assert len(result.frames) == N_FRAMES and all(f.detections for f in result.frames)
    assert any("no metadata.yaml" in w for w in warnings)
    (data_file,) = [p for p in bag.iterdir() if p.suffix in (".mcap", ".db3")]
    assert len(replayed(data_file).frames) == N_FRAMES  # the data file itself, named directly


@pytest.mark.parametrize("kind", ["mcap", "sqlite3", "ros1"])
def test_a_truncated_bag_replays_up_to_the_damage_with_a_warning(bags, frames, tmp_path, kind):
    if kind == "ros1":
        src = to_ros1(bags["jpeg"], tmp_path / "whole.bag")
    else:
        src = record(tmp_path / "whole", frames, compression="jpeg", storage=kind)
    cut = truncated(src, tmp_path / ("cut.bag" if kind == "ros1" else "cut"), 0.6)
    warnings: list[str] = []
    result = replayed(cut, warnings)
    assert 2 <= len(result.frames) < N_FRAMES, len(result.frames)
    assert all([d.marker_id for d in f.detections] == [7] for f in result.frames)
    assert [round(f.stamp, 3) for f in result.frames] == [round(fr.stamp, 3) for fr, _ in frames[: len(result.frames)]]
    assert any("damaged" in w for w in warnings), warnings


def test_the_cli_replays_a_ros1_bag_with_topic_flags_and_a_calibration_file(bags, frames, tmp_path):
    bag = to_ros1(
        renamed(
            bags["jpeg"],
            tmp_path / "robot",
            {"/camera/image_raw/compressed": "/cam/image/compressed", "/camera/camera_info": "/cam/info"},
        ),
        tmp_path / "robot.bag",
    )
    k = frames[0][0].intrinsics
    (tmp_path / "cam.yaml").write_text(
        f"image_width: {k.width}\nimage_height: {k.height}\ncamera_name: cam\n"
        f"camera_matrix: {{rows: 3, cols: 3, data: [{k.fx}, 0, {k.cx}, 0, {k.fy}, {k.cy}, 0, 0, 1]}}\n"
        "distortion_model: plumb_bob\ndistortion_coefficients: {rows: 1, cols: 5, data: [0, 0, 0, 0, 0]}\n"
    )
    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "mission",
            "replay",
            str(bag),
            "--image-topic",
            "/cam/image/compressed",
            "--camera-info-topic",
            "/nowhere",
            "--calibration",
            str(tmp_path / "cam.yaml"),
            "--json",
        ],
        capture_output=True,
        text=True,
        timeout=120,
        cwd=ROOT,
    )
    assert proc.returncode == 0, proc.stderr
    records = [json.loads(line) for line in proc.stdout.splitlines()]
    assert len(records) == N_FRAMES
    assert all(r["detections"][0]["extra"]["intrinsics"] == "calibrated" for r in records)
    assert "rosbag1" in proc.stderr and f"{N_FRAMES} frames processed" in proc.stderr
