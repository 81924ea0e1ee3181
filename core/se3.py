"""The one SE(3) helper: rigid transforms as 4×4 numpy arrays, quaternions as (x, y, z, w).

Naming follows the TF convention: ``T_a_b`` maps points expressed in frame b into frame a
(the pose of b in a), so ``T_a_c = T_a_b @ T_b_c`` and ``inv(T_a_b) == T_b_a``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

ArrayLike = Sequence[float] | np.ndarray


def normalize_quat(q: ArrayLike) -> np.ndarray:
    """Unit quaternion with w ≥ 0 (one representative of ±q); raises on a zero or non-finite input.

    On Python floats: every detection's orientation passes through here (bench: perception).
    """
    x, y, z, w = np.asarray(q, dtype=np.float64).reshape(4).tolist()
    n = math.hypot(x, y, z, w)  # no overflow or underflow at any scale, as np.linalg.norm
    if not math.isfinite(n) or n < 1e-12:
        raise ValueError(f"quaternion {[x, y, z, w]} cannot be normalised")
    if w < 0:
        n = -n
    return np.array([x / n, y / n, z / n, w / n])


def quat_to_matrix(q: ArrayLike) -> np.ndarray:
    """3×3 rotation matrix of quaternion (x, y, z, w)."""
    x, y, z, w = normalize_quat(q)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


def matrix_to_quat(r: np.ndarray) -> np.ndarray:
    """Quaternion (x, y, z, w) of a 3×3 rotation matrix (Shepperd's method, stable for all angles)."""
    # Python floats, not numpy element reads: it runs for every detection (bench: perception).
    (m00, m01, m02), (m10, m11, m12), (m20, m21, m22) = np.asarray(r, dtype=np.float64)[:3, :3].tolist()
    tr = m00 + m11 + m22
    if tr > 0:
        s = math.sqrt(tr + 1.0) * 2
        q = [(m21 - m12) / s, (m02 - m20) / s, (m10 - m01) / s, 0.25 * s]
    elif m00 > m11 and m00 > m22:
        s = math.sqrt(1.0 + m00 - m11 - m22) * 2
        q = [0.25 * s, (m01 + m10) / s, (m02 + m20) / s, (m21 - m12) / s]
    elif m11 > m22:
        s = math.sqrt(1.0 + m11 - m00 - m22) * 2
        q = [(m01 + m10) / s, 0.25 * s, (m12 + m21) / s, (m02 - m20) / s]
    else:
        s = math.sqrt(1.0 + m22 - m00 - m11) * 2
        q = [(m02 + m20) / s, (m12 + m21) / s, 0.25 * s, (m10 - m01) / s]
    return normalize_quat(q)


def rvec_to_matrix(rvec: ArrayLike) -> np.ndarray:
    """Rodrigues: axis-angle vector (OpenCV's rvec) → 3×3 rotation.

    Written out on scalars: it runs for both pose hypotheses of every marker in every frame, and the
    matrix form (skew matrix, two products) costs ~10× more in numpy call overhead.
    """
    x, y, z = np.asarray(rvec, dtype=np.float64).reshape(3).tolist()
    theta = math.sqrt(x * x + y * y + z * z)
    if theta < 1e-12:
        return np.eye(3)
    x, y, z = x / theta, y / theta, z / theta
    c, s = math.cos(theta), math.sin(theta)
    k = 1.0 - c
    return np.array(
        [
            [c + x * x * k, x * y * k - z * s, x * z * k + y * s],
            [y * x * k + z * s, c + y * y * k, y * z * k - x * s],
            [z * x * k - y * s, z * y * k + x * s, c + z * z * k],
        ]
    )


def matrix_to_rvec(r: np.ndarray) -> np.ndarray:
    """3×3 rotation → axis-angle vector (OpenCV's rvec)."""
    q = matrix_to_quat(r)
    s = float(np.linalg.norm(q[:3]))
    if s < 1e-12:
        return np.zeros(3)
    angle = 2.0 * math.atan2(s, q[3])
    return q[:3] / s * angle


def transform(rotation: np.ndarray | None = None, translation: ArrayLike | None = None) -> np.ndarray:
    """A 4×4 transform from a 3×3 rotation and a translation (either may be omitted)."""
    t = np.eye(4)
    if rotation is not None:
        t[:3, :3] = np.asarray(rotation, dtype=np.float64)
    if translation is not None:
        t[:3, 3] = np.asarray(translation, dtype=np.float64).reshape(3)
    return t


def from_pos_quat(position: ArrayLike, quat: ArrayLike) -> np.ndarray:
    """4×4 transform from a position and a quaternion (x, y, z, w)."""
    return transform(quat_to_matrix(quat), position)


def to_pos_quat(t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(position (3,), quaternion (4,)) of a 4×4 transform."""
    return np.asarray(t[:3, 3], dtype=np.float64).copy(), matrix_to_quat(t[:3, :3])


def invert(t: np.ndarray) -> np.ndarray:
    """Inverse of a rigid transform (uses Rᵀ, not a general matrix inverse)."""
    r = t[:3, :3]
    out = np.eye(4)
    out[:3, :3] = r.T
    out[:3, 3] = -r.T @ t[:3, 3]
    return out


def compose(*ts: np.ndarray) -> np.ndarray:
    """T0 @ T1 @ … — chain transforms left to right (T_a_b, T_b_c, … → T_a_z)."""
    out = np.eye(4)
    for t in ts:
        out = out @ t
    return out


def apply(t: np.ndarray, points: ArrayLike) -> np.ndarray:
    """Transform N×3 (or 3,) points by a 4×4 transform."""
    p = np.asarray(points, dtype=np.float64)
    flat = p.reshape(-1, 3)
    out = flat @ t[:3, :3].T + t[:3, 3]
    return out.reshape(p.shape)


def rot_x(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]], dtype=np.float64)


def rot_y(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]], dtype=np.float64)


def rot_z(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]], dtype=np.float64)


def planar(x: float, y: float, yaw: float, z: float = 0.0) -> np.ndarray:
    """The 4×4 transform of a floor pose (x, y, yaw) at height z."""
    return transform(rot_z(yaw), (x, y, z))


def yaw_of(t: np.ndarray) -> float:
    """Heading of a transform's x axis projected on the floor."""
    return math.atan2(t[1, 0], t[0, 0])


def rotation_angle(r_a: np.ndarray, r_b: np.ndarray) -> float:
    """Angle (rad) of the relative rotation between two 3×3 rotations."""
    # trace(Aᵀ·B) is the sum of the element-wise product: one dot product of the flattened matrices
    c = (float(np.vdot(np.asarray(r_a)[:3, :3], np.asarray(r_b)[:3, :3])) - 1.0) / 2.0
    return math.acos(max(-1.0, min(1.0, c)))


def wrap_angle(a: float) -> float:
    """Angle wrapped into (-π, π]."""
    return math.atan2(math.sin(a), math.cos(a))


# The optical frame (x right, y down, z forward) seen from a body frame (x forward, y left, z up).
R_BODY_OPTICAL = np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])


def slerp(q0: ArrayLike, q1: ArrayLike, f: float) -> np.ndarray:
    """Spherical interpolation between unit quaternions (x, y, z, w): q0 at f = 0, q1 at f = 1, shortest arc."""
    a, b = normalize_quat(q0), normalize_quat(q1)
    dot = float(a @ b)
    if dot < 0.0:  # q and −q are the same rotation: go the short way
        b, dot = -b, -dot
    if dot > 0.9995:  # nearly equal: linear is exact enough and avoids dividing by sin(≈0)
        return normalize_quat(a + f * (b - a))
    theta = math.acos(dot)
    s = math.sin(theta)
    return (math.sin((1.0 - f) * theta) / s) * a + (math.sin(f * theta) / s) * b


def interpolate(t0: np.ndarray, t1: np.ndarray, f: float) -> np.ndarray:
    """The pose a fraction `f` of the way from `t0` to `t1`: translation linear, rotation slerped (as tf2 does)."""
    p0, q0 = to_pos_quat(t0)
    p1, q1 = to_pos_quat(t1)
    return from_pos_quat(p0 + f * (p1 - p0), slerp(q0, q1, f))
