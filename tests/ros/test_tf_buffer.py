"""The node's TF buffer (mission/ros/tf_buffer.py): a robot's frame tree as /tf and /tf_static describe it —
map → odom → base_link (dynamic) and base_link → camera_link → camera_optical_frame (static) — looked up at
an image's stamp, and every way a TF tree goes wrong named in the error."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mission.core import se3
from mission.ros.tf_buffer import TfBuffer, TfError

CAMERA_LINK = se3.transform(se3.rot_y(0.1), (0.17, 0.0, 0.35))  # camera 17 cm forward, 35 cm up, pitched down
OPTICAL = se3.transform(se3.R_BODY_OPTICAL)


def robot_tree(tolerance_s: float = 0.05) -> TfBuffer:
    tf = TfBuffer(cache_s=10.0, tolerance_s=tolerance_s)
    tf.set_transform("base_link", "camera_link", 0.0, CAMERA_LINK, static=True)
    tf.set_transform("camera_link", "camera_optical_frame", 0.0, OPTICAL, static=True)
    for t in (0.0, 1.0):  # AMCL's correction, republished
        tf.set_transform("map", "odom", t, se3.planar(0.5, -0.2, 0.1))
    for i in range(11):  # the robot drives 1 m along odom x while turning 90°, sampled at 10 Hz
        t = i * 0.1
        tf.set_transform("odom", "base_link", t, se3.planar(t, 0.0, t * math.pi / 2))
    return tf


def test_a_camera_pose_at_an_image_stamp_between_odometry_samples_is_interpolated():
    tf = robot_tree()
    got = tf.lookup("map", "camera_optical_frame", 0.25)
    want = se3.compose(se3.planar(0.5, -0.2, 0.1), se3.planar(0.25, 0.0, 0.25 * math.pi / 2), CAMERA_LINK, OPTICAL)
    np.testing.assert_allclose(got, want, atol=1e-9)


def test_the_inverse_lookup_is_the_inverse_transform():
    tf = robot_tree()
    np.testing.assert_allclose(
        tf.lookup("camera_optical_frame", "map", 0.5),
        se3.invert(tf.lookup("map", "camera_optical_frame", 0.5)),
        atol=1e-9,
    )


def test_static_mount_needs_no_stamp():
    np.testing.assert_allclose(robot_tree().lookup("base_link", "camera_optical_frame", 123.0), CAMERA_LINK @ OPTICAL)


def test_an_image_a_little_newer_than_the_last_odometry_is_held_but_a_much_newer_one_is_stale():
    tf = robot_tree(tolerance_s=0.05)
    np.testing.assert_allclose(tf.lookup("odom", "base_link", 1.03), tf.lookup("odom", "base_link", 1.0))
    with pytest.raises(TfError, match=r"odom → base_link: the newest transform \(1.000 s\) is 0.50 s older") as err:
        tf.lookup("map", "camera_optical_frame", 1.5)
    assert err.value.kind == "stale"


def test_older_than_the_cache_is_an_error():
    tf = TfBuffer(cache_s=0.5)
    for i in range(20):
        tf.set_transform("odom", "base_link", i * 0.1, se3.planar(i * 0.1, 0, 0))
    with pytest.raises(TfError, match="older than the buffer holds") as err:
        tf.lookup("odom", "base_link", 0.2)
    assert err.value.kind == "past"


def test_a_missing_frame_and_unconnected_trees_are_named():
    tf = robot_tree()
    with pytest.raises(TfError, match="no such frame") as err:
        tf.lookup("map", "laser")
    assert err.value.kind == "missing"
    tf.set_transform("world", "gps", 0.0, np.eye(4))
    with pytest.raises(TfError, match=r"not connected.*'gps' ends at 'world', 'map' at 'map'"):
        tf.lookup("map", "gps")


def test_a_loop_in_the_tree_is_reported_not_followed_for_ever():
    tf = robot_tree()
    tf.set_transform("base_link", "odom", 1.0, np.eye(4))  # a second publisher with the link the wrong way round
    with pytest.raises(TfError, match="TF loop: base_link → odom → base_link") as err:
        tf.lookup("map", "camera_optical_frame", 1.0)
    assert err.value.kind == "loop"


def test_clearing_after_time_jumps_back_keeps_the_static_mount():
    tf = robot_tree()
    tf.clear()
    np.testing.assert_allclose(tf.lookup("base_link", "camera_optical_frame"), CAMERA_LINK @ OPTICAL)
    with pytest.raises(TfError, match="no transform to 'map': no such frame"):
        tf.lookup("map", "base_link")


def test_slerp_halfway_between_two_headings():
    half = se3.interpolate(se3.planar(0, 0, 0.2), se3.planar(2, 0, 1.0), 0.5)
    assert se3.yaw_of(half) == pytest.approx(0.6)
    assert half[0, 3] == pytest.approx(1.0)
