"""Detections drawn on a camera image: marker outlines, pose axes and ids — for the live page and recordings.

One implementation, so the browser and a recorded GIF show exactly the same thing. Drawing never raises
on odd data (a detection without corners, no intrinsics, a pose behind the camera): it draws what it can.
"""

from __future__ import annotations

import contextlib
from collections.abc import Sequence

import cv2
import numpy as np

from mission.core import se3
from mission.core.types import CameraIntrinsics, Detection

OUTLINE_BGR = (80, 220, 60)  # green
CORNER0_BGR = (40, 40, 230)  # red dot on the first (top-left) corner: shows the marker's orientation
LABEL_BG_BGR = (30, 30, 30)


def as_bgr(image: np.ndarray) -> np.ndarray:
    """A 3-channel uint8 copy of a mono or BGR image."""
    img = np.asarray(image)
    if img.dtype != np.uint8:
        img = np.clip(img, 0, 255).astype(np.uint8)
    if img.ndim == 2:
        return cv2.cvtColor(img, cv2.COLOR_GRAY2BGR)
    if img.shape[2] == 4:
        return cv2.cvtColor(img, cv2.COLOR_BGRA2BGR)
    return img.copy()


def _label(det: Detection) -> str:
    who = f"id {det.marker_id}" if det.marker_id is not None else (det.label or det.source)
    if det.label and det.marker_id is not None:
        who += f" {det.label}"
    dist = det.distance
    return f"{who}  {dist:.2f} m" if np.isfinite(dist) and dist > 0 else who


def put_label(img: np.ndarray, text: str, org: tuple[int, int], scale: float = 0.5, colour=(255, 255, 255)) -> None:
    """White text on a dark box, readable on any background."""
    font = cv2.FONT_HERSHEY_SIMPLEX
    thick = max(1, round(scale * 2))
    (w, h), base = cv2.getTextSize(text, font, scale, thick)
    x = int(np.clip(org[0], 0, max(0, img.shape[1] - w - 4)))
    y = int(np.clip(org[1], h + 4, img.shape[0] - 2))
    cv2.rectangle(img, (x, y - h - 4), (x + w + 4, y + base - 1), LABEL_BG_BGR, -1)
    cv2.putText(img, text, (x + 2, y - 2), font, scale, colour, thick, cv2.LINE_AA)


def _axis_length(det: Detection, intr: CameraIntrinsics) -> float:
    """Half the marker's size, estimated from its outline in pixels and its distance (no size in Detection)."""
    if det.corners is None or len(det.corners) < 4:
        return 0.05
    c = np.asarray(det.corners, float)
    edge_px = float(np.mean(np.linalg.norm(c - np.roll(c, 1, axis=0), axis=1)))
    z = float(det.position[2])
    est = edge_px * z / intr.fx if intr.fx > 0 and z > 0 else 0.1
    return float(np.clip(0.5 * est, 0.01, 1.0))


def draw_detections(
    image: np.ndarray, detections: Sequence[Detection], intrinsics: CameraIntrinsics | None = None
) -> np.ndarray:
    """A BGR copy of `image` with every detection's outline, axes (when the camera is calibrated) and id."""
    img = as_bgr(image)
    scale = max(0.4, img.shape[1] / 1100.0)
    thick = max(1, round(img.shape[1] / 320))
    for det in detections:
        corners = None if det.corners is None else np.asarray(det.corners, float).reshape(-1, 2)
        if corners is not None and len(corners) >= 3 and np.all(np.isfinite(corners)):
            pts = np.round(corners).astype(np.int32)
            cv2.polylines(img, [pts], True, OUTLINE_BGR, thick, cv2.LINE_AA)
            cv2.circle(img, tuple(int(v) for v in pts[0]), thick + 2, CORNER0_BGR, -1, cv2.LINE_AA)
            anchor = (int(pts[:, 0].min()), int(pts[:, 1].min()) - 6)
        else:
            anchor = (8, 24)
        pos = np.asarray(det.position, float)
        if (
            intrinsics is not None
            and intrinsics.is_valid()
            and pos.shape == (3,)
            and np.all(np.isfinite(pos))
            and pos[2] > 0.01
        ):
            rvec = se3.matrix_to_rvec(se3.quat_to_matrix(det.orientation))
            with contextlib.suppress(cv2.error):  # a degenerate pose: the outline and label still show
                cv2.drawFrameAxes(
                    img, intrinsics.matrix, intrinsics.dist_coeffs, rvec, pos, _axis_length(det, intrinsics), thick
                )
        put_label(img, _label(det), anchor, scale)
    return img


def encode_jpeg(image: np.ndarray, quality: int = 80) -> bytes:
    """JPEG bytes of a BGR image (what the live page's camera endpoint serves)."""
    ok, buf = cv2.imencode(".jpg", image, [int(cv2.IMWRITE_JPEG_QUALITY), int(quality)])
    if not ok:
        raise ValueError("cv2.imencode failed")
    return buf.tobytes()
