"""Rendered marker sequences for the tracking benchmark: a camera panning across markers, with exact truth.

The camera turns on the spot at a constant rate (a robot's search turn, ~0.3 rad/s at 30 Hz) in front of
markers standing 1–3 m away on an arc, so markers come into view at one side, cross the image and leave at
the other: what a tracker must follow, and what its full-frame passes must pick up. Every frame is rendered
by tools.synthetic_views (exact homographies, defocus and sensor noise), each marker's true corners kept.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from mission.core import se3
from mission.core.types import CameraIntrinsics
from tools import synthetic_views as sv

MARKER_SIZE_M = 0.15
PAN_RAD_PER_FRAME = 0.01  # 0.3 rad/s at 30 Hz


@dataclass
class SequenceFrame:
    """One frame: the BGR image and each visible marker's true corners (id → 4×2 px)."""

    image: np.ndarray
    truth: dict[int, np.ndarray]


def _in_view(corners: np.ndarray, k: CameraIntrinsics, margin_px: float = 2.0) -> bool:
    return bool(
        (corners[:, 0] >= margin_px).all()
        and (corners[:, 0] <= k.width - 1 - margin_px).all()
        and (corners[:, 1] >= margin_px).all()
        and (corners[:, 1] <= k.height - 1 - margin_px).all()
    )


def _quiet_box(corners: np.ndarray) -> tuple[float, float, float, float]:
    """The marker's bounding box grown by its quiet zone and then some (half a side)."""
    lo, hi = corners.min(axis=0), corners.max(axis=0)
    grow = 0.5 * float(np.max(hi - lo))
    return (lo[0] - grow, lo[1] - grow, hi[0] + grow, hi[1] + grow)


def _overlap(a: tuple[float, float, float, float], b: tuple[float, float, float, float]) -> bool:
    return a[0] < b[2] and b[0] < a[2] and a[1] < b[3] and b[1] < a[3]


def panning_sequence(
    width: int, height: int, n_frames: int, n_markers: int, *, dictionary: int, seed: int = 0
) -> tuple[CameraIntrinsics, list[SequenceFrame]]:
    """`n_frames` of a camera (`width`×`height`, 45° vertical field of view) panning across `n_markers` markers
    of `dictionary` (ids 1…n), spread over the pan so they enter and leave the view at different frames."""
    rng = np.random.default_rng(seed)
    k = sv.default_intrinsics(width, height)
    hfov = 2 * math.atan(width / (2 * k.fx))
    pan_total = PAN_RAD_PER_FRAME * n_frames
    # Markers at bearings spread over what the pan sweeps past, each facing the camera, 1–3 m away.
    bearings = np.linspace(-hfov / 2, pan_total + hfov / 2, n_markers + 2)[1:-1] if n_markers > 1 else [pan_total / 2]
    markers = []
    for i, bearing in enumerate(bearings):
        d = rng.uniform(1.0, 3.0)
        # world: x right, z ahead at pan 0 (the camera's optical frame at frame 0), y down
        position = np.array([d * math.sin(bearing), rng.uniform(-0.2, 0.2) * d, d * math.cos(bearing)])
        markers.append((i + 1, se3.transform(se3.rot_y(bearing) @ sv.R_FRONTAL, position)))  # facing the camera
    frames: list[SequenceFrame] = []
    for f in range(n_frames):
        T_cam_world = np.linalg.inv(se3.transform(se3.rot_y(PAN_RAD_PER_FRAME * f)))
        placements, boxes = [], []
        for marker_id, T_world_marker in sorted(markers, key=lambda m: m[1][2, 3]):  # nearest first
            T = T_cam_world @ T_world_marker
            corners = k.project(se3.apply(T, sv.marker_corners_3d(MARKER_SIZE_M)))
            box = _quiet_box(corners)
            if T[2, 3] > 0.3 and _in_view(corners, k) and not any(_overlap(box, b) for b in boxes):
                placements.append((marker_id, T))  # a marker another hides is not in this frame's truth
                boxes.append(box)
        if placements:
            views = sv.render_markers_view(
                placements, marker_size_m=MARKER_SIZE_M, intrinsics=k, rng=rng, dictionary=dictionary
            )
            frames.append(SequenceFrame(views[-1].image, {v.marker_id: v.corners for v in views}))
        else:
            frames.append(SequenceFrame(_background(k, rng), {}))
    return k, frames


def _background(k: CameraIntrinsics, rng: np.random.Generator) -> np.ndarray:
    grey = np.clip(rng.normal(128, 30, size=(k.height, k.width)), 0, 255).astype(np.uint8)
    return cv2.cvtColor(cv2.GaussianBlur(grey, (0, 0), 3.0), cv2.COLOR_GRAY2BGR)
