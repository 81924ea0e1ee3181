"""The `apriltag` source: tag attribution, per-tag sizes, static transforms composed on the right sides
(checked against hand-computed SE(3)), stamps and the static flag, confidence, and every param."""

from __future__ import annotations

import json
import math
import subprocess
import sys
import textwrap
from pathlib import Path

import cv2
import numpy as np
import pytest

from mission.core import se3
from mission.core.config import SourceConfig
from mission.core.errors import ConfigError
from mission.core.types import Frame
from mission.perception_plugins import registry
from mission.perception_plugins.apriltag import AprilTagSource
from tests.helpers.apriltag_images import flip_data_cells, place_tag, tag_cells
from tools import synthetic_views as sv

REPO_ROOT = Path(__file__).resolve().parents[2]
K = sv.default_intrinsics()
FRONTAL = sv.R_FRONTAL  # a tag squarely facing the camera: x right, y up, z towards the camera

# A robot whose camera sits 0.2 m ahead of and 0.5 m above its base, looking forward (ROS optical frame).
CAMERA_MOUNT = {"xyz": [0.2, 0.0, 0.5], "rpy": [-math.pi / 2, 0.0, -math.pi / 2]}
# autobot03 carries tag 402 on its front face, 0.1 m ahead of and 0.3 m above its base, upright. Tag frame:
# x = entity +y, y = entity +z, z = entity +x, so T_entity_tag = (R = [[0,0,1],[1,0,0],[0,1,0]],
# t = (0.1, 0, 0.3)) and, inverted by hand, T_tag_entity = (R = [[0,1,0],[0,0,1],[1,0,0]] = quat
# (-0.5, -0.5, -0.5, 0.5), t = -Rᵀ·(0.1, 0, 0.3) = (0, -0.3, -0.1)).
TAG_TO_AUTOBOT = {"xyz": [0.0, -0.3, -0.1], "quat": [-0.5, -0.5, -0.5, 0.5]}
# The scene: autobot03 stands 2.0 m ahead and 0.5 m left of our base, turned to face us (yaw π). Its tag
# is then at base (1.9, 0.5, 0.3): from the camera (0.2, 0, 0.5) that is 1.7 ahead, 0.5 left, 0.2 down,
# i.e. optical (x right, y down, z forward) (-0.5, 0.2, 1.7), facing the camera squarely.
T_CAM_TAG402 = se3.transform(FRONTAL, (-0.5, 0.2, 1.7))
T_CAM_TAG53 = se3.transform(FRONTAL, (0.4, -0.1, 1.5))  # a 10 cm traffic-sign tag
T_CAM_TAG9 = se3.transform(FRONTAL, (0.1, -0.3, 2.0))  # a tag nobody listed

TABLE = {
    402: {"name": "autobot03", "marker_size_m": 0.15, "T_tag_entity": TAG_TO_AUTOBOT},
    53: {"name": "traffic_sign", "marker_size_m": 0.10, "static": True},
}


def scene(seed: int = 0) -> np.ndarray:
    """Three tags in one image: 402 (0.15 m), 53 (0.10 m), 9 (0.15 m)."""
    rng = np.random.default_rng(seed)
    img = None
    for t, tag_id, size in ((T_CAM_TAG402, 402, 0.15), (T_CAM_TAG53, 53, 0.10), (T_CAM_TAG9, 9, 0.15)):
        bg = None if img is None else cv2.cvtColor(img, cv2.COLOR_BGR2GRAY).astype(np.float32)
        img = sv.render_marker_view(
            t,
            marker_id=tag_id,
            marker_size_m=size,
            dictionary=cv2.aruco.DICT_APRILTAG_36h11,
            intrinsics=K,
            rng=rng,
            background=bg,
            noise_sigma=1.0,
        ).image
    return img


@pytest.fixture(scope="module")
def image() -> np.ndarray:
    return scene()


def by_id(dets) -> dict:
    return {d.marker_id: d for d in dets}


def frame(img: np.ndarray, stamp: float = 12.5) -> Frame:
    return Frame(img, stamp=stamp, frame_id="front_camera_optical", intrinsics=K)


# -- attribution, sizes, stamps ----------------------------------------------------------------------


@pytest.mark.parametrize("backend", ["apriltag3", "opencv"])
def test_tags_are_attributed_to_their_entities(image, backend):
    src = AprilTagSource({"backend": backend, "marker_size_m": 0.15, "tags": TABLE})
    dets = by_id(src.process(frame(image)))
    assert sorted(dets) == [9, 53, 402]
    assert dets[402].label == "autobot03" and dets[53].label == "traffic_sign"
    assert dets[9].label is None  # not in the table: reported, unnamed
    assert dets[53].extra["static"] is True and dets[402].extra["static"] is False
    assert all(d.stamp == 12.5 and d.frame_id == "front_camera_optical" for d in dets.values())  # stamps kept
    for d in dets.values():
        assert {"hamming", "decision_margin", "static", "family", "backend"} <= set(d.extra)
        assert d.extra["precision"] == "precise" and 0.5 < d.confidence <= 1.0
        json.dumps(d.to_json())


def test_the_short_table_form_names_an_entity(image):
    src = AprilTagSource({"marker_size_m": 0.15, "tags": {402: "autobot03", "53": "traffic_sign"}})
    assert src.entity(402) == "autobot03" and src.entity(53) == "traffic_sign" and src.entity(9) is None
    assert by_id(src.process(frame(image)))[53].label == "traffic_sign"


def test_ignore_unknown_drops_tags_outside_the_table(image):
    src = AprilTagSource({"marker_size_m": 0.15, "tags": TABLE, "ignore_unknown": True})
    assert sorted(by_id(src.process(frame(image)))) == [53, 402]


def test_per_tag_sizes_override_the_default_size(image):
    sized = by_id(AprilTagSource({"marker_size_m": 0.15, "tags": TABLE}).process(frame(image)))
    assert np.allclose(sized[53].position, T_CAM_TAG53[:3, 3], atol=0.01)
    assert sized[53].extra["marker_size_m"] == 0.10
    unsized = by_id(AprilTagSource({"marker_size_m": 0.15}).process(frame(image)))
    assert np.allclose(unsized[53].position, 1.5 * T_CAM_TAG53[:3, 3], atol=0.015)  # a 0.15 m tag would be farther


# -- static transforms against hand-computed SE(3) ---------------------------------------------------


@pytest.mark.parametrize("backend", ["apriltag3", "opencv"])
def test_report_frame_base_gives_robot_base_to_entity_base(image, backend):
    src = AprilTagSource(
        {
            "backend": backend,
            "marker_size_m": 0.15,
            "tags": TABLE,
            "camera_mount": CAMERA_MOUNT,
            "report_frame": "base",
            "base_frame": "base_link",
        }
    )
    d = by_id(src.process(frame(image)))[402]
    assert d.frame_id == "base_link"
    # By hand: autobot03's base is 2.0 m ahead, 0.5 m left of ours, on the floor, turned to face us.
    assert np.allclose(d.position, [2.0, 0.5, 0.0], atol=0.03)
    r = se3.quat_to_matrix(d.orientation)
    assert math.degrees(se3.rotation_angle(r, se3.rot_z(math.pi))) < 3.0
    assert np.allclose(d.extra["T_camera_tag"][:3], [-0.5, 0.2, 1.7], atol=0.03)
    # A tag without T_tag_entity is its own entity: base → tag = mount ∘ camera→tag. By hand, an optical
    # point (x, y, z) is base (0.2 + z, -x, 0.5 - y) for this mount.
    sign = by_id(src.process(frame(image)))[53]
    x, y, z = sign.extra["T_camera_tag"][:3]
    assert np.allclose(sign.position, [0.2 + z, -x, 0.5 - y], atol=1e-5)
    assert np.allclose(sign.position, [1.7, -0.4, 0.6], atol=0.06)  # ≈ optical (0.4, -0.1, 1.5), a 10 cm tag


def test_report_frame_camera_keeps_the_tag_pose_and_adds_the_entity_pose(image):
    src = AprilTagSource({"marker_size_m": 0.15, "tags": TABLE})
    d = by_id(src.process(frame(image)))[402]
    assert d.frame_id == "front_camera_optical"
    assert np.allclose(d.position, [-0.5, 0.2, 1.7], atol=0.02)  # the tag, marker z towards the camera
    assert math.degrees(se3.rotation_angle(se3.quat_to_matrix(d.orientation), FRONTAL)) < 3.0
    # By hand: autobot03's base, 1.8 ahead / 0.5 left / 0.5 below the camera → optical (-0.5, 0.5, 1.8).
    assert np.allclose(d.extra["T_camera_entity"][:3], [-0.5, 0.5, 1.8], atol=0.03)
    assert "T_camera_entity" not in by_id(src.process(frame(image)))[53].extra


def test_a_transform_is_given_as_xyz_and_quat_or_rpy():
    from mission.perception_plugins.apriltag import TransformSpec

    by_rpy = TransformSpec(xyz=(1.0, 2.0, 3.0), rpy=(-math.pi / 2, 0.0, -math.pi / 2)).matrix()
    by_quat = TransformSpec(xyz=(1.0, 2.0, 3.0), quat=(-0.5, 0.5, -0.5, 0.5)).matrix()
    assert np.allclose(by_rpy[:3, :3], se3.R_BODY_OPTICAL) and np.allclose(by_quat, by_rpy)
    assert np.allclose(by_rpy[:3, 3], [1.0, 2.0, 3.0])
    assert np.allclose(TransformSpec().matrix(), np.eye(4))


# -- confidence and decode quality -------------------------------------------------------------------


def test_confidence_drops_with_corrected_bits_and_weak_contrast():
    cells, _, wab = tag_cells("tag36h11", 7)
    src = AprilTagSource({"disambiguation": "naive"})

    def conf(img):
        return src.process(Frame(img, stamp=0.0, intrinsics=K))[0].confidence

    clean = conf(place_tag(cells, wab)[0])
    one_bit = conf(place_tag(flip_data_cells(cells, [(3, 3)]), wab)[0])
    dull = conf(place_tag(cells, wab, black=115, white=150)[0])
    assert one_bit < 0.6 * clean and dull < 0.8 * clean  # (a frontal tag's flip ambiguity costs half anyway)


def test_min_decision_margin_drops_weak_decodes():
    cells, _, wab = tag_cells("tag36h11", 7)
    dull = place_tag(cells, wab, black=115, white=150)[0]
    clean = place_tag(cells, wab)[0]
    (weak,) = AprilTagSource({}).process(Frame(dull, 0.0, intrinsics=K))
    (strong,) = AprilTagSource({}).process(Frame(clean, 0.0, intrinsics=K))
    floor = weak.extra["decision_margin"] + 1.0
    assert strong.extra["decision_margin"] > floor
    src = AprilTagSource({"min_decision_margin": floor})
    assert src.process(Frame(dull, 0.0, intrinsics=K)) == [] and src.counters["rejected_margin"] == 1
    assert src.process(Frame(clean, 0.0, intrinsics=K))


# -- the detector params -----------------------------------------------------------------------------


def test_small_tags_are_found_at_the_defaults():
    """A 16 px tag (2 px per cell): full resolution by default; decimating 4× loses it."""
    cells, _, wab = tag_cells("tag36h11", 7)
    small = place_tag(cells, wab, cell_px=2)[0]  # a 16 px tag
    assert AprilTagSource({}).process(Frame(small, 0.0, intrinsics=K))
    assert AprilTagSource({"decimate": 4.0}).process(Frame(small, 0.0, intrinsics=K)) == []


def test_threads_do_not_change_what_is_found():
    """`threads: 2` finds the same tags at the same corners as one thread. Run in a child process:
    AprilTag 3's threaded path has open data-race reports (AprilRobotics/apriltag#387, #184) and once
    died of SIGSEGV inside this very call in CI, so a crash here is this test's failure, with the child's
    stack, not the end of the whole test run."""
    script = textwrap.dedent(
        """
        import faulthandler, json
        faulthandler.enable()
        from mission.perception_plugins.apriltag import AprilTagSource
        from tests.perception.test_apriltag_source import frame, scene
        image = scene()
        out = {}
        for threads in (1, 2):
            dets = AprilTagSource({"marker_size_m": 0.15, "threads": threads}).process(frame(image))
            out[threads] = {d.marker_id: d.corners.tolist() for d in dets}
        print(json.dumps(out))
        """
    )
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=120, cwd=REPO_ROOT)
    assert done.returncode == 0, f"the child died ({done.returncode}):\n{done.stderr[-3000:]}"
    found = json.loads(done.stdout.strip().splitlines()[-1])
    one, two = found["1"], found["2"]
    assert sorted(one) == sorted(two) and len(one) == 3
    assert all(np.allclose(one[i], two[i]) for i in one)


@pytest.mark.parametrize("backend", ["apriltag3", "opencv"])
def test_edge_corner_refinement_makes_corners_more_accurate(backend):
    rng = np.random.default_rng(5)
    err = {True: [], False: []}
    for _ in range(4):
        view = sv.render_marker_view(
            sv.random_pose(1.5, 30.0, rng, K, 0.2),
            marker_id=7,
            marker_size_m=0.2,
            dictionary=cv2.aruco.DICT_APRILTAG_36h11,
            intrinsics=K,
            rng=rng,
        )
        for refine in (True, False):
            src = AprilTagSource({"backend": backend, "corner_refinement": "edges" if refine else "none"})
            (d,) = src.process(Frame(view.image, 0.0, intrinsics=K))
            err[refine].append(np.linalg.norm(d.corners - view.corners, axis=1).mean())
    assert np.mean(err[True]) < np.mean(err[False])


def test_temporal_disambiguation_follows_each_tag_over_frames():
    rng = np.random.default_rng(9)
    views = sv.render_sequence(
        2.0, 35.0, 5, rng, marker_id=7, marker_size_m=0.2, dictionary=cv2.aruco.DICT_APRILTAG_36h11, intrinsics=K
    )
    temporal = AprilTagSource({"marker_size_m": 0.2})
    naive = AprilTagSource({"marker_size_m": 0.2, "disambiguation": "naive"})
    frames = [Frame(v.image, stamp=i / 15, intrinsics=K) for i, v in enumerate(views)]
    assert [temporal.process(f)[0].extra["track_frames"] for f in frames] == [1, 2, 3, 4, 5]
    assert {naive.process(f)[0].extra["track_frames"] for f in frames} == {1}


def test_missing_intrinsics_fall_back_to_the_degraded_pinhole(image):
    (d, *_) = AprilTagSource({"marker_size_m": 0.15}).process(Frame(image, stamp=0.0))
    assert d.extra["intrinsics"] == "fallback"


def test_a_bad_image_raises_a_clear_error():
    with pytest.raises(ValueError, match="uint8"):
        AprilTagSource({}).process(Frame(np.zeros((48, 64), np.float32), stamp=0.0))


# -- params ------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("params", "key", "text"),
    [
        ({"family": "tagStandard41h12", "backend": "opencv"}, "family", "supported: tag36h11, tag25h9, tag16h5"),
        ({"family": "tag99h1"}, "family", "tag36h11, tag25h9, tag16h5, tagStandard41h12"),
        ({"backend": "gpu"}, "backend", ""),
        ({"max_hamming": 3}, "max_hamming", "at most 2"),
        ({"report_frame": "base"}, "camera_mount", "needs camera_mount"),
        ({"report_frame": "map"}, "report_frame", ""),
        ({"marker_size_m": 0}, "marker_size_m", ""),
        ({"decimate": 0.5}, "decimate", ""),
        ({"threads": 0}, "threads", ""),
        ({"tags": {7: {"name": "t", "marker_size_m": -1}}}, "tags[7].marker_size_m", ""),
        ({"tags": {"seven": "t"}}, "tags.seven.[key]", ""),
        (
            {"tags": {7: {"name": "t", "T_tag_entity": {"quat": [0, 0, 0, 1], "rpy": [0, 0, 0]}}}},
            "tags[7].T_tag_entity",
            "either quat or rpy",
        ),
        ({"camera_mount": {"xyz": [0, 0]}}, "camera_mount.xyz[2]", ""),
        ({"tag_sise_m": 0.2}, "tag_sise_m", "unknown key"),
    ],
)
def test_a_bad_param_is_a_config_error_naming_the_key(params, key, text):
    with pytest.raises(ConfigError) as err:
        AprilTagSource(params)
    assert err.value.key == key
    assert text in str(err.value)


def test_the_registry_builds_the_source_with_documented_defaults():
    src = registry.create(SourceConfig(plugin="apriltag"))
    p = src.params
    assert isinstance(src, AprilTagSource) and src.name == "apriltag"
    assert (p.family, p.backend, p.marker_size_m, p.report_frame) == ("tag36h11", "apriltag3", 0.15, "camera")
    assert (p.decimate, p.threads, p.corner_refinement, p.max_hamming, p.min_contrast) == (1.0, 1, "edges", 2, "auto")
    src.close()
    with pytest.raises(ConfigError, match=r"perception\.sources\.params\.family"):
        registry.create(SourceConfig(plugin="apriltag", params={"family": "tag99"}))
