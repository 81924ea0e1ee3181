"""sensor_msgs / geometry_msgs ↔ numpy and core types: the one conversion, for rclpy and rosbags messages."""

from __future__ import annotations

import math

import numpy as np
import pytest
from rosbags.typesys import Stores, get_typestore

from mission.core import se3
from mission.core.types import CameraIntrinsics, LaserScan, Pose2D, RobotState, Twist
from mission.ros.conversions import (
    BadMessage,
    array_to_image,
    camera_info_to_intrinsics,
    image_to_array,
    image_to_camera_array,
    image_to_depth_m,
    intrinsics_to_camera_info,
    odometry_to_state,
    pose_stamped,
    pose_stamped_to_matrix,
    scan_from_msg,
    scan_to_msg,
    state_to_odometry,
)
from mission.ros.messages import BagMessages, RclpyMessages, stamp_to_sec

pytestmark = pytest.mark.ros

FACTORIES = {"rclpy": RclpyMessages(), "rosbags": BagMessages(get_typestore(Stores.ROS2_JAZZY))}


@pytest.fixture(params=sorted(FACTORIES))
def factory(request):
    return FACTORIES[request.param]


def _bgr(h: int = 6, w: int = 5) -> np.ndarray:
    rng = np.random.default_rng(1)
    return rng.integers(0, 255, size=(h, w, 3), dtype=np.uint8)


@pytest.mark.parametrize("encoding", ["bgr8", "rgb8"])
def test_colour_images_round_trip_as_bgr_whatever_the_wire_order(factory, encoding):
    img = _bgr()
    msg = array_to_image(factory, img, encoding, 12.5, "cam")
    assert (msg.width, msg.height, msg.step, msg.encoding) == (5, 6, 15, encoding)
    assert np.array_equal(image_to_camera_array(msg), img)
    assert stamp_to_sec(msg.header.stamp) == pytest.approx(12.5)


def test_rgb8_on_the_wire_is_red_first():
    img = np.zeros((1, 1, 3), np.uint8)
    img[0, 0] = (255, 0, 0)  # pure blue in BGR
    msg = array_to_image(FACTORIES["rclpy"], img, "rgb8", 0.0, "cam")
    assert bytes(msg.data) == bytes([0, 0, 255])


def test_row_padding_in_step_is_skipped(factory):
    img = _bgr(4, 3)
    msg = array_to_image(factory, img, "bgr8", 0.0, "cam", step=16)  # 9 bytes of pixels + 7 of padding per row
    assert msg.step == 16 and len(msg.data) == 64
    assert np.array_equal(image_to_array(msg), img)


def test_mono8_comes_back_two_dimensional(factory):
    mono = np.arange(12, dtype=np.uint8).reshape(3, 4)
    out = image_to_camera_array(array_to_image(factory, mono, "mono8", 0.0, "cam", step=6))
    assert out.shape == (3, 4) and np.array_equal(out, mono)


def test_depth_16uc1_is_millimetres_and_zero_means_no_return(factory):
    depth_m = np.array([[0.5, 1.25], [np.nan, 3.0]], dtype=np.float32)
    msg = array_to_image(factory, depth_m, "16UC1", 0.0, "depth")
    assert image_to_array(msg).tolist() == [[500, 1250], [0, 3000]]
    out = image_to_depth_m(msg)
    assert out.dtype == np.float32 and out[0, 1] == pytest.approx(1.25) and math.isnan(out[1, 0])


def test_big_endian_16uc1_is_read_in_its_byte_order():
    msg = RclpyMessages().new(
        "sensor_msgs/msg/Image",
        height=1,
        width=2,
        encoding="16UC1",
        is_bigendian=1,
        step=4,
        data=np.array([0x01, 0xF4, 0x0B, 0xB8], np.uint8),
    )
    assert image_to_depth_m(msg).tolist() == [[0.5, 3.0]]


def test_depth_32fc1_is_metres_with_nan_for_no_return(factory):
    depth = np.array([[1.5, 0.0, np.inf]], dtype=np.float32)
    out = image_to_depth_m(array_to_image(factory, depth, "32FC1", 0.0, "depth", step=16))
    assert out[0, 0] == pytest.approx(1.5) and np.isnan(out[0, 1:]).all()


@pytest.mark.parametrize(
    ("change", "kind", "words"),
    [
        ({"encoding": "yuv422"}, "encoding", "unsupported encoding 'yuv422'"),
        ({"step": 10}, "size", "step 10 < width×bytes per pixel = 15"),
        ({"height": 7}, "size", "expected step×height = 15×7"),
        ({"width": 0}, "empty", "empty image"),
        ({"data": np.zeros(0, np.uint8)}, "empty", "empty image"),
    ],
)
def test_a_bad_image_raises_one_line_naming_what_was_expected(change, kind, words):
    m = RclpyMessages()
    msg = array_to_image(m, _bgr(), "bgr8", 0.0, "cam")
    for k, v in change.items():
        setattr(msg, k, m.new("sensor_msgs/msg/Image", data=v).data if k == "data" else v)
    with pytest.raises(BadMessage) as err:
        image_to_camera_array(msg)
    assert err.value.kind == kind and words in str(err.value) and "\n" not in str(err.value)


def test_depth_encodings_are_not_camera_images():
    msg = array_to_image(RclpyMessages(), np.ones((2, 2), np.float32), "32FC1", 0.0, "d")
    with pytest.raises(BadMessage, match="expected one of bgr8, rgb8, mono8"):
        image_to_camera_array(msg)


def test_camera_info_round_trips_intrinsics_with_distortion(factory):
    intr = CameraIntrinsics(
        fx=500.0, fy=501.0, cx=320.0, cy=239.0, width=640, height=480, distortion=(0.1, -0.05, 0.001, 0.002, 0.0)
    )
    msg = intrinsics_to_camera_info(factory, intr, 3.0, "cam")
    assert msg.distortion_model == "plumb_bob"
    assert np.allclose(np.asarray(msg.p).reshape(3, 4)[:, :3], intr.matrix)
    assert camera_info_to_intrinsics(msg) == intr


@pytest.mark.parametrize(("fx", "fy"), [(0.0, 500.0), (500.0, 0.0), (float("nan"), 500.0), (-1.0, 500.0)])
def test_camera_info_without_a_focal_length_is_invalid(fx, fy):
    m = RclpyMessages()
    msg = intrinsics_to_camera_info(m, CameraIntrinsics(1, 1, 320, 240, 640, 480), 0.0, "cam")
    k = np.asarray(msg.k).copy()
    k[0], k[4] = fx, fy
    msg.k = k
    with pytest.raises(BadMessage, match="expected finite fx > 0 and fy > 0"):
        camera_info_to_intrinsics(msg)


def test_pose_stamped_round_trips_a_transform(factory):
    t = se3.transform(se3.rot_z(0.3) @ se3.rot_x(-1.1), (0.2, -0.1, 1.7))
    msg = pose_stamped(factory, t, 4.25, "camera_optical_frame")
    back, stamp, frame = pose_stamped_to_matrix(msg)
    assert np.allclose(back, t) and stamp == pytest.approx(4.25) and frame == "camera_optical_frame"


def test_odometry_and_scan_round_trip(factory):
    state = RobotState(Pose2D(1.0, -2.0, 2.5), Twist(0.3, -0.2), 7.0)
    back = odometry_to_state(state_to_odometry(factory, state, "odom", "base_link"))
    assert back.pose.x == pytest.approx(1.0) and back.pose.yaw == pytest.approx(2.5)
    assert back.twist == Twist(pytest.approx(0.3), pytest.approx(-0.2)) and back.stamp == pytest.approx(7.0)
    scan = LaserScan(-1.0, 0.5, np.array([1.0, np.inf, 0.01, 2.0], np.float32), 0.1, 10.0, 7.0, "base_scan")
    out = scan_from_msg(scan_to_msg(factory, scan))
    assert out.ranges.tolist() == [1.0, np.inf, np.inf, 2.0] and out.angle_increment == pytest.approx(0.5)


# -- image_transport's compressed images ---------------------------------------------------------------


def test_a_png_compressed_image_is_the_image_and_a_jpeg_one_is_close(factory):
    from mission.ros.conversions import array_to_compressed_image

    img = _bgr(48, 64)
    png = array_to_compressed_image(factory, img, "png", 2.5, "cam")
    assert png.format == "bgr8; png compressed bgr8" and stamp_to_sec(png.header.stamp) == 2.5
    assert np.array_equal(image_to_camera_array(png), img)
    smooth = np.tile(np.linspace(0, 255, 64, dtype=np.uint8), (48, 1))
    jpeg = array_to_compressed_image(factory, smooth, "jpeg", 2.5, "cam")
    out = image_to_camera_array(jpeg)
    assert out.shape == (48, 64) and np.abs(out.astype(int) - smooth).mean() < 2.0  # mono stays mono


def test_compressed_depth_is_millimetres_with_no_return_kept(factory):
    from mission.ros.conversions import depth_to_compressed_depth

    depth = np.full((4, 5), 1.234, np.float32)
    depth[0, 0] = np.nan
    msg = depth_to_compressed_depth(factory, depth, 1.0, "depth")
    assert msg.format == "16UC1; compressedDepth png"
    out = image_to_depth_m(msg)
    assert np.isnan(out[0, 0]) and np.allclose(out[1:], 1.234, atol=5e-4)


def test_32fc1_compressed_depth_is_inverse_depth_as_image_transport_quantises_it(factory):
    """image_transport's compressedDepth for 32FC1: value = A / depth + B, A = q (q + 1), B = 1 − A / depth_max."""
    import struct

    import cv2

    depth = np.array([[0.5, 1.0], [2.0, np.nan]], np.float32)
    quant, dmax = 100.0, 10.0
    a, b = quant * (quant + 1.0), 1.0 - quant * (quant + 1.0) / dmax
    inv = np.where(np.isfinite(depth), a / np.nan_to_num(depth, nan=1.0) + b, 0).astype(np.uint16)
    payload = struct.pack("<iff", 0, a, b) + cv2.imencode(".png", inv)[1].tobytes()
    msg = factory.new(
        "sensor_msgs/msg/CompressedImage",
        header=array_to_image(factory, np.zeros((1, 1), np.uint8), "mono8", 0.0, "d").header,
        format="32FC1; compressedDepth png",
        data=np.frombuffer(payload, np.uint8),
    )
    out = image_to_depth_m(msg)
    assert np.isnan(out[1, 1]) and np.allclose(out[np.isfinite(depth)], depth[np.isfinite(depth)], rtol=0.01)


def test_compressed_data_that_is_not_an_image_is_a_bad_message(factory):
    from mission.ros.conversions import array_to_compressed_image

    msg = array_to_compressed_image(factory, _bgr(), "png", 0.0, "cam")
    msg.data = np.frombuffer(b"not a png at all", np.uint8)
    with pytest.raises(BadMessage) as err:
        image_to_camera_array(msg)
    assert err.value.kind == "encoding" and "not a decodable JPEG or PNG" in err.value.detail
    msg.format = "16UC1; compressedDepth rvl"
    with pytest.raises(BadMessage, match="RVL"):
        image_to_depth_m(msg)


def test_ros1_camera_info_spells_its_arrays_in_capitals():
    """What rosbags reads from a ROS 1 bag: sensor_msgs/CameraInfo with D, K, R, P."""
    store = get_typestore(Stores.ROS1_NOETIC)
    intr = CameraIntrinsics(500.0, 502.0, 320.0, 240.0, 640, 480, (0.1, -0.2, 0.0, 0.0, 0.0))
    ros2 = intrinsics_to_camera_info(FACTORIES["rosbags"], intr, 1.0, "cam")
    roi = store.types["sensor_msgs/msg/RegionOfInterest"](x_offset=0, y_offset=0, height=0, width=0, do_rectify=False)
    info = store.types["sensor_msgs/msg/CameraInfo"](
        header=store.types["std_msgs/msg/Header"](seq=0, stamp=ros2.header.stamp, frame_id="cam"),
        height=480,
        width=640,
        distortion_model="plumb_bob",
        D=np.asarray(ros2.d),
        K=np.asarray(ros2.k),
        R=np.asarray(ros2.r),
        P=np.asarray(ros2.p),
        binning_x=0,
        binning_y=0,
        roi=roi,
    )
    assert camera_info_to_intrinsics(info) == intr
