"""Rendered test scenes for the perception benchmarks: 0, 1 or 8 markers with known poses at any resolution.

Built on tools.synthetic_views (exact homography, anti-aliased, blur + sensor noise), so
every frame comes with its ground truth. Several markers are composited by rendering one after the
other onto the previous image (noise and blur applied once, at the end).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from mission.core import se3
from mission.core.types import CameraIntrinsics
from tools import synthetic_views as sv

ARUCO_DICT = cv2.aruco.DICT_4X4_250
APRILTAG_DICT = cv2.aruco.DICT_APRILTAG_36h11


@dataclass
class Scene:
    image: np.ndarray  # H×W×3 BGR uint8
    intrinsics: CameraIntrinsics
    truths: list[sv.SyntheticView]  # one per marker (their images are intermediate; use `image`)

    @property
    def n_markers(self) -> int:
        return len(self.truths)


def _grid_poses(n: int, k: CameraIntrinsics, size: float, rng: np.random.Generator) -> list[np.ndarray]:
    """`n` (≤ 8) marker poses on a 4×2 grid 1.5 m ahead, each tilted up to 25° — all inside the image."""
    z = 1.5
    half_w = (k.width / 2 - 40) / k.fx * z
    half_h = (k.height / 2 - 40) / k.fy * z
    xs = np.linspace(-half_w * 0.8, half_w * 0.8, 4)
    ys = (-half_h * 0.5, half_h * 0.5)
    poses = []
    for i in range(n):
        pos = np.array([xs[i % 4], ys[i // 4], z])
        poses.append(
            sv.pose_facing_camera(
                pos, rng.uniform(0, 2 * math.pi), math.radians(rng.uniform(0, 25)), rng.uniform(-0.4, 0.4)
            )
        )
    return poses


def render_scene(
    width: int, height: int, n_markers: int, dictionary: int, rng: np.random.Generator, size_m: float = 0.12
) -> Scene:
    """A frame with `n_markers` (0, 1 or up to 8) markers of `dictionary`, ids 0…n−1 (1 marker: id 7)."""
    k = sv.default_intrinsics(width, height)
    if n_markers == 0:
        far = se3.transform(sv.R_FRONTAL, (50.0, 0.0, 2.0))  # outside the field of view: background only
        v = sv.render_marker_view(far, marker_size_m=size_m, dictionary=dictionary, intrinsics=k, rng=rng)
        return Scene(v.image, k, [])
    if n_markers == 1:
        t = sv.random_pose(1.5, 30.0, rng, k, size_m)
        v = sv.render_marker_view(t, marker_id=7, marker_size_m=size_m, dictionary=dictionary, intrinsics=k, rng=rng)
        return Scene(v.image, k, [v])
    poses = _grid_poses(n_markers, k, size_m, rng)
    truths = sv.render_markers_view(
        list(enumerate(poses)), marker_size_m=size_m, intrinsics=k, rng=rng, dictionary=dictionary
    )
    return Scene(truths[-1].image, k, truths)
