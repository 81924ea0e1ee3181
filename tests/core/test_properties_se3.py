"""Properties of the SE(3) helpers (core/se3.py) over generated rotations and translations:
compose/invert round-trips, quaternion normalisation, quaternion ↔ matrix and rvec ↔ matrix."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from mission.core import se3

SETTINGS = settings(max_examples=150, deadline=None)
TOL = 1e-9

finite = st.floats(-1e3, 1e3, allow_nan=False, allow_infinity=False)
positions = st.tuples(finite, finite, finite).map(np.array)
raw_quats = st.tuples(*[st.floats(-1.0, 1.0, allow_nan=False)] * 4).map(np.array)
quats = raw_quats.filter(lambda q: np.linalg.norm(q) > 1e-3).map(se3.normalize_quat)
transforms = st.builds(se3.from_pos_quat, positions, quats)
# rotation vectors with angle < π (where the axis-angle form is unique)
rvecs = (
    st.tuples(*[st.floats(-1.8, 1.8, allow_nan=False)] * 3)
    .map(np.array)
    .filter(lambda v: np.linalg.norm(v) < math.pi - 1e-3)
)


def is_rotation(r: np.ndarray) -> bool:
    return np.allclose(r @ r.T, np.eye(3), atol=1e-9) and abs(np.linalg.det(r) - 1.0) < 1e-9


@SETTINGS
@given(transforms)
def test_a_transform_composed_with_its_inverse_is_the_identity(t):
    assert np.allclose(se3.compose(t, se3.invert(t)), np.eye(4), atol=1e-9)
    assert np.allclose(se3.compose(se3.invert(t), t), np.eye(4), atol=1e-9)


@SETTINGS
@given(transforms)
def test_inverting_twice_gives_the_transform_back_and_stays_rigid(t):
    inv = se3.invert(t)
    assert is_rotation(inv[:3, :3]) and np.array_equal(inv[3], [0, 0, 0, 1])
    assert np.allclose(se3.invert(inv), t, atol=1e-9)


@SETTINGS
@given(transforms, transforms, transforms)
def test_compose_is_associative_and_its_inverse_reverses_the_chain(a, b, c):
    assert np.allclose(se3.compose(se3.compose(a, b), c), se3.compose(a, se3.compose(b, c)), atol=1e-6)
    assert np.allclose(se3.invert(se3.compose(a, b)), se3.compose(se3.invert(b), se3.invert(a)), atol=1e-6)


@SETTINGS
@given(transforms, st.lists(st.tuples(finite, finite, finite), min_size=1, max_size=5).map(np.array))
def test_applying_a_transform_then_its_inverse_returns_the_points(t, points):
    back = se3.apply(se3.invert(t), se3.apply(t, points))
    assert np.allclose(back, points, atol=1e-6)


@SETTINGS
@given(raw_quats, st.floats(1e-6, 1e6))
def test_normalisation_gives_a_unit_quaternion_with_w_non_negative_whatever_the_scale(q, scale):
    assume(np.linalg.norm(q) > 1e-3)
    n = se3.normalize_quat(q * scale)
    assert abs(np.linalg.norm(n) - 1.0) < TOL and n[3] >= 0
    # scale does not matter — up to the sign where w is ~0 (w = −5e-324 halves to −0.0: either is w ≥ 0)
    assert np.allclose(n, se3.normalize_quat(q), atol=1e-9) or abs(n[3]) < 1e-12
    assert np.allclose(se3.normalize_quat(-q), n, atol=1e-9) or abs(n[3]) < 1e-12  # ±q: one representative
    assert np.allclose(se3.normalize_quat(n), n, atol=TOL)  # idempotent


@SETTINGS
@given(st.tuples(*[st.sampled_from([0.0, 1e-13, -1e-14, math.nan, math.inf, -math.inf, 0.5])] * 4))
def test_a_zero_or_non_finite_quaternion_raises_instead_of_returning_nan(q):
    norm = math.sqrt(sum(v * v for v in q)) if all(math.isfinite(v) for v in q) else math.nan
    if math.isfinite(norm) and norm >= 1e-12:
        assert np.all(np.isfinite(se3.normalize_quat(q)))
    else:
        try:
            se3.normalize_quat(q)
        except ValueError as err:
            assert "cannot be normalised" in str(err)
        else:
            raise AssertionError(f"{q} was normalised")


@SETTINGS
@given(quats)
def test_quaternion_to_matrix_and_back_is_the_same_rotation(q):
    r = se3.quat_to_matrix(q)
    assert is_rotation(r)
    assert np.allclose(se3.matrix_to_quat(r), q, atol=1e-9) or np.allclose(se3.matrix_to_quat(r), -q, atol=1e-9)


@SETTINGS
@given(transforms)
def test_position_and_quaternion_round_trip_through_a_transform(t):
    pos, quat = se3.to_pos_quat(t)
    assert np.allclose(se3.from_pos_quat(pos, quat), t, atol=1e-9)


@SETTINGS
@given(rvecs)
def test_rvec_to_matrix_and_back_is_the_same_vector_below_pi(v):
    r = se3.rvec_to_matrix(v)
    assert is_rotation(r)
    assert np.allclose(se3.matrix_to_rvec(r), v, atol=1e-7)


@SETTINGS
@given(quats)
def test_any_rotation_survives_matrix_to_rvec_to_matrix_even_near_pi(q):
    r = se3.quat_to_matrix(q)
    v = se3.matrix_to_rvec(r)
    assert np.linalg.norm(v) <= math.pi + 1e-9
    assert np.allclose(se3.rvec_to_matrix(v), r, atol=1e-7)
    assert se3.rotation_angle(se3.rvec_to_matrix(v), r) < 1e-6


@SETTINGS
@given(st.floats(-1e4, 1e4, allow_nan=False))
def test_wrap_angle_lands_in_minus_pi_to_pi_and_keeps_the_direction(a):
    w = se3.wrap_angle(a)
    assert -math.pi <= w <= math.pi
    assert math.isclose(math.cos(w), math.cos(a), abs_tol=1e-9) and math.isclose(math.sin(w), math.sin(a), abs_tol=1e-9)
