"""A printed marker over one exposure (sim/marker_optics.py, issue 33): it smears by its own motion in the
picture, and a glossy print mirrors the light into the camera where the geometry says it must."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest

from mission.core import se3
from mission.sim.camera_model import CameraModel
from mission.sim.marker_optics import Exposure, MarkerOptics, PrintedQuad, line_kernel
from mission.sim.scenario import CameraSpec, load_scenario
from mission.sim.scene import intrinsics_for
from mission.sim.sim_adapter import SimAdapter

SIDE = 0.30
FACING_CAMERA = np.diag([1.0, -1.0, -1.0])  # the sheet's normal (its z) points back along the optical axis


def camera() -> CameraModel:
    cam = CameraSpec(exposure_s=0.03)
    return CameraModel(cam, intrinsics_for(cam, "tiny"), seed=0, render_k=lambda spec: intrinsics_for(spec, "tiny"))


def sheet_at(x: float, z: float) -> np.ndarray:
    return se3.transform(FACING_CAMERA, (x, 0.0, z))


def exposure(quad: PrintedQuad, light=(0.0, 0.0, 1.0), gloss: float = 0.0) -> Exposure:
    still = np.eye(4)  # the camera at the origin, looking along +z (the optical frame is the map frame here)
    return Exposure(still, still, still, [quad], light, gloss)


def picture_of(optics: MarkerOptics, quad: PrintedQuad) -> np.ndarray:
    """Grey background, the sheet drawn black where it was at mid-exposure (a sharp render)."""
    img = np.full((480, 640, 3), 128, np.uint8)
    mid = (quad.T_start[:3, 3] + quad.T_end[:3, 3]) / 2
    corners = optics.project(quad.corners(se3.transform(FACING_CAMERA, mid)), np.eye(4))
    cv2.fillConvexPoly(img, corners.round().astype(np.int32), (0, 0, 0))
    return img


def edge_width(row: np.ndarray) -> float:
    """Width of a blurred step edge: a uniform smear of L px makes the edge's derivative a box of width L,
    whose variance is L² / 12."""
    d = np.abs(np.diff(row.astype(float)))
    x = np.arange(len(d))
    mean = (d * x).sum() / d.sum()
    return math.sqrt(12.0 * (d * (x - mean) ** 2).sum() / d.sum())


def test_a_target_crossing_the_view_is_smeared_by_speed_times_exposure_times_focal_over_range():
    model = camera()
    speed, exposure_s, z = 1.5, 0.03, 1.5
    half = speed * exposure_s / 2
    quad = PrintedQuad(SIDE, sheet_at(-half, z), sheet_at(half, z))
    sharp = picture_of(model.optics, quad)
    out = sharp.copy()
    model.optics.smear(sharp, out, exposure(quad), rotation_px=0.0)
    expected = speed * exposure_s * model.true_k.fx / z  # ≈ 12.5 px
    left_edge = out[240, 200:300, 0]
    assert edge_width(left_edge) == pytest.approx(expected, abs=1.0)
    assert edge_width(sharp[240, 200:300, 0]) < 1.0  # it was a sharp edge
    assert np.array_equal(out[:, :150], sharp[:, :150])  # the wall beside it does not move: not smeared


def test_a_marker_standing_still_before_a_still_camera_is_not_smeared():
    model = camera()
    quad = PrintedQuad(SIDE, sheet_at(0.0, 1.5), sheet_at(0.0, 1.5))
    sharp = picture_of(model.optics, quad)
    out = sharp.copy()
    model.optics.smear(sharp, out, exposure(quad), rotation_px=0.0)
    assert np.array_equal(out, sharp)


def test_the_smear_kernel_has_the_motions_length_in_any_direction():
    for flow in ((10.0, 0.0), (0.0, 6.5), (7.0, 7.0)):
        k = line_kernel(np.array(flow))
        assert k.sum() == pytest.approx(1.0)
        ys, xs = np.mgrid[: k.shape[0], : k.shape[1]]
        c = (k.shape[0] - 1) / 2
        along = ((xs - c) * flow[0] + (ys - c) * flow[1]) / math.hypot(*flow)
        spread = math.sqrt(12 * (k * along**2).sum())
        assert spread == pytest.approx(math.hypot(*flow), rel=0.1)


def test_a_glossy_print_lit_from_behind_the_camera_is_washed_out_at_the_mirror_point():
    model = camera()
    quad = PrintedQuad(SIDE, sheet_at(0.0, 1.5), sheet_at(0.0, 1.5))
    sharp = picture_of(model.optics, quad)
    lit = sharp.copy()
    model.optics.glare(lit, exposure(quad, light=(0.0, 0.0, -1.0), gloss=0.8))  # the light behind the camera
    added = lit[..., 0].astype(int) - sharp[..., 0].astype(int)
    ys, xs = np.mgrid[: added.shape[0], : added.shape[1]]
    u, v = (added * xs).sum() / added.sum(), (added * ys).sum() / added.sum()
    k = model.true_k
    # the mirror point is the foot of the camera's perpendicular on the sheet: the image centre
    assert (u, v) == (pytest.approx(k.cx, abs=1.0), pytest.approx(k.cy, abs=1.0))
    assert added.max() == pytest.approx(0.8 * 255, abs=2)
    assert np.count_nonzero(added > 128) > 20  # a patch, not a pixel: cells under it are unreadable
    corners = model.optics.project(quad.corners(quad.T_start), np.eye(4))
    assert added[:, : math.floor(corners[:, 0].min()) - 1].max() == 0  # only the print shines, not the wall


def test_a_lamp_overhead_never_mirrors_into_a_camera_at_the_markers_height():
    model = camera()
    quad = PrintedQuad(SIDE, sheet_at(0.1, 1.5), sheet_at(0.1, 1.5))
    sharp = picture_of(model.optics, quad)
    lit = sharp.copy()
    model.optics.glare(lit, exposure(quad, light=(0.0, -1.0, 0.0), gloss=1.0))  # above (optical y is down)
    assert int(np.abs(lit.astype(int) - sharp.astype(int)).max()) <= 1


def test_the_simulation_moves_the_targets_marker_by_its_velocity_over_the_exposure():
    scenario = load_scenario("follow_open")
    scenario = scenario.model_copy(update={"camera": scenario.camera.model_copy(update={"exposure_s": 0.03})})
    sim = SimAdapter(scenario, seed=0)
    sim.setup()
    try:
        for _ in range(100):  # 5 s: past the target's start delay
            sim.advance(0.05)
        ex = sim._exposure(sim.T_map_optical())
        assert ex is not None and len(ex.quads) == len(scenario.target.markers)
        vx, vy, _ = sim._target_velocity
        moved = ex.quads[0].T_end[:3, 3] - ex.quads[0].T_start[:3, 3]
        assert math.hypot(vx, vy) > 0.1  # the target walks
        assert moved[:2] == pytest.approx(np.array([vx, vy]) * 0.03, abs=1e-3)
    finally:
        sim.close()


def test_a_sheet_beside_the_camera_is_left_alone_not_projected_through_the_lens_polynomial():
    cam = CameraSpec(exposure_s=0.03, distortion=(-0.3, 0.08, 0.0, 0.0, 0.0))
    model = CameraModel(cam, intrinsics_for(cam, "tiny"), seed=0, render_k=lambda spec: intrinsics_for(spec, "tiny"))
    beside = PrintedQuad(SIDE, sheet_at(1.0, 0.2), sheet_at(1.3, 0.2))  # 79° off the axis, moving fast
    image = np.full((480, 640, 3), 128, np.uint8)
    out = image.copy()
    model.optics.smear(image, out, exposure(beside), rotation_px=0.0)
    model.optics.glare(out, exposure(beside, light=(0.0, 0.0, -1.0), gloss=1.0))
    assert np.array_equal(out, image)
