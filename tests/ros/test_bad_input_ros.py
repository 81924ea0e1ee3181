"""Bad ROS messages on the conversion path (issue 9, bad-input matrix: camera info and images).

Messages go through the same SensorCache → blackboard → PerceiveTargets path as on the robot (the
CachedWorld of mission/ros/world_io.py, without DDS), with a real ArUco source: each bad message is
dropped or replaced by the fallback, counted under its reason, warned about once naming the topic, and
the next good image is still detected.

Already covered: unsupported encoding, step < width×bytes, too little data and empty images
(test_conversions.py); fx/fy zero, NaN or negative and a camera info for another resolution
(test_conversions.py, test_world_io.py); the live node dropping bad images (test_node.py).
"""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import py_trees
import pytest

from mission.core import blackboard as bbk
from mission.core.config import TargetSpec
from mission.core.errors import ConfigError
from mission.core.perception import Perceived
from mission.core.types import CameraIntrinsics, LaserScan, Pose2D, RobotState, Twist
from mission.perception_plugins.aruco import ArucoSource
from mission.perception_plugins.pipeline import PerceptionStage
from mission.ros.conversions import (
    BadMessage,
    array_to_image,
    camera_info_to_intrinsics,
    grid_from_msg,
    image_to_camera_array,
    image_to_depth_m,
    intrinsics_to_camera_info,
    matrix_to_pose,
    scan_from_msg,
    scan_to_msg,
    state_to_odometry,
)
from mission.ros.messages import header_msg, time_msg
from mission.ros.node import PARAMETERS, check_params, given_params
from tests.helpers import ros_env
from tests.helpers.behaviour_world import read
from tests.ros.test_world_io import MSGS, RecordingWorld
from tools import synthetic_views as sv

pytestmark = pytest.mark.ros

S = py_trees.common.Status
MARKER = 0.2
_rng = np.random.default_rng(5)
VIEW = sv.render_marker_view(sv.random_pose(1.0, 20, _rng), rng=_rng, marker_size_m=MARKER)
K = VIEW.intrinsics
TOPIC = "/camera/image_raw"
ROOT = ros_env.ROOT


class Pipeline:
    """A ROS world feeding the perception stage (real aruco) through the blackboard, one step per call."""

    def __init__(self) -> None:
        self.world = RecordingWorld()
        self.bb = bbk.writer("ros-world")
        self.stage = PerceptionStage([ArucoSource({"marker_size_m": MARKER})], {"t": TargetSpec(marker_id=7)})
        self.stamp = 0.0

    def good_image(self) -> object:
        self.stamp += 0.1
        return array_to_image(MSGS, VIEW.image, "bgr8", self.stamp, "cam")

    def cycle(self) -> Perceived | None:
        """sense → perceive; what the stage made of the frame the world delivered (None: no new frame)."""
        self.world.sense(self.bb)
        return self.stage.update(self.bb)

    def detects_the_marker(self) -> bool:
        """Good camera info and image in: is the marker seen with the calibrated intrinsics?"""
        self.world.cache.on_camera_info(intrinsics_to_camera_info(MSGS, K, self.stamp + 0.1, "cam"))
        assert self.world.cache.on_image(self.good_image(), TOPIC)
        perceived = self.cycle()
        assert perceived is not None and perceived.processed
        det = read(bbk.TRACKS)["t"].detection
        return read(bbk.TRACKS)["t"].visible and det.extra["intrinsics"] == "calibrated"


@pytest.fixture
def pipeline() -> Pipeline:
    return Pipeline()


# -- images whose step disagrees with the width ------------------------------------------------------------


def _with(msg: object, **fields: object) -> object:
    for key, value in fields.items():
        setattr(msg, key, value)
    return msg


@pytest.mark.parametrize(
    ("change", "reason", "words"),
    [
        (lambda m: _with(m, step=m.width * 3 - 1), "size", "step 1919 < width×bytes per pixel = 1920 (bgr8, width 640)"),  # noqa: E501
        (lambda m: _with(m, step=0), "size", "step 0 < width×bytes per pixel = 1920"),
        (lambda m: _with(m, step=m.width * 3 + 64), "size", "expected step×height = 1984×480 = 952320"),
        (lambda m: _with(m, width=m.width * 2), "size", "step 1920 < width×bytes per pixel = 3840"),
        (lambda m: _with(m, height=m.height + 1), "size", "expected step×height = 1920×481"),
        (lambda m: _with(m, height=2**31), "size", "expected step×height = 1920×2147483648"),
        (lambda m: _with(m, encoding="mono16"), "encoding", "unsupported encoding 'mono16'; expected one of bgr8"),
        (lambda m: _with(m, encoding="32FC1"), "encoding", "unsupported encoding '32FC1'"),
    ],
)  # fmt: skip
def test_an_image_whose_step_or_size_disagrees_is_dropped_counted_and_the_next_one_detected(
    pipeline, change, reason, words
):
    world = pipeline.world
    for _ in range(3):
        assert world.cache.on_image(change(pipeline.good_image()), TOPIC) is False
        assert pipeline.cycle() is None  # no new frame: nothing to perceive
    assert world.cache.stats.dropped == {f"image:{reason}": 3}
    [warning] = world.warnings  # throttled: once, not per message
    assert warning.startswith(f"dropped a message on {TOPIC}: ") and words in warning and "\n" not in warning
    assert read(bbk.PERCEPTION_STATS, {}).get("frames_processed", 0) == 0
    assert pipeline.detects_the_marker()


@pytest.mark.parametrize("encoding", ["bgr8", "rgb8", "mono8"])
@pytest.mark.parametrize("padding", [1, 3, 64])
def test_row_padding_of_any_size_in_step_is_skipped_and_the_marker_found(pipeline, encoding, padding):
    image = VIEW.image if encoding != "mono8" else VIEW.image.mean(axis=2).astype(np.uint8)
    channels = 1 if encoding == "mono8" else 3
    msg = array_to_image(MSGS, image, encoding, 1.0, "cam", step=640 * channels + padding)
    assert np.array_equal(image_to_camera_array(msg), image)
    pipeline.world.cache.on_camera_info(intrinsics_to_camera_info(MSGS, K, 1.0, "cam"))
    assert pipeline.world.cache.on_image(msg, TOPIC)
    assert pipeline.cycle().processed and read(bbk.TRACKS)["t"].visible


def test_a_16uc1_depth_image_with_odd_padding_keeps_its_millimetres():
    depth = np.array([[0.5, 0.0], [1.25, 65.535]], np.float32)
    msg = array_to_image(MSGS, depth, "16UC1", 0.0, "d", step=5)
    out = image_to_depth_m(msg)
    assert np.isnan(out[0, 1]) and np.allclose(out[[0, 1, 1], [0, 0, 1]], [0.5, 1.25, 65.535])


# -- camera info -------------------------------------------------------------------------------------------


def _info(**fields: object) -> object:
    return _with(intrinsics_to_camera_info(MSGS, K, 1.0, "cam"), **fields)


@pytest.mark.parametrize(
    ("fields", "words"),
    [
        ({"k": np.array([579.0, 0.0, 320.0, 0.0])}, "camera_info k has 4 values, expected 9"),
        ({"k": np.zeros(12)}, "camera_info k has 12 values, expected 9"),
        ({"k": np.array([-579.0, 0, 320, 0, -579.0, 240, 0, 0, 1])}, "fx=-579, fy=-579; expected finite fx > 0"),
        ({"d": np.zeros(3)}, "distortion has 3 coefficients; expected 0, 4, 5, 8, 12, 14"),
        ({"d": np.zeros(7), "distortion_model": "rational_polynomial"}, "distortion has 7 coefficients"),
        ({"d": np.array([0.1, np.inf, 0, 0, 0])}, "distortion d has non-finite values"),
    ],
)
def test_unusable_camera_info_is_one_line_naming_the_field(fields, words):
    with pytest.raises(BadMessage) as err:
        camera_info_to_intrinsics(_info(**fields))
    assert words in str(err.value) and "\n" not in str(err.value) and err.value.kind == "value"


@pytest.mark.parametrize("d", [np.zeros(0), np.zeros(4), np.zeros(5), np.zeros(8), np.zeros(12), np.zeros(14)])
def test_every_distortion_length_opencv_knows_is_accepted(d):
    assert camera_info_to_intrinsics(_info(d=d)).distortion == tuple(d)


def test_bad_camera_info_gives_the_fallback_counted_and_warned_once_and_good_info_is_used_again(pipeline):
    world = pipeline.world
    for i in range(3):
        world.cache.on_camera_info(_with(_info(d=np.zeros(3)), header=pipeline.good_image().header))
        assert world.cache.on_image(pipeline.good_image(), TOPIC)
        assert pipeline.cycle().processed
        assert bbk.get(pipeline.bb, bbk.FRAME).intrinsics == CameraIntrinsics.fallback(640, 480), i
        track = read(bbk.TRACKS)["t"]
        assert track.visible and track.detection.extra["intrinsics"] == "fallback", i  # seen, and labelled degraded
    assert world.cache.stats.dropped == {"camera_info:value": 3} and world.cache.stats.fallback_intrinsics == 3
    [warning] = [w for w in world.warnings if "invalid camera info" in w]
    assert warning.startswith("invalid camera info on camera_info: camera_info distortion has 3 coefficients")
    assert pipeline.detects_the_marker()


# -- depth -------------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("encoding", "values", "valid"),
    [
        ("32FC1", [np.nan, np.inf, -np.inf, -1.0, 0.0, 2.5], [False, False, False, False, False, True]),
        ("16UC1", [0, 1, 65535], [False, True, True]),
    ],
)
def test_nan_inf_negative_and_zero_depth_become_no_return(encoding, values, valid):
    arr = np.array([values], np.float32 if encoding == "32FC1" else np.uint16)
    out = image_to_depth_m(array_to_image(MSGS, arr, encoding, 0.0, "d"))
    assert out.dtype == np.float32 and list(np.isfinite(out[0])) == valid
    assert np.all(out[np.isfinite(out)] > 0)


def test_depth_of_another_size_than_the_image_is_ignored_with_a_warning_and_the_frame_still_used(pipeline):
    world = pipeline.world
    world.cache.on_depth(array_to_image(MSGS, np.ones((240, 320), np.float32), "32FC1", 0.1, "cam"))
    world.cache.on_camera_info(intrinsics_to_camera_info(MSGS, K, 0.1, "cam"))
    assert world.cache.on_image(pipeline.good_image(), TOPIC)
    assert pipeline.cycle().processed
    assert bbk.get(pipeline.bb, bbk.FRAME).depth is None and read(bbk.TRACKS)["t"].visible
    assert any("depth (240, 320) does not match the image (480, 640); ignored" in w for w in world.warnings)


def test_a_camera_info_without_size_takes_the_images():
    info = _with(intrinsics_to_camera_info(MSGS, CameraIntrinsics(500, 500, 320, 240, 0, 0), 0.0, "cam"))
    assert (camera_info_to_intrinsics(info).width, camera_info_to_intrinsics(info).height) == (0, 0)
    world = RecordingWorld()
    world.cache.on_camera_info(info)
    world.cache.on_image(array_to_image(MSGS, VIEW.image, "bgr8", 0.0, "cam"))
    frame = world.cache.take_frame()
    assert (frame.intrinsics.width, frame.intrinsics.height, frame.intrinsics.fx) == (640, 480, 500)


# -- the node's own parameters -----------------------------------------------------------------------------


def _defaults() -> dict:
    return {name: default for name, (default, _doc) in PARAMETERS.items()}


@pytest.mark.parametrize(
    ("name", "value", "message"),
    [
        ("tick_hz", -5, "-p tick_hz: expected a number from 0 (the config's rate) to 200, got -5"),
        ("tick_hz", float("nan"), "-p tick_hz: expected a finite number, got nan"),
        ("tick_hz", "fast", "-p tick_hz: expected a finite number, got 'fast'"),
        ("marker_size_m", 0.0, "-p marker_size_m: expected a side length > 0 (m), got 0.0"),
        ("target_marker_id", 1.5, "-p target_marker_id: expected an integer, got 1.5"),
        ("serve_port", 70000, "-p serve_port: expected a TCP port 0..65535, got 70000"),
        ("groot_port", 65535, "-p groot_port: expected a TCP port 1..65534 (PORT and PORT+1 are used), or 0 for"),
        ("camera_xyz_rpy", [0.1, 0.0], "-p camera_xyz_rpy: expected 6 numbers [x, y, z, roll, pitch, yaw], got [0.1"),
        ("image_topic", 5, "-p image_topic: expected a string, got 5"),
    ],
)
def test_a_node_parameter_of_the_wrong_type_or_range_is_one_line_naming_it(name, value, message):
    with pytest.raises(ConfigError) as err:
        check_params({**_defaults(), name: value})
    assert str(err.value).startswith(message)


def test_an_unknown_node_parameter_is_named_with_the_likely_one():
    given = given_params(
        ["tree", "--ros-args", "-p", "marker_size:=0.1", "-r", "__ns:=/x", "-p", "mission_tree:tick_hz:=5"]
    )
    assert given == ["marker_size", "tick_hz"]
    with pytest.raises(ConfigError) as err:
        check_params(_defaults(), given)
    assert str(err.value).startswith("-p marker_size: unknown parameter (did you mean marker_size_m?); the node's ")
    check_params({**_defaults(), "tick_hz": 5}, ["tick_hz"])  # a node-prefixed known one is fine


@pytest.mark.parametrize(
    ("args", "line"),
    [
        (["-p", "tick_hz:=-5"], "mission_tree: error: -p tick_hz: expected a number from 0 (the config's rate) to 200"),
        (["-p", "image_topic:="], "mission_tree: error: --ros-args: Failed to parse ROS arguments: Couldn't parse"),
    ],
)
def test_mission_tree_with_a_bad_parameter_exits_2_with_one_line(args, line):
    proc = subprocess.run(
        [sys.executable, "-m", "mission", "tree", "--ros-args", *args],
        capture_output=True,
        text=True,
        timeout=60,
        cwd=ROOT,
    )
    assert proc.returncode == 2, proc.stderr
    errors = [ln for ln in proc.stderr.splitlines() if "DDS: shared memory only" not in ln]
    assert len(errors) == 1 and errors[0].startswith(line), proc.stderr


def test_a_busy_serve_port_is_named_as_the_node_parameter_that_chose_it():
    import socket

    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        proc = subprocess.run(
            [sys.executable, "-m", "mission", "tree", "--tree", "none", "--ros-args", "-p", f"serve_port:={port}"],
            capture_output=True,
            text=True,
            timeout=60,
            cwd=ROOT,
        )
    assert proc.returncode == 2, proc.stderr
    assert (
        f"mission_tree: error: -p serve_port:={port}: 127.0.0.1:{port} is already in use (another live view?); "
        "choose another with -p serve_port:=N, or -p serve_port:=0 for any free port"
    ) in proc.stderr


BAD_DOCK = """/**:
  ros__parameters:
    dock_plugins: ["tag_dock"]
    docks: ["home_dock"]
    home_dock: {type: "tag_dock", pose: [1.0, 2.0]}
"""


@pytest.mark.parametrize(
    ("text", "line"),
    [
        (None, "mission_tree: error: NOFILE: cannot read the params file (No such file or directory)"),
        (BAD_DOCK, "mission_tree: error: FILE: home_dock.pose: expected [x, y, yaw], got [1.0, 2.0]"),
        (
            BAD_DOCK.replace('type: "tag_dock"', 'type: "charger"').replace("2.0]", "2.0, 0.0]"),
            "mission_tree: error: FILE: home_dock.type: dock type 'charger' is not in dock_plugins; known: tag_dock",
        ),
    ],
)
def test_a_bad_nav2_params_file_stops_the_server_with_one_line_naming_the_file_and_key(tmp_path, text, line):
    path = tmp_path / "docking.yaml"
    if text is not None:
        path.write_text(text)
    proc = subprocess.run(
        [sys.executable, "-m", "mission", "tree", "--tree", "none", "--params-file", str(path)],
        capture_output=True,
        text=True,
        timeout=60,
        cwd=ROOT,
    )
    assert proc.returncode == 2, proc.stderr
    errors = [ln for ln in proc.stderr.splitlines() if "DDS: shared memory only" not in ln]
    expected = line.replace("NOFILE", str(path)).replace("FILE", str(path))
    assert len(errors) == 1 and errors[0] == expected, proc.stderr


# -- odometry, AMCL, scans and maps with impossible numbers ------------------------------------------------


def _odom(**change: float) -> object:
    msg = state_to_odometry(
        MSGS, RobotState(pose=Pose2D(1.0, 2.0, 0.3), twist=Twist(0.2, 0.1), stamp=1.0), "odom", "base_link"
    )
    p, tw = msg.pose.pose, msg.twist.twist
    for key, value in change.items():
        target, attr = {"x": (p.position, "x"), "z": (p.position, "z"), "v": (tw.linear, "x"), "w": (tw.angular, "z")}[
            key
        ]
        setattr(target, attr, value)
    return msg


@pytest.mark.parametrize(
    ("change", "words"),
    [
        ({"x": float("nan")}, "pose has a non-finite position (nan, 2, 0)"),
        ({"z": float("inf")}, "pose has a non-finite position (1, 2, inf)"),
        ({"v": float("nan")}, "odometry twist is not finite (v=nan, w=0.1)"),
        ({"w": float("-inf")}, "odometry twist is not finite (v=0.2, w=-inf)"),
    ],
)
def test_odometry_with_nan_or_inf_is_dropped_and_the_last_good_pose_kept(change, words):
    """Before: a NaN pose was taken as the robot's, and every target placed through it became NaN."""
    world = RecordingWorld()
    assert world.cache.on_odometry(_odom(), "/odom")
    assert world.cache.on_odometry(_odom(**change), "/odom") is False
    pose = world.cache.robot_state().pose
    assert (pose.x, pose.y, pose.yaw) == pytest.approx((1.0, 2.0, 0.3))
    assert world.cache.stats.dropped == {"odom:value": 1}
    assert world.warnings == [f"dropped a message on /odom: {words}"]


def test_a_scan_with_nan_angles_and_a_map_with_zero_resolution_are_dropped():
    scan = scan_to_msg(
        MSGS,
        LaserScan(
            angle_min=0.0,
            angle_increment=0.1,
            ranges=np.ones(8, np.float32),
            range_min=0.1,
            range_max=5.0,
            stamp=1.0,
            frame_id="laser",
        ),
    )
    scan.angle_increment = float("nan")
    with pytest.raises(BadMessage, match=r"scan has angle_min=0, angle_increment=nan; expected finite, increment ≠ 0"):
        scan_from_msg(scan)
    scan.angle_increment = 0.0
    world = RecordingWorld()
    assert world.cache.on_scan(scan, "/scan") is False and world.cache.stats.dropped == {"scan:value": 1}
    info = MSGS.new(
        "nav_msgs/msg/MapMetaData",
        map_load_time=time_msg(MSGS, 0.0),
        resolution=0.0,
        width=5,
        height=4,
        origin=matrix_to_pose(MSGS, np.eye(4)),
    )
    grid = MSGS.new(
        "nav_msgs/msg/OccupancyGrid", header=header_msg(MSGS, 1.0, "map"), info=info, data=np.zeros(20, np.int8)
    )
    with pytest.raises(BadMessage, match=r"map resolution is 0; expected a cell size > 0 \(m\)"):
        grid_from_msg(grid)
