"""A real camera on the simulation's ideal pinhole (sim/camera_model.py, issue 33): each effect asserted on the
picture or the numbers it must produce."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest

from mission.ros.conversions import intrinsics_to_camera_info
from mission.ros.messages import RclpyMessages
from mission.sim.camera_model import CameraModel, smear_kernel
from mission.sim.scenario import CameraSpec, load_scenario
from mission.sim.scene import intrinsics_for
from mission.sim.sim_adapter import SimAdapter

WIDE_LENS = (-0.30, 0.08, 0.0, 0.0, 0.0)  # a wide-angle webcam's barrel distortion


def model(**camera) -> CameraModel:
    cam = CameraSpec(**camera)
    return CameraModel(cam, intrinsics_for(cam, "tiny"), seed=0, render_k=lambda spec: intrinsics_for(spec, "tiny"))


def test_a_straight_edge_bends_by_the_distortion_models_amount():
    m = model(distortion=WIDE_LENS)
    rk = m.render_k
    ideal = np.zeros((480, 640, 3), np.uint8)
    u_line = 560  # a vertical edge near the right border of the ideal (wider) render
    ideal[:, u_line : u_line + 2] = 255
    out, _ = m.apply(ideal, None, yaw_rate=0.0)
    # where the lens puts that edge, row by row: OpenCV's plumb-bob projection of the same rays
    rows = np.linspace(-0.4, 0.4, 5) * rk.height + rk.cy
    rays = np.column_stack([(u_line + 0.5 - rk.cx) / rk.fx * np.ones_like(rows), (rows - rk.cy) / rk.fy])
    pts = np.column_stack([rays, np.ones(len(rays))])
    projected, _ = cv2.projectPoints(pts, np.zeros(3), np.zeros(3), m.K, m.distortion)
    seen = []
    for u, v in projected.reshape(-1, 2):
        if not 0 <= round(v) < 480:
            continue
        row = out[round(v), :, 0].astype(float)
        if row.sum() > 0:
            seen.append((float((row * np.arange(640)).sum() / row.sum()), u))
    assert len(seen) >= 3
    for measured, expected in seen:
        assert measured == pytest.approx(expected, abs=0.75)
    bend = max(u for _, u in seen) - min(u for _, u in seen)
    assert bend > 10  # the edge is visibly curved: a pinhole would keep it straight (0 px)


def test_the_wider_render_leaves_no_pixel_of_the_lens_image_without_a_source():
    m = model(distortion=WIDE_LENS)
    out, _ = m.apply(np.full((480, 640, 3), 200, np.uint8), None, 0.0)
    assert m.render_spec.vfov_deg > 60.0
    assert int(out.min()) == 200  # no black border


def test_a_blur_kernels_length_equals_rate_times_exposure_times_focal_length():
    m = model(exposure_s=0.02)
    dot = np.zeros((480, 640), np.uint8)
    dot[240, 320] = 255
    out, _ = m.apply(dot, None, yaw_rate=1.0)
    length = 1.0 * 0.02 * m.true_k.fx  # ≈ 8.3 px for the 640×480 60° camera
    lit = np.nonzero(out[240])[0]
    assert lit.max() - lit.min() == math.ceil(length)  # a point smeared over `length` covers ceil(length)+1 px
    row = out[240].astype(float)
    # the render is the middle of the exposure: the smear is centred on where the point was then
    assert (row * np.arange(640)).sum() / row.sum() == pytest.approx(320, abs=0.6)
    assert smear_kernel(length).sum() == pytest.approx(1.0)
    still, _ = m.apply(dot, None, yaw_rate=0.0)
    assert np.array_equal(still, dot)  # standing still: no blur


def test_the_calibration_the_detector_is_told_is_off_by_a_seeded_error():
    told = [model(calibration_focal_pct=2.0, calibration_center_px=3.0).told for _ in range(2)]
    assert told[0] == told[1]  # the same seed, the same error
    true = model().true_k
    assert told[0].fx != true.fx and abs(told[0].fx / true.fx - 1) < 0.08
    assert abs(told[0].cx - true.cx) < 12
    assert model().told == true  # no error asked: the truth


def test_an_uncorrected_lens_is_told_to_the_detector_as_a_pinhole():
    calibrated = model(distortion=WIDE_LENS)
    uncorrected = model(distortion=WIDE_LENS, lens_calibrated=False)
    assert calibrated.told.distortion == WIDE_LENS
    assert uncorrected.told.distortion == ()  # what a driver publishes when nobody calibrated the lens
    image = np.full((480, 640, 3), 90, np.uint8)
    image[200:280, 300:340] = 255
    assert np.array_equal(calibrated.apply(image, None, 0.0)[0], uncorrected.apply(image, None, 0.0)[0])  # same lens


def test_a_simulated_frame_carries_the_lens_in_its_calibration_and_camera_info():
    scenario = load_scenario("explore_dock")
    scenario = scenario.model_copy(update={"camera": scenario.camera.model_copy(update={"distortion": WIDE_LENS})})
    sim = SimAdapter(scenario, seed=0)
    sim.setup()
    try:
        frame = sim.capture()
        assert frame.intrinsics.distortion == WIDE_LENS
        info = intrinsics_to_camera_info(RclpyMessages(), frame.intrinsics, frame.stamp, frame.frame_id)
        assert info.distortion_model == "plumb_bob" and tuple(info.d) == pytest.approx(WIDE_LENS)
    finally:
        sim.close()


def test_stereo_depth_noise_grows_with_the_square_of_the_distance():
    m = model(depth=True, depth_noise_pct_at_2m=2.0)
    near = m.depth_errors(np.full((200, 200), 2.0, np.float32))
    far = m.depth_errors(np.full((200, 200), 4.0, np.float32))
    assert float(np.std(near)) == pytest.approx(0.04, rel=0.05)  # 2 % of 2 m
    assert float(np.std(far)) == pytest.approx(0.16, rel=0.05)  # four times that at twice the range
    assert float(np.mean(far)) == pytest.approx(4.0, abs=0.005)  # unbiased


def test_depth_has_holes_where_the_scene_jumps():
    m = model(depth=True, depth_edge_holes_m=0.3)
    z = np.full((40, 40), 3.0, np.float32)
    z[:, 20:] = 1.5  # a box edge in front of the wall
    out = m.depth_errors(z)
    assert np.isnan(out[:, 19:21]).all()  # both sides of the edge
    assert not np.isnan(out[:, :19]).any() and not np.isnan(out[:, 21:]).any()


def test_a_frame_arrives_latency_after_its_exposure_with_the_exposures_stamp():
    scenario = load_scenario("explore_dock")
    scenario = scenario.model_copy(update={"camera": scenario.camera.model_copy(update={"latency_s": 0.08})})
    sim = SimAdapter(scenario, seed=0)
    sim.setup()
    from mission.core import blackboard as bbk

    bb = bbk.writer("latency")
    delivered = []
    try:
        seq = 0
        while sim.t < 1.0:
            sim.sense(bb)
            if bbk.get(bb, bbk.FRAME_SEQ, 0) != seq:
                seq = bbk.get(bb, bbk.FRAME_SEQ)
                delivered.append((sim.t, bbk.get(bb, bbk.FRAME).stamp))
            sim.advance(1.0 / 30.0)
    finally:
        sim.close()
    ages = [t - stamp for t, stamp in delivered]
    assert len(delivered) >= 12  # 15 Hz for a second, the first ones still in flight
    assert all(0.08 - 1e-6 <= age < 0.08 + 1.0 / 30.0 + 1e-6 for age in ages), ages


def test_a_dim_scene_is_lifted_by_gain_and_its_noise_with_it():
    m = model(scene_brightness=0.25)
    grey = np.full((10, 10), 100, np.uint8)
    out = m.expose(grey, m.light_level(0.0, (0.4, -0.3, 1.0)), t=0.0)
    assert int(out[0, 0]) == 100  # the auto-exposure brings the picture back to its level…
    assert m.gain == pytest.approx(4.0)  # …with a gain of 4, which multiplies the sensor noise (sim_adapter)


def test_turning_toward_the_light_over_exposes_until_the_auto_exposure_catches_up():
    m = model(light_variation=0.4, auto_exposure_s=0.5)
    light = (1.0, 0.0, 1.0)  # the light is toward +x
    grey = np.full((4, 4), 100, np.uint8)
    away = m.expose(grey, m.light_level(math.pi, light), t=0.0)  # facing away: adapted, mid-grey
    assert int(away[0, 0]) == 100
    toward = m.light_level(0.0, light)
    first = int(m.expose(grey, toward, t=0.1)[0, 0])  # turned toward it: the gain is still the old one
    later = int(m.expose(grey, toward, t=3.0)[0, 0])
    assert first > 150 and later == pytest.approx(100, abs=2)


def test_jpeg_at_low_quality_changes_the_picture_as_a_compressed_topic_would():
    m = model(jpeg_quality=20)
    img = np.random.default_rng(0).integers(0, 255, (64, 64, 3), dtype=np.uint8)
    out = m.compress(img)
    assert out.shape == img.shape and not np.array_equal(out, img)
    assert np.array_equal(model().compress(img), img)  # 0: raw
