"""Bad images and depth into the perception sources and PerceiveTargets (issue 9, bad-input matrix).

Each source either uses the image or rejects it with a one-line ValueError saying what it expected (the
PerceptionSource contract: PerceiveTargets isolates the raise); PerceiveTargets drops a frame no source
could use, counts it, says why in its feedback, and the next good frame is processed as usual.

Already covered elsewhere: a float32 / 4-channel / non-array image into aruco and a float32 image into
apriltag (test_aruco_source.py, test_apriltag_source.py); a str / None / empty / 7-channel image into
PerceiveTargets (test_perception_stage.py); an unsupported ArUco dictionary and AprilTag family
(test_aruco_source.py, test_apriltag_source.py); frames without depth into vlm (vlm/test_vlm_source.py).
"""

from __future__ import annotations

import logging
import math
from pathlib import Path

import cv2
import numpy as np
import py_trees
import pytest

from mission.core import blackboard as bbk
from mission.core.config import TargetSpec
from mission.core.types import CameraIntrinsics, Frame, Pose2D
from mission.perception_plugins.apriltag import AprilTagSource
from mission.perception_plugins.aruco import ArucoSource
from mission.perception_plugins.pipeline import PerceptionStage
from mission.perception_plugins.vlm.source import VlmSource
from mission.trees.loader import load_tree
from tests.helpers.behaviour_world import Scene, marker_facing, read
from tests.helpers.vlm_scene import Box, camera_pose, render, yaw_towards
from tests.helpers.vlm_scene import Scene as VlmScene
from tools import synthetic_views as sv

S = py_trees.common.Status
MARKER = 0.2
K = sv.default_intrinsics()


def _view(dictionary: int = cv2.aruco.DICT_4X4_250, seed: int = 3) -> sv.SyntheticView:
    rng = np.random.default_rng(seed)
    return sv.render_marker_view(sv.random_pose(1.0, 20, rng), rng=rng, marker_size_m=MARKER, dictionary=dictionary)


ARUCO_VIEW = _view()
TAG_VIEW = _view(cv2.aruco.DICT_APRILTAG_36h11)


def aruco() -> ArucoSource:
    return ArucoSource({"marker_size_m": MARKER})


def apriltag() -> AprilTagSource:
    return AprilTagSource({"marker_size_m": MARKER, "backend": "opencv"})


SOURCES = {"aruco": (aruco, ARUCO_VIEW), "apriltag": (apriltag, TAG_VIEW)}

# image kind → (what to feed, words of the ValueError, or None: the source uses it)
BAD_IMAGES = {
    "zero-size colour": (lambda img: np.zeros((0, 0, 3), np.uint8), "empty image of shape (0, 0, 3)"),
    "zero-width mono": (lambda img: np.zeros((480, 0), np.uint8), "empty image of shape (480, 0)"),
    "4×4 pixels": (lambda img: img[:4, :4], "image 4×4 is too small to hold a marker"),
    "16-bit": (lambda img: img.astype(np.uint16) * 257, "expected a uint8 image (H×W mono or H×W×3 BGR), got dtype uint16"),  # noqa: E501
    "bool": (lambda img: img > 128, "got dtype bool"),
    "4-channel": (lambda img: cv2.cvtColor(img, cv2.COLOR_BGR2BGRA), "got shape (480, 640, 4)"),
    "2-channel": (lambda img: img[:, :, :2].copy(), "got shape (480, 640, 2)"),
    "a batch of images": (lambda img: img[None], "got shape (1, 480, 640, 3)"),
}  # fmt: skip
GOOD_IMAGES = {
    "single-channel": lambda img: cv2.cvtColor(img, cv2.COLOR_BGR2GRAY),
    "H×W×1": lambda img: cv2.cvtColor(img, cv2.COLOR_BGR2GRAY)[:, :, None],
    "non-contiguous view": lambda img: np.asfortranarray(img),
}


@pytest.mark.parametrize("kind", list(BAD_IMAGES))
@pytest.mark.parametrize("source", list(SOURCES))
def test_a_fiducial_source_rejects_an_unusable_image_with_one_line_saying_what_it_expected(source, kind):
    make, view = SOURCES[source]
    convert, words = BAD_IMAGES[kind]
    with pytest.raises(ValueError) as err:
        make().process(Frame(convert(view.image), stamp=0.0, intrinsics=view.intrinsics))
    assert words in str(err.value) and "\n" not in str(err.value)


@pytest.mark.parametrize("kind", list(GOOD_IMAGES))
@pytest.mark.parametrize("source", list(SOURCES))
def test_mono_and_odd_layouts_give_the_same_pose_as_the_colour_image(source, kind):
    make, view = SOURCES[source]
    [ref] = make().process(Frame(view.image, stamp=0.0, intrinsics=view.intrinsics))
    [det] = make().process(Frame(GOOD_IMAGES[kind](view.image), stamp=0.0, intrinsics=view.intrinsics))
    assert det.marker_id == ref.marker_id and np.allclose(det.position, ref.position, atol=2e-3)


@pytest.mark.parametrize("source", list(SOURCES))
def test_a_huge_image_is_processed_and_the_marker_found_at_its_true_distance(source):
    """A 4000×3000 (12 MP) frame: slow-ish, but neither refused nor mis-scaled."""
    k = CameraIntrinsics.from_vertical_fov(4000, 3000, 45.0)
    dictionary = cv2.aruco.DICT_4X4_250 if source == "aruco" else cv2.aruco.DICT_APRILTAG_36h11
    rng = np.random.default_rng(8)
    view = sv.render_marker_view(
        sv.random_pose(3.0, 20, rng), rng=rng, marker_size_m=MARKER, intrinsics=k, dictionary=dictionary, supersample=1
    )
    [det] = SOURCES[source][0]().process(Frame(view.image, stamp=0.0, intrinsics=k))
    assert det.distance == pytest.approx(view.distance, rel=0.01)


# -- wrong calibration -----------------------------------------------------------------------------------


@pytest.mark.parametrize("distortion", [(0.1,), (0.0, 0.0, 0.0), (0.0,) * 7, (0.0, float("nan"), 0.0, 0.0, 0.0)])
@pytest.mark.parametrize("source", list(SOURCES))
def test_a_distortion_vector_opencv_rejects_warns_once_and_falls_back_instead_of_losing_every_marker(
    source, distortion, caplog
):
    make, view = SOURCES[source]
    k = view.intrinsics
    bad = CameraIntrinsics(k.fx, k.fy, k.cx, k.cy, k.width, k.height, distortion=distortion)
    src = make()
    with caplog.at_level(logging.WARNING):
        first = src.process(Frame(view.image, stamp=0.0, intrinsics=bad))
        second = src.process(Frame(view.image, stamp=0.1, intrinsics=bad))
    assert len(first) == 1 and len(second) == 1  # before: zero detections, silently, on every frame
    assert first[0].extra["intrinsics"] == "fallback"
    [warning] = [r.getMessage() for r in caplog.records if "fallback pinhole" in r.getMessage()]
    expected = "non-finite" if any(math.isnan(v) for v in distortion) else f"has {len(distortion)} coefficients"
    assert "invalid" in warning and expected in warning


@pytest.mark.parametrize("source", list(SOURCES))
def test_intrinsics_calibrated_for_another_resolution_are_not_used_for_this_image(source, caplog):
    """A 640×480 image with a 1920×1080 calibration (a driver switching modes): its pose would be wrong by
    the scale; the source falls back and says why, once, as the ROS adapter does for CameraInfo."""
    make, view = SOURCES[source]
    k = view.intrinsics
    hd = CameraIntrinsics(k.fx * 3, k.fy * 3, 960.0, 540.0, 1920, 1080)
    with caplog.at_level(logging.WARNING):
        [det] = make().process(Frame(view.image, stamp=0.0, intrinsics=hd))
    assert det.extra["intrinsics"] == "fallback"
    [warning] = [r.getMessage() for r in caplog.records if "fallback pinhole" in r.getMessage()]
    assert "calibrated for 1920×1080, the image is 640×480" in warning
    unsized = CameraIntrinsics(k.fx, k.fy, k.cx, k.cy, 0, 0)  # size not stated: used as given
    [det] = make().process(Frame(view.image, stamp=0.0, intrinsics=unsized))
    assert det.extra["intrinsics"] == "calibrated"


# -- markers at the border -------------------------------------------------------------------------------


def _at_edge(edge: str, inside_px: float, dictionary: int) -> tuple[sv.SyntheticView, np.ndarray]:
    """A marker 1 m away, tilted 10°, whose outer edge is `inside_px` inside the image edge (negative:
    that many pixels beyond it, i.e. partly outside the image)."""
    z, half = 1.0, K.fx * MARKER / 2
    u, v = {
        "left": (inside_px + half, K.cy),
        "right": (K.width - inside_px - half, K.cy),
        "top": (K.cx, inside_px + half),
        "bottom": (K.cx, K.height - inside_px - half),
    }[edge]
    position = np.array([(u - K.cx) * z / K.fx, (v - K.cy) * z / K.fy, z])
    pose = sv.pose_facing_camera(position, 0.0, math.radians(10), 0.0)
    view = sv.render_marker_view(pose, rng=np.random.default_rng(4), marker_size_m=MARKER, dictionary=dictionary)
    return view, position


@pytest.mark.parametrize("edge", ["left", "right", "top", "bottom"])
@pytest.mark.parametrize("source", list(SOURCES))
def test_a_marker_at_the_border_or_partly_outside_is_found_accurately_or_not_at_all(source, edge):
    dictionary = cv2.aruco.DICT_4X4_250 if source == "aruco" else cv2.aruco.DICT_APRILTAG_36h11
    make = SOURCES[source][0]
    # with its white quiet zone (one code cell, ~19 px here) in the image: found, pose within 1 %
    view, truth = _at_edge(edge, 40.0, dictionary)
    [det] = make().process(Frame(view.image, stamp=0.0, intrinsics=K))
    assert det.marker_id == view.marker_id and np.linalg.norm(det.position - truth) < 0.01
    # touching the border, a quarter, half and most of it outside: never a wrong id or a wrong pose
    for inside in (3.0, 0.0, -29.0, -58.0, -100.0):
        view, truth = _at_edge(edge, inside, dictionary)
        for det in make().process(Frame(view.image, stamp=0.0, intrinsics=K)):
            assert det.marker_id == view.marker_id, (edge, inside)
            assert np.linalg.norm(det.position - truth) < 0.02, (edge, inside)


# -- vlm: images and depth ---------------------------------------------------------------------------------

BOX = Box((3.0, 0.3, 0.25), (0.3, 0.3, 0.5), (30, 30, 200), yaw=0.2)
VLM_FRAME = render(VlmScene([BOX]), camera_pose(0.0, 0.0, yaw_towards(0.0, 0.0, 3.0, 0.3)))


class Clock:
    t = 1_700_000_000.0

    def __call__(self) -> float:
        return self.t


def vlm(tmp_path: Path) -> tuple[VlmSource, Clock]:
    clock = Clock()
    params = {
        "state_file": str(tmp_path / "quota.json"),
        "latency_s": 0.0,
        "miss_rate": 0.0,
        "publish_rate_limit_hz": 1.0,
        "daily_quota": 100,
    }
    return VlmSource(params, name="vlm", clock=clock), clock


def feed(src: VlmSource, clock: Clock, frame: Frame, n: int = 4) -> None:
    for i in range(n):
        src.process(
            Frame(
                frame.image,
                i * 0.1,
                frame.frame_id,
                frame.intrinsics,
                frame.depth,
                frame.T_anchor_camera,
                frame.anchor_frame,
            )
        )
        assert src.wait_idle(timeout=10.0)
        clock.t += 1.0


@pytest.mark.parametrize(
    ("kind", "image", "words"),
    [
        ("zero-size", np.zeros((0, 0, 3), np.uint8), "got shape (0, 0, 3)"),
        ("16-bit", VLM_FRAME.image.astype(np.uint16) * 257, "got dtype uint16"),
        ("single-channel", cv2.cvtColor(VLM_FRAME.image, cv2.COLOR_BGR2GRAY), "finds objects by colour"),
        ("4-channel", cv2.cvtColor(VLM_FRAME.image, cv2.COLOR_BGR2BGRA), "got shape (240, 320, 4)"),
        ("not an array", "frame.png", "got str"),
    ],
)
def test_vlm_rejects_an_image_it_cannot_look_at_before_spending_a_model_call(tmp_path, kind, image, words):
    src, _ = vlm(tmp_path)
    try:
        with pytest.raises(ValueError, match="expected an H×W×3 uint8 BGR image") as err:
            src.process(
                Frame(
                    image,
                    0.0,
                    intrinsics=VLM_FRAME.intrinsics,
                    depth=VLM_FRAME.depth,
                    T_anchor_camera=VLM_FRAME.T_anchor_camera,
                )
            )
        assert words in str(err.value) and "\n" not in str(err.value)
        assert src.model_calls == 0 and src.status()["calls_today"] == 0
    finally:
        src.close()


@pytest.mark.parametrize(
    ("kind", "depth", "words"),
    [
        ("all NaN", np.full((240, 320), np.nan, np.float32), "no valid return"),
        ("all inf", np.full((240, 320), np.inf, np.float32), "no valid return"),
        ("all zero", np.zeros((240, 320), np.float32), "no valid return"),
        ("negative", -np.ones((240, 320), np.float32), "no valid return"),
        ("16UC1 millimetres", np.full((240, 320), 3000, np.uint16), "dtype uint16, expected float metres"),
        ("H×W×1", np.ones((240, 320, 1), np.float32), "shape (240, 320, 1)"),
        ("other size", np.ones((120, 160), np.float32), "does not match image (240, 320)"),
    ],
)
def test_vlm_skips_frames_whose_depth_cannot_place_an_answer_and_spends_no_quota(tmp_path, caplog, kind, depth, words):
    src, clock = vlm(tmp_path)
    try:
        with caplog.at_level(logging.WARNING, logger="mission.perception_plugins.vlm.source"):
            feed(
                src,
                clock,
                Frame(VLM_FRAME.image, 0.0, VLM_FRAME.frame_id, VLM_FRAME.intrinsics, depth, VLM_FRAME.T_anchor_camera),
            )
        status = src.status()
        assert status["frames_bad_depth"] == 4 and status["calls_today"] == 0 and status["state"] == "bad_depth"
        [line] = [r.getMessage() for r in caplog.records]  # once, not per frame
        assert line.startswith("vlm: ") and words in line and "no model call spent" in line
        feed(src, clock, VLM_FRAME)  # good depth again: the model is asked and the target latches
        assert src.latch.latched
    finally:
        src.close()


def test_vlm_partly_missing_depth_still_latches(tmp_path):
    """Half the rows without a return (a real depth camera's holes) is not bad depth."""
    depth = VLM_FRAME.depth.copy()
    depth[::2] = np.nan
    src, clock = vlm(tmp_path)
    try:
        feed(
            src,
            clock,
            Frame(VLM_FRAME.image, 0.0, VLM_FRAME.frame_id, VLM_FRAME.intrinsics, depth, VLM_FRAME.T_anchor_camera),
        )
        assert src.latch.latched and src.status().get("frames_bad_depth", 0) == 0
    finally:
        src.close()


# -- the perception stage keeps going ----------------------------------------------------------------------


def test_the_perception_stage_drops_16_bit_bgra_float_bool_and_nan_stamped_frames_and_keeps_going():
    """One counted drop each, with the reason in its summary — not an error raised by every source —
    and the next good frame is detected as usual."""
    stage = PerceptionStage([aruco()], {"target": TargetSpec(marker_id=7)})
    w = bbk.writer("adapter")
    img, k = ARUCO_VIEW.image, ARUCO_VIEW.intrinsics
    bad = {
        "16-bit": (img.astype(np.uint16) * 257, 1.0, "image has dtype uint16, expected uint8"),
        "BGRA": (cv2.cvtColor(img, cv2.COLOR_BGR2BGRA), 2.0, "image has shape (480, 640, 4), expected H×W or H×W×3"),
        "float": (img.astype(np.float32) / 255, 3.0, "image has dtype float32, expected uint8"),
        "bool": (img > 128, 4.0, "image has dtype bool, expected uint8"),
        "NaN stamp": (img, float("nan"), "stamp nan is not finite"),
    }
    for seq, (kind, (image, stamp, words)) in enumerate(bad.items(), 1):
        bbk.set_(w, bbk.FRAME, Frame(image=image, stamp=stamp, intrinsics=k))
        bbk.set_(w, bbk.FRAME_SEQ, seq)
        perceived = stage.update(w)
        assert perceived is not None and perceived.dropped == "frames_dropped", kind
        assert perceived.summary == f"dropped frame {seq}: {words}"
    stats = read(bbk.PERCEPTION_STATS)
    assert stats["frames_dropped"] == len(bad)
    assert not any(key.startswith("source_errors") for key in stats), "a dropped frame never reaches a source"
    bbk.set_(w, bbk.FRAME, Frame(image=img, stamp=10.0, intrinsics=k))
    bbk.set_(w, bbk.FRAME_SEQ, 10)
    assert stage.update(w).processed
    assert read(bbk.TRACKS)["target"].visible and read(bbk.PERCEPTION_STATS)["frames_processed"] == 1


def test_the_shipped_follow_tree_keeps_following_through_a_burst_of_bad_frames():
    """A mission tick with garbage in the middle: the tree never fails or stops, the drops are counted, and
    FOLLOW carries on (a dropped frame is not a miss, so it does not push the tree into LOST or SEARCH)."""
    scene = Scene(robot=Pose2D(0.0, 0.0, 0.0), marker=marker_facing(2.0, 0.0, math.pi))
    scene.perceive_targets({"target": TargetSpec(marker_id=7)})
    tree = py_trees.trees.BehaviourTree(load_tree("follow.xml"))
    tree.setup(timeout=5.0)
    w = bbk.writer("adapter")

    def cycle(bad_image: object = None) -> str:
        scene.sense()  # what the adapter writes: pose, clock, a good frame…
        if bad_image is not None:  # …unless the camera sent garbage
            bbk.set_(w, bbk.FRAME, Frame(image=bad_image, stamp=scene.clock))  # type: ignore[arg-type]
        scene.perceive()
        tree.tick()
        scene.act()
        assert tree.root.status == S.RUNNING
        return tree.root.tip().name

    assert [cycle() for _ in range(5)][-1] == "FollowTarget"
    garbage = [np.zeros((480, 640), np.uint16), np.zeros((0, 0, 3), np.uint8), "frame", np.ones((4, 4, 4))]
    tips = [cycle(image) for image in garbage * 5]
    assert set(tips) == {"FollowTarget"}
    assert read(bbk.PERCEPTION_STATS)["frames_dropped"] == 20
    assert [cycle() for _ in range(5)][-1] == "FollowTarget" and read(bbk.TRACKS)["target"].misses == 0
