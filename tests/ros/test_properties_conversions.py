"""Properties of the image ↔ message conversion (mission/ros/conversions.py) over generated images:
every supported encoding round-trips at any size and row padding, on rclpy and rosbags messages alike,
either byte order reads the same values, and a message with arbitrary header fields either converts to
the shape it declares or raises BadMessage — never another exception."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp
from rosbags import typesys as rosbags_typesys

from mission.core.types import DISTORTION_LENGTHS, CameraIntrinsics
from mission.ros.conversions import (
    ENCODINGS,
    BadMessage,
    array_to_image,
    camera_info_to_intrinsics,
    image_to_array,
    image_to_depth_m,
    intrinsics_to_camera_info,
)
from mission.ros.messages import BagMessages, RclpyMessages

pytestmark = pytest.mark.ros
SETTINGS = settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])


# Both message flavours the node meets: rclpy's (live topics) and rosbags' (recordings). The [ros] extra
# installs both, so neither is optional here: a missing one fails the suite instead of skipping.
FACTORIES = {
    "rosbags": BagMessages(rosbags_typesys.get_typestore(rosbags_typesys.Stores.ROS2_JAZZY)),
    "rclpy": RclpyMessages(),
}


@pytest.fixture(params=list(FACTORIES))
def factory(request):
    return FACTORIES[request.param]


def images(encoding: str) -> st.SearchStrategy[np.ndarray]:
    dtype, channels = ENCODINGS[encoding]
    shape = st.tuples(st.integers(1, 9), st.integers(1, 9)).map(lambda hw: hw + ((channels,) if channels > 1 else ()))
    elements = st.floats(width=32, allow_nan=True, allow_infinity=True) if dtype.kind == "f" else None
    return hnp.arrays(dtype, shape, elements=elements)


def same(a: np.ndarray, b: np.ndarray) -> bool:
    """Equal values, NaN equal to NaN (for 32FC1)."""
    return a.shape == b.shape and a.dtype == b.dtype and np.array_equal(a, b, equal_nan=a.dtype.kind == "f")


@SETTINGS
@given(data=st.data(), encoding=st.sampled_from(sorted(ENCODINGS)), padding=st.integers(0, 17))
def test_every_encoding_round_trips_at_any_size_and_row_padding(factory, data, encoding, padding):
    arr = data.draw(images(encoding))
    dtype, channels = ENCODINGS[encoding]
    step = arr.shape[1] * channels * dtype.itemsize + padding
    msg = array_to_image(factory, arr, encoding, 12.5, "cam", step=step)
    assert (msg.height, msg.width, msg.step, msg.encoding) == (arr.shape[0], arr.shape[1], step, encoding)
    assert same(image_to_array(msg), arr)  # colour comes back BGR whatever the wire order


@SETTINGS
@given(data=st.data(), encoding=st.sampled_from(["16UC1", "32FC1"]))
def test_big_endian_depth_reads_the_same_values(factory, data, encoding):
    arr = data.draw(images(encoding))
    little = array_to_image(factory, arr, encoding, 0.0, "d")
    swapped = np.ascontiguousarray(arr, dtype=arr.dtype.newbyteorder(">")).view(np.uint8).reshape(-1)
    big = array_to_image(factory, arr, encoding, 0.0, "d")
    big.is_bigendian = 1
    big.data = swapped if isinstance(factory, BagMessages) else factory.new("sensor_msgs/msg/Image", data=swapped).data
    assert same(image_to_array(big), arr) and same(image_to_array(little), arr)


@SETTINGS
@given(data=st.data(), encoding=st.sampled_from(["16UC1", "32FC1"]))
def test_depth_in_metres_is_positive_and_finite_or_nan(data, encoding):
    arr = data.draw(images(encoding))
    depth = image_to_depth_m(array_to_image(FACTORIES["rosbags"], arr, encoding, 0.0, "d"))
    assert depth.dtype == np.float32 and depth.shape == arr.shape
    valid = np.isfinite(depth)
    assert np.all(depth[valid] > 0)
    if encoding == "16UC1":
        assert np.array_equal(valid, arr > 0) and np.allclose(depth[valid], arr[arr > 0] / 1000.0)
    else:
        assert np.array_equal(valid, np.isfinite(arr) & (arr > 0)) and np.array_equal(depth[valid], arr[valid])


@SETTINGS
@given(
    encoding=st.sampled_from([*sorted(ENCODINGS), "yuv422", ""]),
    height=st.integers(0, 12),
    width=st.integers(0, 12),
    step=st.integers(0, 60),
    nbytes=st.integers(0, 600),
    big_endian=st.booleans(),
)
def test_a_message_with_arbitrary_fields_converts_to_its_declared_shape_or_raises_bad_message(
    encoding, height, width, step, nbytes, big_endian
):
    m = FACTORIES["rosbags"]
    msg = array_to_image(m, np.zeros((1, 1, 3), np.uint8), "bgr8", 0.0, "cam")
    msg.encoding, msg.height, msg.width, msg.step, msg.is_bigendian = encoding, height, width, step, int(big_endian)
    msg.data = np.arange(nbytes, dtype=np.uint8)
    try:
        out = image_to_array(msg)
    except BadMessage as err:
        assert err.kind in ("encoding", "size", "empty") and "\n" not in str(err)
        return
    dtype, channels = ENCODINGS[encoding]
    assert out.shape == ((height, width, channels) if channels > 1 else (height, width))
    assert out.dtype == dtype and out.flags["C_CONTIGUOUS"]


intrinsics = st.builds(
    CameraIntrinsics,
    fx=st.floats(1e-3, 1e5),
    fy=st.floats(1e-3, 1e5),
    cx=st.floats(-1e4, 1e4),
    cy=st.floats(-1e4, 1e4),
    width=st.integers(0, 8192),
    height=st.integers(0, 8192),
    distortion=st.sampled_from([n for n in DISTORTION_LENGTHS if n]).flatmap(
        lambda n: st.tuples(*[st.floats(-10, 10)] * n)
    ),
)


@SETTINGS
@given(intr=intrinsics)
def test_camera_info_round_trips_every_valid_calibration(factory, intr):
    assert camera_info_to_intrinsics(intrinsics_to_camera_info(factory, intr, 3.0, "cam")) == intr
