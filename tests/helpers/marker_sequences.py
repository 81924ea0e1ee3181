"""Rendered marker sequences for the ArUco tests: what a turning robot's camera sees, with exact truth."""

from __future__ import annotations

from collections.abc import Iterator

import cv2
import numpy as np

from mission.core import se3
from tools import synthetic_views as sv

K = sv.default_intrinsics(1280, 720)  # fx ≈ 869 px: a 0.15 m marker 1.5 m ahead is ~87 px wide


def sliding(
    n: int,
    *,
    ids: tuple[int, ...] = (7,),
    step_px: float = 6.0,
    appear_at: dict[int, int] | None = None,
    dictionary: int = cv2.aruco.DICT_4X4_250,
    distance_m: float = 1.5,
    turned_deg: float = 0.0,
) -> Iterator[tuple[np.ndarray, dict[int, np.ndarray]]]:
    """`n` frames (1280×720) of 0.15 m markers 1.5 m ahead sliding sideways `step_px` a frame (a turning robot's
    view); a marker in `appear_at` comes into the picture at that frame. At another `distance_m` the picture is the
    same, scaled. Markers `turned_deg` about the vertical are seen obliquely (narrow across, full height).
    Yields (image, {id: true corners})."""
    turned = se3.rot_y(np.radians(turned_deg)) @ sv.R_FRONTAL
    rng = np.random.default_rng(3)
    appear_at = appear_at or {}
    for i in range(n):
        shown = [m for m in ids if appear_at.get(m, 0) <= i]
        placements = [
            (
                m,
                se3.transform(
                    turned,
                    (
                        ((-0.6 + 0.5 * j) + i * step_px * 1.5 / K.fx) * distance_m / 1.5,
                        (0.1 * j - 0.1) * distance_m / 1.5,
                        distance_m,
                    ),
                ),
            )
            for j, m in enumerate(shown)
        ]
        views = sv.render_markers_view(placements, marker_size_m=0.15, intrinsics=K, rng=rng, dictionary=dictionary)
        yield views[-1].image, {v.marker_id: v.corners for v in views}
