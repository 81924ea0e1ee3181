"""A 6-DoF pose for "the thing at pixel (u, v)" from one RGB-D frame, without a model of the thing.

This is the geometric half of the VLM pipeline (the design notes' Gemini Robotics-ER node):

1. back-project the pixel with its depth through the lens the frame's intrinsics describe (each pixel's ray
   undistorted when the camera has distortion; pinhole x = (u-cx)·z/fx, y = (v-cy)·z/fy otherwise);
2. take the depth patch around it (a fixed physical radius, so the patch shrinks with distance), reject
   pixels whose depth is more than k·MAD (2.5) from the median — background behind a small target — and
   fit a plane by SVD: its normal, turned toward the camera, is the target's z axis. A stereo camera's depth
   noise grows with distance squared; far away it swamps the patch's few centimetres of width, and the
   "plane" the SVD finds then runs along the rays. Such a plane is not used: the surface is taken to face
   the camera at the patch's mean depth, which averages the noise instead of amplifying it. The point's
   standard error (``sigma_m``) says how far to trust it;
3. in-plane rotation: Canny edges on the image patch, PCA of their gradient vectors (the structure
   tensor) gives the dominant edge direction; when edges are balanced (a square, a printed tag) the
   4-fold circular mean of edge angles is used instead. The axis is carried onto the plane by
   intersecting pixel rays with it. A rectangle's in-plane angle is known modulo 90°: of the four
   candidate axes the one pointing most to the image's right is the x axis, so the choice is stable
   from frame to frame.

The resulting frame follows the marker convention of mission.core.types: z out of the surface toward
the camera, x right and y up as seen when facing it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from mission.core.types import CameraIntrinsics

MIN_PLANE_POINTS = 6
MIN_PLANE_FACING = 0.25  # |cos| between the pixel's ray and a fitted normal below which the plane is noise (75°)
MAX_PLANE_RMS = 0.3  # plane residual over the patch's half-width above which the plane is noise
BALANCED_EDGES = 0.3  # structure-tensor anisotropy below which a single "dominant edge" is not trusted


@dataclass(frozen=True)
class SurfacePose:
    """A surface point's pose in the camera optical frame, and how it was found."""

    T_camera_target: np.ndarray  # 4×4
    inliers: int  # depth pixels kept by the MAD test and used for the plane
    outliers: int  # depth pixels rejected by it
    plane_rms_m: float  # RMS distance of the inliers to the plane (the depth spread when no plane was used)
    edge_anisotropy: float  # 0 = balanced edges (4-fold mean used), 1 = one clear edge direction
    edge_pixels: int
    sigma_m: float = 0.0  # the point's standard error from the depth noise (how far two answers may differ)
    plane_used: bool = True  # False: the depth noise swamped the patch, the surface faces the camera


def mad_inliers(values: np.ndarray, k: float = 2.5) -> np.ndarray:
    """Boolean mask of values within k·MAD of the median (MAD = median absolute deviation).

    A zero MAD (more than half the values identical) keeps exactly the values equal to the median
    (within 1 mm), which is what "not an outlier" means then.
    """
    v = np.asarray(values, dtype=np.float64)
    med = np.median(v)
    dev = np.abs(v - med)
    mad = np.median(dev)
    return dev <= max(k * mad, 1e-3)


def fit_plane_svd(points: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """(centroid, unit normal, RMS residual) of the least-squares plane through N×3 points.

    The normal is the right singular vector of the centred points with the smallest singular value.
    """
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    centroid = p.mean(axis=0)
    _, s, vt = np.linalg.svd(p - centroid, full_matrices=False)
    normal = vt[-1] / np.linalg.norm(vt[-1])
    rms = float(s[-1] / math.sqrt(len(p))) if len(s) == 3 else 0.0
    return centroid, normal, rms


def depth_at(depth: np.ndarray, u: float, v: float, radius_px: int = 2) -> float | None:
    """Median valid depth in a small window around (u, v); None when there is none."""
    h, w = depth.shape[:2]
    iu, iv = int(np.rint(u)), int(np.rint(v))
    if not (0 <= iu < w and 0 <= iv < h):
        return None
    win = depth[max(0, iv - radius_px) : iv + radius_px + 1, max(0, iu - radius_px) : iu + radius_px + 1]
    win = win[np.isfinite(win) & (win > 0)]
    return float(np.median(win)) if win.size else None


def _ray(intr: CameraIntrinsics, u: float, v: float) -> np.ndarray:
    return intr.rays(np.array([u]), np.array([v]))[0]


def _ray_plane(ray: np.ndarray, centroid: np.ndarray, normal: np.ndarray) -> np.ndarray | None:
    denom = float(ray @ normal)
    if abs(denom) < 1e-9:
        return None
    t = float(centroid @ normal) / denom
    return ray * t if t > 0 else None


def dominant_edge_angle(gray_patch: np.ndarray) -> tuple[float | None, float, int]:
    """(edge angle in the image (rad, u right / v down) or None, anisotropy 0..1, edge pixel count).

    PCA of the image gradients at Canny edge pixels (the structure tensor): its principal axis is the
    dominant gradient direction, the edge runs perpendicular to it. When no direction dominates, the
    4-fold circular mean of edge angles gives the orientation of a rectangular pattern instead.
    """
    if gray_patch.size == 0 or min(gray_patch.shape[:2]) < 5:
        return None, 0.0, 0
    g = cv2.GaussianBlur(gray_patch, (3, 3), 0)
    edges = cv2.Canny(g, 50, 150)
    gx = cv2.Sobel(g, cv2.CV_64F, 1, 0, ksize=3)[edges > 0]
    gy = cv2.Sobel(g, cv2.CV_64F, 0, 1, ksize=3)[edges > 0]
    n = int(gx.size)
    if n < 8:
        return None, 0.0, n
    cov = np.array([[gx @ gx, gx @ gy], [gx @ gy, gy @ gy]]) / n
    evals, evecs = np.linalg.eigh(cov)  # ascending
    anisotropy = float((evals[1] - evals[0]) / (evals[1] + evals[0])) if evals.sum() > 0 else 0.0
    if anisotropy >= BALANCED_EDGES:
        grad = evecs[:, 1]
        return math.atan2(grad[1], grad[0]) + math.pi / 2, anisotropy, n
    # Balanced: mean of 4·θ over edge pixels (θ = gradient angle), weighted by gradient strength.
    theta = np.arctan2(gy, gx)
    weight = np.hypot(gx, gy)
    c, s = float(weight @ np.cos(4 * theta)), float(weight @ np.sin(4 * theta))
    if math.hypot(c, s) < 1e-6 * float(weight.sum()):
        return None, anisotropy, n
    return math.atan2(s, c) / 4 + math.pi / 2, anisotropy, n


def _rightmost_quadrant(x_axis: np.ndarray, normal: np.ndarray) -> np.ndarray:
    """Of x, y, -x, -y in the plane (y = n × x), the one pointing most to the camera's +x (image right)."""
    y_axis = np.cross(normal, x_axis)
    candidates = (x_axis, y_axis, -x_axis, -y_axis)
    return max(candidates, key=lambda a: float(a[0]))


def estimate_surface_pose(
    image: np.ndarray,
    depth: np.ndarray,
    intr: CameraIntrinsics,
    u: float,
    v: float,
    *,
    patch_radius_m: float = 0.05,
    mad_k: float = 2.5,
    box: tuple[float, float, float, float] | None = None,
) -> SurfacePose | None:
    """The pose of the surface at pixel (u, v), or None when the depth there is missing. A `box` (u0, v0,
    u1, v1 px: the model's box around the object) bounds the depth patch, so the plane is fitted to the
    object and not to what is beside it (kept at least 3 px a side)."""
    z0 = depth_at(depth, u, v)
    if z0 is None:
        return None
    h, w = depth.shape[:2]
    r = int(np.clip(round(intr.fx * patch_radius_m / z0), 3, max(3, min(h, w) // 4)))
    u0, u1 = max(0, int(np.rint(u)) - r), min(w, int(np.rint(u)) + r + 1)
    v0, v1 = max(0, int(np.rint(v)) - r), min(h, int(np.rint(v)) + r + 1)
    if box is not None:
        bu0, bv0 = max(u0, int(np.ceil(box[0]))), max(v0, int(np.ceil(box[1])))
        bu1, bv1 = min(u1, int(np.floor(box[2])) + 1), min(v1, int(np.floor(box[3])) + 1)
        if bu1 - bu0 >= 3 and bv1 - bv0 >= 3:
            u0, v0, u1, v1 = bu0, bv0, bu1, bv1
    patch = depth[v0:v1, u0:u1].astype(np.float64)
    vv, uu = np.mgrid[v0:v1, u0:u1]
    valid = np.isfinite(patch) & (patch > 0)
    z = patch[valid]
    keep = mad_inliers(z, mad_k)
    zs, us, vs = z[keep], uu[valid][keep], vv[valid][keep]
    pts = intr.rays(us, vs) * zs[:, None]

    ray = _ray(intr, u, v)
    ray_unit = ray / np.linalg.norm(ray)
    point = ray * z0
    facing = -ray_unit  # too few pixels or too much noise for a plane: the surface faces the camera
    normal, rms, sigma, plane_used = facing, 0.0, 0.0, False
    if len(zs) >= 2:
        rms = float(np.std(zs))
        sigma = rms * float(np.linalg.norm(ray)) / math.sqrt(len(zs))
    if len(pts) >= MIN_PLANE_POINTS:
        centroid, fitted, fit_rms = fit_plane_svd(pts)
        if fitted @ centroid > 0:  # turn the normal toward the camera (origin)
            fitted = -fitted
        cos = abs(float(ray_unit @ fitted))
        half_width = r * z0 / intr.fx
        determined = cos >= MIN_PLANE_FACING and fit_rms <= MAX_PLANE_RMS * half_width
        hit = _ray_plane(ray, centroid, fitted) if determined else None
        if hit is not None and abs(hit[2] - z0) < 0.5 * z0:
            point, normal, rms, plane_used = hit, fitted, fit_rms, True  # the ray through the plane: less noisy
            sigma = fit_rms / (math.sqrt(len(pts)) * cos)
        else:  # the noise runs along the rays: average it over the patch
            point = ray * float(np.mean(zs))

    gray = image if image.ndim == 2 else cv2.cvtColor(image, cv2.COLOR_BGR2GRAY)
    angle, anisotropy, n_edges = dominant_edge_angle(gray[v0:v1, u0:u1])
    x_axis = None
    if angle is not None:
        step = max(3.0, r / 2)
        p1 = _ray_plane(_ray(intr, u + step * math.cos(angle), v + step * math.sin(angle)), point, normal)
        if p1 is not None:
            d = p1 - point
            d -= (d @ normal) * normal
            if np.linalg.norm(d) > 1e-9:
                x_axis = d / np.linalg.norm(d)
    if x_axis is None:  # no usable edges: the camera's x axis projected onto the plane
        d = np.array([1.0, 0.0, 0.0]) - normal[0] * normal
        x_axis = d / np.linalg.norm(d) if np.linalg.norm(d) > 1e-9 else np.array([0.0, 1.0, 0.0])
    x_axis = _rightmost_quadrant(x_axis, normal)
    y_axis = np.cross(normal, x_axis)
    t = np.eye(4)
    t[:3, :3] = np.stack([x_axis, y_axis, normal], axis=1)
    t[:3, 3] = point
    return SurfacePose(
        T_camera_target=t,
        inliers=int(keep.sum()),
        outliers=int((~keep).sum()),
        plane_rms_m=rms,
        edge_anisotropy=anisotropy,
        edge_pixels=n_edges,
        sigma_m=float(sigma),
        plane_used=plane_used,
    )
