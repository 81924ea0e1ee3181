"""What happens to a printed marker between the world and the sensor over one exposure (issue 33): it moves,
and it shines.

* **Smear.** The camera model blurs the whole picture by the camera's own rotation (a yaw rate ω moves the
  image by ω · t · fx). A marker also moves in the picture because the robot drives and because the target
  walks; its smear is the motion of its projected corners between the exposure's start and end, with the
  lens. :meth:`MarkerOptics.smear` blurs the marker's neighbourhood along that vector, so a target crossing
  the view at 0.5 m/s, 1.5 m away, under 20 ms of exposure is smeared by 0.5 · 0.02 · fx / 1.5 ≈ 4 px while
  the wall behind it is not.
* **Glare.** A glossy print mirrors the light. Where the mirror direction of the light about the marker's
  normal points at the camera, the print is washed out: :meth:`MarkerOptics.glare` adds a Phong lobe,
  ``gloss`` × 255 at perfect alignment, falling off as (R · V)^``GLOSS_SHININESS``, on the printed sheet only.
  The light is the scenario's (``lighting.direction``): a lamp overhead never mirrors into a camera at the
  marker's height; a low window light does, from one side.

Both work on the lens's picture (after distortion), with the true camera; the detector is told its
calibration elsewhere (sim/camera_model.py).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import cv2
import numpy as np

GLOSS_SHININESS = 40.0  # a laminated print: the highlight covers a few degrees of viewing angle
FEATHER_PX = 2  # the smeared neighbourhood blends into the picture over this many pixels
MIN_EXTRA_SMEAR_PX = 0.5  # a marker's own motion below this adds nothing the rotation blur has not
MAX_SMEAR_PX = 120.0  # a longer smear leaves nothing of a marker to read: not worth the kernel
FIELD_MARGIN = 1.5  # sheets are projected up to this far beyond the field of view's edge (normalized coords)


@dataclass(frozen=True)
class PrintedQuad:
    """A printed sheet (black square and quiet zone) at the exposure's start and end, in the map frame."""

    side_m: float
    T_start: np.ndarray
    T_end: np.ndarray

    def corners(self, T: np.ndarray) -> np.ndarray:
        """The sheet's four corners (map frame) when it is at pose `T` (its normal is T's z axis)."""
        h = self.side_m / 2.0
        local = np.array([[-h, -h, 0.0], [h, -h, 0.0], [h, h, 0.0], [-h, h, 0.0]])
        return local @ T[:3, :3].T + T[:3, 3]


@dataclass(frozen=True)
class Exposure:
    """Where the camera and the markers were over one exposure (map frame, optical convention)."""

    T_opt_start: np.ndarray
    T_opt_mid: np.ndarray
    T_opt_end: np.ndarray
    quads: Sequence[PrintedQuad]
    light_direction: tuple[float, float, float]
    gloss: float


class MarkerOptics:
    """Projects printed sheets through the true lens, smears and lights them (module doc)."""

    def __init__(self, K: np.ndarray, distortion: np.ndarray, width: int, height: int) -> None:
        self.K = K
        self.distortion = distortion
        self.width = width
        self.height = height
        corners = np.array([[0.0, 0.0], [width - 1.0, 0.0], [0.0, height - 1.0], [width - 1.0, height - 1.0]])
        rays = cv2.undistortPoints(corners.reshape(-1, 1, 2), K, distortion).reshape(-1, 2)
        # how far off the axis the lens sees (x/z, y/z), with a margin: beyond it the polynomial means nothing
        self.reach = np.abs(rays).max(axis=0) * FIELD_MARGIN

    def project(self, points_map: np.ndarray, T_map_opt: np.ndarray) -> np.ndarray | None:
        """Pixels of map points seen from `T_map_opt`, or None if any is behind the camera or well outside
        its field of view (where the lens model's polynomial is meaningless)."""
        T = np.linalg.inv(T_map_opt)
        cam = points_map @ T[:3, :3].T + T[:3, 3]
        if np.any(cam[:, 2] <= 0.05):
            return None
        if np.any(np.abs(cam[:, :2] / cam[:, 2:3]) > self.reach):
            return None
        px, _ = cv2.projectPoints(cam, np.zeros(3), np.zeros(3), self.K, self.distortion)
        return px.reshape(-1, 2)

    def image_motion(self, quad: PrintedQuad, ex: Exposure) -> tuple[np.ndarray, np.ndarray] | None:
        """The sheet's corners at the exposure's start and end (px), or None when it is not in front."""
        a = self.project(quad.corners(quad.T_start), ex.T_opt_start)
        b = self.project(quad.corners(quad.T_end), ex.T_opt_end)
        if a is None or b is None:
            return None
        return a, b

    def _roi(self, pts: np.ndarray, pad: float) -> tuple[int, int, int, int] | None:
        x0 = max(0, math.floor(float(pts[:, 0].min()) - pad))
        y0 = max(0, math.floor(float(pts[:, 1].min()) - pad))
        x1 = min(self.width, math.ceil(float(pts[:, 0].max()) + pad) + 1)
        y1 = min(self.height, math.ceil(float(pts[:, 1].max()) + pad) + 1)
        if x1 - x0 < 2 or y1 - y0 < 2:
            return None
        return x0, y0, x1, y1

    def smear(self, sharp: np.ndarray, out: np.ndarray, ex: Exposure, rotation_px: float) -> None:
        """Blur each sheet's neighbourhood in `out` along its own image motion, from the unblurred `sharp`,
        where that motion differs from the rotation smear already in `out`."""
        for quad in ex.quads:
            moved = self.image_motion(quad, ex)
            if moved is None:
                continue
            a, b = moved
            flow = (b - a).mean(axis=0)
            length = float(np.hypot(*flow))
            if abs(length - rotation_px) < MIN_EXTRA_SMEAR_PX and abs(flow[1]) < MIN_EXTRA_SMEAR_PX:
                continue
            if length > MAX_SMEAR_PX:
                flow = flow * (MAX_SMEAR_PX / length)
                length = MAX_SMEAR_PX
            hull = np.vstack([a, b])
            roi = self._roi(hull, length + 2 * FEATHER_PX + 2)
            if roi is None:
                continue
            x0, y0, x1, y1 = roi
            patch = sharp[y0:y1, x0:x1]
            blurred = cv2.filter2D(patch, -1, line_kernel(flow), borderType=cv2.BORDER_REPLICATE)
            mask = np.zeros(patch.shape[:2], dtype=np.uint8)
            poly = cv2.convexHull((hull - (x0, y0)).astype(np.float32)).astype(np.int32)
            cv2.fillConvexPoly(mask, poly, 255)
            mask = cv2.dilate(mask, np.ones((3, 3), np.uint8), iterations=math.ceil(length / 2) + FEATHER_PX)
            alpha = cv2.GaussianBlur(mask.astype(np.float32) / 255.0, (0, 0), FEATHER_PX)[..., None]
            region = out[y0:y1, x0:x1].astype(np.float32)
            out[y0:y1, x0:x1] = np.clip(alpha * blurred + (1.0 - alpha) * region + 0.5, 0, 255).astype(np.uint8)

    def glare(self, image: np.ndarray, ex: Exposure) -> None:
        """Wash out, in place, the part of each glossy sheet that mirrors the light into the camera."""
        if ex.gloss <= 0:
            return
        L = np.asarray(ex.light_direction, dtype=np.float64)
        L = L / max(float(np.linalg.norm(L)), 1e-9)
        eye = ex.T_opt_mid[:3, 3]
        for quad in ex.quads:
            T = _midpoint(quad)
            n = T[:3, 2]
            if float(n @ (eye - T[:3, 3])) <= 0:
                continue  # the camera sees the sheet's back
            R = 2.0 * float(n @ L) * n - L  # the light's mirror direction off the print
            corners = self.project(quad.corners(T), ex.T_opt_mid)
            if corners is None:
                continue
            roi = self._roi(corners, 1)
            if roi is None:
                continue
            x0, y0, x1, y1 = roi
            u, v = np.meshgrid(np.arange(x0, x1, dtype=np.float64), np.arange(y0, y1, dtype=np.float64))
            rays = cv2.undistortPoints(
                np.column_stack([u.ravel(), v.ravel()]).reshape(-1, 1, 2), self.K, self.distortion
            ).reshape(-1, 2)
            d_opt = np.column_stack([rays, np.ones(len(rays))])
            d_map = d_opt @ ex.T_opt_mid[:3, :3].T  # each pixel's ray in the map frame
            denom = d_map @ n
            with np.errstate(divide="ignore", invalid="ignore"):
                s = ((T[:3, 3] - eye) @ n) / denom
            points = eye + d_map * s[:, None]
            view = eye - points
            view /= np.maximum(np.linalg.norm(view, axis=1, keepdims=True), 1e-9)
            lobe = np.clip(view @ R, 0.0, 1.0) ** GLOSS_SHININESS
            add = (ex.gloss * 255.0 * lobe).reshape(y1 - y0, x1 - x0)
            mask = np.zeros(add.shape, dtype=np.uint8)
            cv2.fillConvexPoly(mask, (corners - (x0, y0)).round().astype(np.int32), 1)
            add = np.where((mask > 0) & np.isfinite(add) & (s.reshape(add.shape) > 0), add, 0.0)
            patch = image[y0:y1, x0:x1].astype(np.float32) + add[..., None]
            image[y0:y1, x0:x1] = np.clip(patch + 0.5, 0, 255).astype(np.uint8)


def _midpoint(quad: PrintedQuad) -> np.ndarray:
    """The sheet's pose at mid-exposure (the frame's stamp): positions averaged, the start's rotation kept."""
    T = quad.T_start.copy()
    T[:3, 3] = (quad.T_start[:3, 3] + quad.T_end[:3, 3]) / 2.0
    return T


def line_kernel(flow: np.ndarray) -> np.ndarray:
    """A kernel that averages the image along the segment `flow` (px), centred: a uniform smear in any
    direction, with sub-pixel ends (samples splatted bilinearly)."""
    length = float(np.hypot(*flow))
    r = math.ceil(length / 2.0) + 1
    k = np.zeros((2 * r + 1, 2 * r + 1), dtype=np.float32)
    n = max(2, math.ceil(length * 4))
    for s in np.linspace(-0.5, 0.5, n):
        x, y = r + s * flow[0], r + s * flow[1]
        ix, iy = math.floor(x), math.floor(y)
        fx, fy = x - ix, y - iy
        k[iy, ix] += (1 - fx) * (1 - fy)
        k[iy, ix + 1] += fx * (1 - fy)
        k[iy + 1, ix] += (1 - fx) * fy
        k[iy + 1, ix + 1] += fx * fy
    return k / k.sum()
