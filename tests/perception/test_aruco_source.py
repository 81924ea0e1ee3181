"""The `aruco` source on rendered images with a known pose: detection, accuracy, flip choice, fallbacks."""

from __future__ import annotations

import json
import logging
import math

import cv2
import numpy as np
import pytest

from mission.core import se3
from mission.core.config import SourceConfig
from mission.core.errors import ConfigError
from mission.core.types import CameraIntrinsics, Frame
from mission.perception_plugins import registry
from mission.perception_plugins.aruco import ArucoSource
from mission.perception_plugins.marker_dictionaries import PREDEFINED
from mission.perception_plugins.square_pose import pixel_side
from tools import synthetic_views as sv

MARKER = 0.20  # the sim's target marker size


def _frame(view: sv.SyntheticView, stamp: float = 0.0, intrinsics: CameraIntrinsics | None = None) -> Frame:
    return Frame(image=view.image, stamp=stamp, intrinsics=intrinsics or view.intrinsics)


def _rot_err_deg(det, view: sv.SyntheticView) -> float:
    return math.degrees(se3.rotation_angle(se3.quat_to_matrix(det.orientation), view.rotation))


def _one_view(distance: float = 1.0, seed: int = 0, **kw) -> sv.SyntheticView:
    rng = np.random.default_rng(seed)
    size = kw.pop("marker_size_m", MARKER)
    return sv.render_marker_view(
        sv.random_pose(distance, 30, rng, marker_size_m=size), rng=rng, marker_size_m=size, **kw
    )


# --------------------------------------------------------------------------------------------------
# Acceptance (issue 2)
# --------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("distance", [0.5, 1.0, 2.0, 3.0])
def test_detects_99_percent_and_median_translation_error_within_1_percent(distance):
    """40 random views per range, ≤ 40° off axis, anywhere in a 640×480 image, blur 0.8 px, noise σ 3."""
    rng = np.random.default_rng(int(distance * 10))
    src = ArucoSource({"marker_size_m": MARKER})
    found, errors = 0, []
    n = 40
    for i in range(n):
        view = sv.render_marker_view(
            sv.random_pose(distance, 40, rng, marker_size_m=MARKER),
            rng=rng,
            marker_size_m=MARKER,
            blur_sigma=0.8,
            noise_sigma=3.0,
        )
        dets = [d for d in src.process(_frame(view, stamp=10.0 * i)) if d.marker_id == view.marker_id]
        if dets:
            found += 1
            errors.append(np.linalg.norm(dets[0].position - view.position) / view.distance)
    assert found / n >= 0.99
    assert float(np.median(errors)) <= 0.01


def _sequence_rotation_errors(
    source_params: dict, distance: float, n_seq: int, n_frames: int, seed: int, marker: float, blur: float, noise: float
) -> np.ndarray:
    rng = np.random.default_rng(seed)
    errs = []
    for _ in range(n_seq):
        views = sv.render_sequence(
            distance, 40, n_frames, rng, marker_size_m=marker, blur_sigma=blur, noise_sigma=noise
        )
        src = ArucoSource({"marker_size_m": marker, **source_params})
        for i, view in enumerate(views):
            dets = src.process(_frame(view, stamp=i / 30.0))
            errs.extend(_rot_err_deg(d, view) for d in dets if d.marker_id == view.marker_id)
    return np.asarray(errs)


@pytest.mark.parametrize("distance", [0.5, 1.0, 2.0, 3.0])
def test_over_short_sequences_p90_rotation_error_is_within_5_degrees(distance):
    errs = _sequence_rotation_errors(
        {}, distance, n_seq=5, n_frames=12, seed=100 + int(distance * 10), marker=MARKER, blur=0.8, noise=3.0
    )
    assert len(errs) >= 0.99 * 5 * 12
    assert float(np.percentile(errs, 90)) <= 5.0


def test_temporal_disambiguation_beats_the_naive_lowest_error_choice_where_the_pose_flips():
    """15 cm marker at 4 m, blur 1 px, noise σ 4: the regime where single-frame IPPE flips (FIELD_NOTES saw it
    from 2–3 m with OpenCV's sub-pixel corners; the fitted-edge corners push it out to ~3.5 m)."""
    kw = dict(distance=4.0, n_seq=12, n_frames=20, seed=7, marker=0.15, blur=1.0, noise=4.0)
    naive = _sequence_rotation_errors({"disambiguation": "naive"}, **kw)
    temporal = _sequence_rotation_errors({"disambiguation": "temporal"}, **kw)
    naive_flips, temporal_flips = np.mean(naive > 20.0), np.mean(temporal > 20.0)
    print(
        f"p90 naive {np.percentile(naive, 90):.1f}° temporal {np.percentile(temporal, 90):.1f}°; "
        f"flipped naive {naive_flips:.1%} temporal {temporal_flips:.1%}"
    )
    assert naive_flips >= 0.10  # the problem is real in this regime …
    assert temporal_flips <= 0.6 * naive_flips  # … and the temporal choice removes a good part of it
    assert np.percentile(temporal, 90) < 0.8 * np.percentile(naive, 90)


# --------------------------------------------------------------------------------------------------
# The detection contract
# --------------------------------------------------------------------------------------------------


def test_detection_carries_pose_corners_confidence_and_extra_in_the_documented_frames():
    view = _one_view(1.0, seed=3)
    [det] = ArucoSource({"marker_size_m": MARKER}).process(_frame(view, stamp=4.5))
    assert det.source == "aruco" and det.marker_id == 7 and det.stamp == 4.5
    assert np.allclose(det.corners, view.corners, atol=0.6)  # TL TR BR BL, like the truth
    assert np.linalg.norm(det.position - view.position) < 0.01
    assert _rot_err_deg(det, view) < 2.0  # marker z out of the face, camera optical frame
    assert 0.5 < det.confidence <= 1.0 and det.reprojection_error < 0.5
    assert {"rvec", "tvec", "ambiguity", "pixel_size", "alternative"} <= set(det.extra)
    assert det.extra["intrinsics"] == "calibrated"
    assert det.extra["pixel_size"] == pytest.approx(pixel_side(view.corners), abs=0.5)
    assert json.loads(json.dumps(det.to_json()))["marker_id"] == 7


@pytest.mark.parametrize("tracking", [False, True])
def test_the_markers_alone_are_the_detections_corners_before_their_pose(tracking):
    # what a bench times against OpenCV's detectMarkers, which computes no pose: process = detections of markers
    views = [_one_view(1.0, seed=s) for s in (3, 5)]
    whole = ArucoSource({"marker_size_m": MARKER, "tracking": tracking})
    staged = ArucoSource({"marker_size_m": MARKER, "tracking": tracking})
    for i, view in enumerate(views + views):
        frame = _frame(view, stamp=i / 30)
        corners, ids = staged.markers(cv2.cvtColor(view.image, cv2.COLOR_BGR2GRAY))
        assert corners.shape == (len(ids), 4, 2) and ids.tolist() == [7]
        [a] = whole.process(frame)
        [b] = staged.detections(frame, corners, ids)
        assert np.array_equal(a.corners, b.corners) and np.array_equal(a.position, b.position)
        assert a.orientation.tolist() == b.orientation.tolist() and a.extra == b.extra


def test_confidence_is_lower_for_a_far_small_marker_than_a_near_one():
    near = ArucoSource({"marker_size_m": MARKER}).process(_frame(_one_view(0.5, seed=1)))[0]
    far = ArucoSource({"marker_size_m": MARKER}).process(_frame(_one_view(3.0, seed=1)))[0]
    assert far.confidence < near.confidence


def test_mono_and_bgr_frames_give_the_same_detection():
    view = _one_view(1.0, seed=4)
    mono = Frame(image=cv2.cvtColor(view.image, cv2.COLOR_BGR2GRAY), stamp=0.0, intrinsics=view.intrinsics)
    a = ArucoSource({"marker_size_m": MARKER}).process(_frame(view))[0]
    b = ArucoSource({"marker_size_m": MARKER}).process(mono)[0]
    assert np.allclose(a.position, b.position, atol=1e-6)


@pytest.mark.parametrize(
    ("image", "expected"),
    [
        (np.zeros((480, 640), np.float32), "uint8"),
        (np.zeros((480, 640, 4), np.uint8), "H×W×3"),
        ("not an image", "numpy image"),
    ],
)
def test_a_malformed_frame_is_rejected_with_what_was_expected(image, expected):
    with pytest.raises(ValueError, match=expected):
        ArucoSource({}).process(Frame(image=image, stamp=0.0))


def test_allowed_ids_and_per_id_sizes():
    view = _one_view(1.0, seed=5, marker_size_m=0.10)  # id 7, printed 10 cm
    assert ArucoSource({"allowed_ids": [1, 2]}).process(_frame(view)) == []
    [det] = ArucoSource({"marker_size_m": 0.3, "marker_sizes": {7: 0.10}}).process(_frame(view))
    assert det.distance == pytest.approx(view.distance, rel=0.02)


def test_apriltag_36h11_dictionary_used_by_the_sim():
    rng = np.random.default_rng(8)
    view = sv.render_marker_view(
        sv.random_pose(1.5, 30, rng), rng=rng, marker_id=0, dictionary=cv2.aruco.DICT_APRILTAG_36h11
    )
    [det] = ArucoSource({"dictionary": "DICT_APRILTAG_36h11", "marker_size_m": MARKER}).process(_frame(view))
    assert det.marker_id == 0 and det.distance == pytest.approx(1.5, rel=0.02)


@pytest.mark.parametrize("name", PREDEFINED)
def test_every_opencv_predefined_dictionary_is_detected_by_its_name(name):
    """DICT_4X4_* … DICT_7X7_*, ARUCO_ORIGINAL, ARUCO_MIP_36h12 and the four AprilTag families; DICT_5X5_1000
    is what other ROS ArUco nodes default to."""
    rng = np.random.default_rng(sum(map(ord, name)))
    dictionary = cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, name))
    marker_id = len(dictionary.bytesList) - 1  # the last id: the whole dictionary is there
    view = sv.render_marker_view(
        sv.random_pose(1.0, 30, rng), rng=rng, marker_id=marker_id, dictionary=getattr(cv2.aruco, name)
    )
    dets = ArucoSource({"dictionary": name, "marker_size_m": MARKER}).process(_frame(view))
    assert [d.marker_id for d in dets] == [marker_id]
    assert dets[0].extra["dictionary"] == name and dets[0].distance == pytest.approx(1.0, rel=0.02)


def test_a_dictionary_name_in_another_case_is_the_same_dictionary():
    assert ArucoSource({"dictionary": "dict_apriltag_36H11"}).dictionary == "DICT_APRILTAG_36h11"


def test_a_dictionary_file_that_is_missing_or_not_a_dictionary_is_a_config_error_naming_the_key(tmp_path):
    (tmp_path / "bad.yml").write_text('%YAML:1.0\nnmarkers: 2\nmarkersize: 4\nmarker_0: "0101"\n')
    for path in (tmp_path / "missing.yml", tmp_path / "bad.yml"):
        with pytest.raises(ConfigError) as err:
            registry.create(
                SourceConfig(plugin="aruco", params={"dictionary": str(path)}), key_prefix="perception.sources[0]"
            )
        assert err.value.key == "perception.sources[0].params.dictionary" and str(path) in str(err.value)


@pytest.mark.parametrize(
    ("params", "key"),
    [
        ({"marker_size_m": 0}, "marker_size_m"),
        ({"marker_size_m": "big"}, "marker_size_m"),
        ({"marker_sizes": {7: -1}}, "marker_sizes[7]"),
        ({"corner_refinement": "magic"}, "corner_refinement"),
        ({"disambiguation": "guess"}, "disambiguation"),
        ({"markersize": 0.1}, "markersize"),
    ],
)
def test_a_bad_param_is_a_config_error_naming_the_key(params, key):
    with pytest.raises(ConfigError) as err:
        registry.create(SourceConfig(plugin="aruco", params=params), key_prefix="perception.sources[0]")
    assert err.value.key == f"perception.sources[0].params.{key}"


# --------------------------------------------------------------------------------------------------
# Fallbacks (design notes: warn and keep going) and what is refused instead
# --------------------------------------------------------------------------------------------------


def test_an_unsupported_dictionary_is_a_config_error_listing_the_names_that_exist():
    """As an unknown AprilTag family is (issue 36): reading another dictionary would see no markers, silently."""
    with pytest.raises(ConfigError) as err:
        registry.create(
            SourceConfig(plugin="aruco", params={"dictionary": "DICT_4x4_25O", "marker_size_m": MARKER}),
            key_prefix="perception.sources[0]",
        )
    assert err.value.key == "perception.sources[0].params.dictionary"
    assert "unsupported dictionary 'DICT_4x4_25O' (did you mean DICT_4X4_250?)" in str(err.value)
    assert all(name in str(err.value) for name in PREDEFINED)  # it lists what does exist


def _fallback_reference(view: sv.SyntheticView):
    k = CameraIntrinsics.fallback(view.intrinsics.width, view.intrinsics.height)
    return ArucoSource({"marker_size_m": MARKER}).process(_frame(view, intrinsics=k))[0]


@pytest.mark.parametrize(
    "bad",
    [
        None,
        CameraIntrinsics(fx=0.0, fy=579.4, cx=320, cy=240, width=640, height=480),
        CameraIntrinsics(fx=579.4, fy=float("nan"), cx=320, cy=240, width=640, height=480),
    ],
)
def test_missing_or_invalid_intrinsics_warn_once_and_use_the_degraded_pinhole(caplog, bad):
    view = _one_view(1.0, seed=9)
    src = ArucoSource({"marker_size_m": MARKER})
    with caplog.at_level(logging.WARNING, logger="mission.perception_plugins.aruco"):
        first = src.process(Frame(image=view.image, stamp=0.0, intrinsics=bad))
        second = src.process(Frame(image=view.image, stamp=0.1, intrinsics=bad))
    warnings = [r for r in caplog.records if "fallback pinhole" in r.getMessage()]
    assert len(warnings) == 1  # once, not per frame
    assert ("missing" if bad is None else "invalid") in warnings[0].getMessage()
    assert first[0].extra["intrinsics"] == "fallback" and second[0].extra["intrinsics"] == "fallback"
    ref = _fallback_reference(view)  # fx = fy = 0.9·640, principal point at the centre
    assert np.allclose(first[0].position, ref.position, atol=1e-9)
    # The fallback focal length (576) is close to the true one (579): still a usable degraded pose.
    assert first[0].distance == pytest.approx(view.distance, rel=0.02)


def test_empty_distortion_means_an_ideal_lens_without_any_warning(caplog):
    view = _one_view(1.0, seed=10)
    k = view.intrinsics
    zeros = CameraIntrinsics(k.fx, k.fy, k.cx, k.cy, k.width, k.height, distortion=(0.0,) * 5)
    assert k.distortion == ()
    with caplog.at_level(logging.WARNING, logger="mission.perception_plugins.aruco"):
        a = ArucoSource({"marker_size_m": MARKER}).process(_frame(view, intrinsics=k))[0]
    b = ArucoSource({"marker_size_m": MARKER}).process(_frame(view, intrinsics=zeros))[0]
    assert caplog.records == []
    assert a.extra["intrinsics"] == "calibrated"
    assert np.allclose(a.position, b.position, atol=1e-12)


# --------------------------------------------------------------------------------------------------
# Corner refinement (perception_plugins/corner_refinement.py)
# --------------------------------------------------------------------------------------------------


def _opencv_corners(image: np.ndarray, method: int) -> np.ndarray | None:
    params = cv2.aruco.DetectorParameters()
    params.cornerRefinementMethod = method
    d = cv2.aruco.getPredefinedDictionary(cv2.aruco.DICT_4X4_250)
    c, ids, _ = cv2.aruco.ArucoDetector(d, params).detectMarkers(cv2.cvtColor(image, cv2.COLOR_BGR2GRAY))
    return None if ids is None else np.asarray(c[0], np.float64).reshape(4, 2)


def test_blurred_small_markers_keep_their_corners_where_opencvs_subpix_drags_them():
    """15 cm markers at 2 m (~45 px) with 2 px of blur: OpenCV's cornerSubPix converges inside the marker for
    some corners; the fitted edges do not, and never do worse than the unrefined corners."""
    rng = np.random.default_rng(21)
    far = {"ours": 0, "unrefined": 0, "subpix": 0}
    for i in range(20):
        view = sv.render_marker_view(
            sv.random_pose(2.0, 50, rng, marker_size_m=0.15),
            rng=rng,
            marker_size_m=0.15,
            blur_sigma=2.0,
            noise_sigma=3.0,
        )
        dets = ArucoSource({"marker_size_m": 0.15}).process(_frame(view, stamp=float(i)))
        found = {
            "ours": dets[0].corners if dets else None,
            "unrefined": _opencv_corners(view.image, 0),
            "subpix": _opencv_corners(view.image, 1),
        }
        for k, c in found.items():
            if c is not None:
                far[k] += int((np.linalg.norm(c - view.corners, axis=1) > 2.0).sum())
    assert far["ours"] <= far["unrefined"] and far["ours"] < far["subpix"], far


def test_refined_corners_are_more_accurate_than_opencvs_subpix_on_sharp_views():
    err = {"edges": [], "subpix": []}
    for i in range(12):
        view = _one_view(1.0 + (i % 3), seed=100 + i)
        for method in err:
            (d,) = ArucoSource({"marker_size_m": MARKER, "corner_refinement": method}).process(_frame(view))
            err[method] += np.linalg.norm(d.corners - view.corners, axis=1).tolist()
    assert np.median(err["edges"]) < 0.6 * np.median(err["subpix"])
