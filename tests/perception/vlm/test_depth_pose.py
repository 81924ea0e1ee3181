"""From a pixel to a 6-DoF pose with depth: back-projection, MAD + SVD plane (z axis), edges + PCA (x axis)."""

from __future__ import annotations

import math

import cv2
import numpy as np

from mission.core import se3
from mission.core.types import CameraIntrinsics
from mission.perception_plugins.vlm.depth_pose import (
    dominant_edge_angle,
    estimate_surface_pose,
    fit_plane_svd,
    mad_inliers,
)
from tests.helpers.vlm_scene import Box, Scene, box_front_face, camera_pose, render

RED = (30, 30, 200)


def angle_deg(a: np.ndarray, b: np.ndarray) -> float:
    return math.degrees(math.acos(np.clip(abs(float(a @ b)) / np.linalg.norm(a) / np.linalg.norm(b), -1, 1)))


def test_mad_rejects_depths_more_than_2_5_mads_from_the_median():
    # median 2.0, |dev| = [0, .01, .01, .02, .02, 1.0, 3.0] → MAD 0.02 → keep |dev| ≤ 0.05
    z = np.array([2.0, 2.01, 1.99, 2.02, 1.98, 3.0, 5.0])
    assert mad_inliers(z, 2.5).tolist() == [True, True, True, True, True, False, False]


def test_svd_plane_of_points_on_a_known_plane():
    rng = np.random.default_rng(0)
    normal = np.array([0.2, -0.3, 1.0]) / np.linalg.norm([0.2, -0.3, 1.0])
    a = np.cross(normal, [1, 0, 0])
    a /= np.linalg.norm(a)
    b = np.cross(normal, a)
    pts = np.array([0.1, 0.2, 2.0]) + rng.uniform(-0.1, 0.1, (50, 1)) * a + rng.uniform(-0.1, 0.1, (50, 1)) * b
    centroid, n, rms = fit_plane_svd(pts)
    assert angle_deg(n, normal) < 1e-6
    assert rms < 1e-9
    assert np.allclose(centroid, pts.mean(axis=0))


def test_the_face_normal_of_a_turned_box_is_its_z_axis_pointing_at_the_camera():
    box = Box((2.5, 0.0, 0.25), (0.3, 0.3, 0.5), RED, yaw=0.5)
    cam = camera_pose(0.0, 0.0, 0.0)
    frame = render(Scene([box]), cam)
    face = box_front_face(box)
    u, v = frame.intrinsics.project(se3.apply(se3.invert(cam), face[:3, 3]))[0]
    pose = estimate_surface_pose(frame.image, frame.depth, frame.intrinsics, u, v)
    assert pose is not None
    assert pose.plane_used and pose.sigma_m < 1e-3  # a clean plane is fitted and trusted to the millimetre
    t_map = cam @ pose.T_camera_target
    assert angle_deg(t_map[:3, 2], face[:3, 2]) < 1.0
    assert np.linalg.norm(t_map[:3, 3] - face[:3, 3]) < 0.01
    assert float(pose.T_camera_target[:3, 2] @ pose.T_camera_target[:3, 3]) < 0  # z faces the camera
    r = pose.T_camera_target[:3, :3]
    assert np.allclose(r.T @ r, np.eye(3), atol=1e-9) and np.isclose(np.linalg.det(r), 1.0)


def test_mad_keeps_the_background_out_of_the_plane_of_a_small_target():
    # A thin 20 cm panel 2 m in front of a wall: the depth patch (radius 0.12 m) spills onto the wall.
    box = Box((2.0, 0.0, 0.3), (0.02, 0.2, 0.2), RED, yaw=0.4)
    cam = camera_pose(0.0, 0.0, 0.0)
    frame = render(Scene([box], wall_x=4.0, floor=False), cam)
    face = box_front_face(box)
    u, v = frame.intrinsics.project(se3.apply(se3.invert(cam), face[:3, 3]))[0]
    kept = estimate_surface_pose(frame.image, frame.depth, frame.intrinsics, u, v, patch_radius_m=0.12)
    naive = estimate_surface_pose(frame.image, frame.depth, frame.intrinsics, u, v, patch_radius_m=0.12, mad_k=1e6)
    assert kept is not None and naive is not None
    assert kept.outliers > 0 and naive.outliers == 0
    assert angle_deg((cam @ kept.T_camera_target)[:3, 2], face[:3, 2]) < 2.0
    assert angle_deg((cam @ naive.T_camera_target)[:3, 2], face[:3, 2]) > 10.0


def test_the_dominant_edge_of_a_stripe_pattern_is_found_by_pca():
    img = np.full((101, 101), 255, np.uint8)
    for k in range(-5, 6):  # stripes at 25° in the image
        c, s = math.cos(math.radians(25)), math.sin(math.radians(25))
        p0 = (50 + k * 10 * -s - 80 * c, 50 + k * 10 * c - 80 * s)
        p1 = (50 + k * 10 * -s + 80 * c, 50 + k * 10 * c + 80 * s)
        cv2.line(img, (round(p0[0]), round(p0[1])), (round(p1[0]), round(p1[1])), 0, 3)
    angle, anisotropy, n = dominant_edge_angle(img)
    assert n > 100 and anisotropy > 0.5
    assert abs(math.degrees(se3.wrap_angle(2 * (angle - math.radians(25)))) / 2) < 2.0


def test_a_square_patterns_in_plane_rotation_is_known_modulo_90_degrees():
    # A fronto-parallel surface 2 m away with a black square turned 20° (balanced edges: 4-fold mean).
    intr = CameraIntrinsics(fx=400.0, fy=400.0, cx=160.0, cy=120.0, width=320, height=240)
    img = np.full((240, 320, 3), 255, np.uint8)
    square = cv2.boxPoints(((160.0, 120.0), (60.0, 60.0), 20.0))
    cv2.fillPoly(img, [np.round(square).astype(np.int32)], (0, 0, 0))
    depth = np.full((240, 320), 2.0, np.float32)
    pose = estimate_surface_pose(img, depth, intr, 160.0, 120.0, patch_radius_m=0.2)
    assert pose is not None and pose.edge_pixels > 50
    x_axis = pose.T_camera_target[:3, 0]
    in_plane = math.degrees(math.atan2(x_axis[1], x_axis[0]))  # image angle (v down) of the target x axis
    assert abs(in_plane - 20.0) < 2.0  # of the four candidates, the one pointing most to the image's right
    assert np.allclose(pose.T_camera_target[:3, 2], [0, 0, -1], atol=1e-6)
    assert np.allclose(pose.T_camera_target[:3, 3], [0, 0, 2.0], atol=1e-6)


def test_missing_depth_at_the_pixel_gives_no_pose():
    intr = CameraIntrinsics.fallback(64, 48)
    img = np.zeros((48, 64, 3), np.uint8)
    depth = np.zeros((48, 64), np.float32)
    assert estimate_surface_pose(img, depth, intr, 30, 20) is None


def test_the_models_box_bounds_the_depth_patch_so_the_plane_is_the_objects():
    # A small panel in front of a near wall, a patch (radius 0.3 m) mostly on the wall: MAD alone keeps the
    # wall (the majority); the box the model drew around the panel keeps the plane on the panel.
    box = Box((2.0, 0.0, 0.3), (0.02, 0.16, 0.16), RED, yaw=0.4)
    cam = camera_pose(0.0, 0.0, 0.0)
    frame = render(Scene([box], wall_x=2.3, floor=False), cam)
    face = box_front_face(box)
    u, v = frame.intrinsics.project(se3.apply(se3.invert(cam), face[:3, 3]))[0]
    red = (frame.image[:, :, 2] > 120) & (frame.image[:, :, 0] < 90)
    vs, us = np.nonzero(red)
    drawn = (float(us.min()), float(vs.min()), float(us.max()), float(vs.max()))
    loose = estimate_surface_pose(frame.image, frame.depth, frame.intrinsics, u, v, patch_radius_m=0.3)
    bounded = estimate_surface_pose(frame.image, frame.depth, frame.intrinsics, u, v, patch_radius_m=0.3, box=drawn)
    assert loose is not None and bounded is not None
    assert angle_deg((cam @ bounded.T_camera_target)[:3, 2], face[:3, 2]) < 3.0
    assert angle_deg((cam @ loose.T_camera_target)[:3, 2], face[:3, 2]) > 10.0


def _stereo_noise(z: np.ndarray, pct_at_2m: float, rng: np.random.Generator) -> np.ndarray:
    """A stereo camera's depth: σ = pct % of 2 m at 2 m, growing with distance squared."""
    return (z + rng.standard_normal(z.shape) * (pct_at_2m / 100.0) * 2.0 * (z / 2.0) ** 2).astype(np.float32)


def test_a_far_answer_on_noisy_stereo_depth_averages_the_noise_and_says_how_far_to_trust_it():
    # A wall 5.8 m away seen by a common stereo camera (2 % at 2 m: σ ≈ 34 cm per pixel there). The few
    # pixels of a 5 cm patch are centimetres wide; fitted as a plane, the noise tilts it along the rays and
    # the answer lands anywhere along a metre. Averaged, thirty answers stay within a few centimetres.
    intr = CameraIntrinsics(fx=277.0, fy=277.0, cx=160.0, cy=120.0, width=320, height=240)
    img = np.full((240, 320, 3), 90, np.uint8)
    rng = np.random.default_rng(7)
    ranges, sigmas = [], []
    for _ in range(30):
        depth = _stereo_noise(np.full((240, 320), 5.8), 2.0, rng)
        pose = estimate_surface_pose(img, depth, intr, 180.0, 110.0)
        assert pose is not None
        ranges.append(float(pose.T_camera_target[2, 3]))
        sigmas.append(pose.sigma_m)
    assert abs(np.mean(ranges) - 5.8) < 0.05
    assert np.std(ranges) < 0.08
    assert 0.5 < np.std(ranges) / np.mean(sigmas) < 2.0  # the standard error it reports is the one it has


def test_an_answer_near_the_edge_of_a_distorted_lens_is_placed_through_the_lens():
    # A barrel lens (k1 = -0.3): the pixel 120 px right of the centre looks farther out than a pinhole says.
    dist = (-0.3, 0.08, 0.0, 0.0, 0.0)
    intr = CameraIntrinsics(fx=277.0, fy=277.0, cx=160.0, cy=120.0, width=320, height=240, distortion=dist)
    truth = np.array([[1.3, 0.2, 3.0]])
    pixels, _ = cv2.projectPoints(truth, np.zeros(3), np.zeros(3), intr.matrix, np.asarray(dist))
    u, v = pixels.reshape(2)
    depth = np.full((240, 320), 3.0, np.float32)
    pose = estimate_surface_pose(np.full((240, 320, 3), 90, np.uint8), depth, intr, float(u), float(v))
    assert pose is not None
    assert np.allclose(pose.T_camera_target[:3, 3], truth[0], atol=0.01)
    pinhole = CameraIntrinsics(fx=277.0, fy=277.0, cx=160.0, cy=120.0, width=320, height=240)
    naive = estimate_surface_pose(np.full((240, 320, 3), 90, np.uint8), depth, pinhole, float(u), float(v))
    assert naive is not None and abs(naive.T_camera_target[0, 3] - truth[0, 0]) > 0.05  # what it used to do
