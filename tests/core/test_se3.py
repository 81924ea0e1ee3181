"""SE(3) helpers: conversions round-trip, compose/invert obey the TF convention."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mission.core import se3


def random_transform(rng: np.random.Generator) -> np.ndarray:
    q = se3.normalize_quat(rng.normal(size=4))
    return se3.from_pos_quat(rng.normal(size=3), q)


def test_quaternion_matrix_round_trip():
    rng = np.random.default_rng(0)
    for _ in range(200):
        q = se3.normalize_quat(rng.normal(size=4))
        assert np.allclose(se3.matrix_to_quat(se3.quat_to_matrix(q)), q, atol=1e-9)


def test_rvec_round_trip_matches_angle():
    v = np.array([0.1, -0.4, 0.3])
    r = se3.rvec_to_matrix(v)
    assert np.allclose(se3.matrix_to_rvec(r), v, atol=1e-9)
    assert math.isclose(se3.rotation_angle(np.eye(3), r), np.linalg.norm(v), abs_tol=1e-9)


def test_compose_with_inverse_is_identity():
    rng = np.random.default_rng(1)
    for _ in range(50):
        t = random_transform(rng)
        assert np.allclose(se3.compose(t, se3.invert(t)), np.eye(4), atol=1e-9)


def test_tf_convention_chains_frames():
    t_map_base = se3.planar(2.0, 1.0, math.pi / 2)
    t_base_cam = se3.transform(se3.R_BODY_OPTICAL, (0.2, 0.0, 0.5))
    point_cam = np.array([0.0, 0.0, 1.0])  # 1 m straight ahead of the camera
    point_map = se3.apply(se3.compose(t_map_base, t_base_cam), point_cam)
    # robot at (2, 1) facing +y: camera 0.2 m ahead, point 1 m further along +y, at camera height
    assert np.allclose(point_map, [2.0, 2.2, 0.5], atol=1e-9)


def test_zero_quaternion_is_an_error():
    with pytest.raises(ValueError, match="cannot be normalised"):
        se3.normalize_quat([0, 0, 0, 0])


def test_wrap_angle():
    assert math.isclose(se3.wrap_angle(3 * math.pi / 2), -math.pi / 2)
