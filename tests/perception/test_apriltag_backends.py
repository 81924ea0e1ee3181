"""The two AprilTag backends (AprilTag 3 via pupil-apriltags, OpenCV's ArUco) see the same tag the same way:
same corners (OpenCV's pixel convention and order), same pose, and the same decode-quality figures."""

from __future__ import annotations

import math
import subprocess
import sys
import textwrap

import cv2
import numpy as np
import pytest

from mission.core import se3
from mission.core.types import Frame
from mission.perception_plugins.apriltag import AprilTagSource
from mission.perception_plugins.apriltag_backends import pupil_corner_order
from tests.helpers.apriltag_images import flip_data_cells, place_tag, tag_cells
from tools import synthetic_views as sv

OPENCV_DICT = {
    "tag36h11": cv2.aruco.DICT_APRILTAG_36h11,
    "tag25h9": cv2.aruco.DICT_APRILTAG_25h9,
    "tag16h5": cv2.aruco.DICT_APRILTAG_16h5,
}


def source(backend: str, **params) -> AprilTagSource:
    return AprilTagSource({"backend": backend, "disambiguation": "naive", **params})


def detect(src: AprilTagSource, image: np.ndarray, intr=None, stamp: float = 0.0):
    return src.process(Frame(image, stamp=stamp, intrinsics=intr or sv.default_intrinsics()))


@pytest.mark.parametrize(
    ("family", "backends"),
    [
        ("tag36h11", ("apriltag3", "opencv")),
        ("tag25h9", ("apriltag3", "opencv")),
        ("tag16h5", ("apriltag3", "opencv")),
        ("tagStandard41h12", ("apriltag3",)),
    ],
)
def test_each_family_is_read_with_corners_in_opencvs_convention(family, backends):
    cells, _, width_at_border = tag_cells(family, 7)
    image, truth = place_tag(cells, width_at_border)
    for backend in backends:
        dets = detect(source(backend, family=family), image)
        assert [d.marker_id for d in dets] == [7], backend
        # TL TR BR BL of the upright tag, pixel centres on integers (pupil's +0.5 px removed)
        assert np.abs(dets[0].corners - truth).max() < 0.3, backend
        assert dets[0].extra["family"] == family and dets[0].extra["backend"] == backend


def test_the_pupil_corner_permutation_is_measured_as_a_permutation():
    order = pupil_corner_order()
    assert sorted(order) == [0, 1, 2, 3]


@pytest.mark.parametrize("family", ["tag36h11", "tag25h9", "tag16h5"])
def test_both_backends_agree_on_rendered_perspective_tags(family):
    """Random poses 1–2 m away, up to 35° off axis (anti-aliased renders with blur and sensor noise)."""
    rng = np.random.default_rng({"tag36h11": 1, "tag25h9": 2, "tag16h5": 3}[family])
    k = sv.default_intrinsics()
    a3, cv = source("apriltag3", family=family, marker_size_m=0.2), source("opencv", family=family, marker_size_m=0.2)
    n = 8 if family == "tag36h11" else 3
    for i in range(n):
        truth = sv.random_pose(1.0 + i % 3 * 0.5, 35.0, rng, k, 0.2)
        view = sv.render_marker_view(
            truth, marker_id=7, marker_size_m=0.2, dictionary=OPENCV_DICT[family], intrinsics=k, rng=rng
        )
        # tag16h5's codes are 5 bits apart: texture decodes as a tag at hamming 2 now and then (AprilTag's docs
        # warn of it), in either backend; the rendered tag is the one compared
        (da,), (do,) = ([d for d in detect(b, view.image, k) if d.marker_id == 7] for b in (a3, cv))
        assert np.linalg.norm(da.corners - do.corners, axis=1).max() <= 0.5
        rng_m = np.linalg.norm(da.position)
        assert np.linalg.norm(da.position - do.position) <= 0.01 * rng_m
        angle = math.degrees(se3.rotation_angle(se3.quat_to_matrix(da.orientation), se3.quat_to_matrix(do.orientation)))
        assert angle < 5.0  # 4 corners of a 20 cm tag at 2 m: OpenCV's 0.3 px corner noise is ~2° of tilt
        # and both are right: the pose is the rendered one
        assert np.linalg.norm(da.position - view.position) <= 0.01 * view.distance


def _flipped(n_flips: int) -> np.ndarray:
    cells, _, wab = tag_cells("tag36h11", 7)
    data = [(3, 3), (5, 6), (7, 4)][:n_flips]  # cells inside the 6×6 data area (rows/cols 2–7)
    return place_tag(flip_data_cells(cells, data), wab)[0]


@pytest.mark.parametrize("backend", ["apriltag3", "opencv"])
def test_corrected_bits_are_reported_as_hamming(backend):
    src = source(backend)
    assert [d.extra["hamming"] for d in detect(src, _flipped(0))] == [0]
    assert [d.extra["hamming"] for d in detect(src, _flipped(1))] == [1]
    assert [d.extra["hamming"] for d in detect(src, _flipped(2))] == [2]


def test_max_hamming_drops_tags_with_more_corrected_bits():
    for backend in ("apriltag3", "opencv"):
        assert detect(source(backend, max_hamming=0), _flipped(1)) == []
        assert [d.extra["hamming"] for d in detect(source(backend, max_hamming=1), _flipped(1))] == [1]
    assert detect(source("apriltag3"), _flipped(3)) == []  # AprilTag 3 corrects at most 2 bits
    assert [d.extra["hamming"] for d in detect(source("opencv", max_hamming=3), _flipped(3))] == [3]


def test_decision_margin_measures_contrast_the_same_way_in_both_backends():
    cells, _, wab = tag_cells("tag36h11", 7)
    crisp = place_tag(cells, wab, black=20, white=235)[0]
    dull = place_tag(cells, wab, black=110, white=160)[0]
    margins = {}
    for backend in ("apriltag3", "opencv"):
        src = source(backend)
        margins[backend] = tuple(detect(src, img)[0].extra["decision_margin"] for img in (crisp, dull))
        assert margins[backend][0] > 3 * margins[backend][1]
    for i in range(2):  # comparable numbers (grey levels), not identical algorithms
        a, o = margins["apriltag3"][i], margins["opencv"][i]
        assert abs(a - o) <= 0.3 * max(a, o)


def test_many_tag16h5_detectors_can_be_made_and_freed(tmp_path):
    """pupil-apriltags 1.0.4 frees a family before its detector; with tag16h5 the next detector then
    aborts the process. The source frees them in the right order (a child process, so a crash is a
    failed test, not a dead test run)."""
    script = textwrap.dedent(
        """
        import numpy as np
        from mission.core.types import Frame
        from mission.perception_plugins.apriltag import AprilTagSource
        img = np.full((120, 160), 128, np.uint8)
        for _ in range(4):
            s = AprilTagSource({"family": "tag16h5"})
            s.process(Frame(img, stamp=0.0))
            s.close()
            del s
        print("ok")
        """
    )
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.strip() == "ok"


def _cell_by_cell(gray: np.ndarray, quad: np.ndarray, code: np.ndarray, ppc: int = 8) -> tuple[int, float]:
    """The definition of hamming and decision margin, one cell at a time (what sample_bits batches):
    warp the tag plus a quiet-zone cell to (n + 4) cells of ppc px, take each cell's central-half mean,
    threshold midway between the quiet zone's and the black border's median cells, and sharpen each data
    cell's distance from it as AprilTag's decoder does (0.25 × (4·v − the data neighbours' v))."""
    n = code.shape[0]
    cells = n + 4
    lo, hi = ppc - 0.5, (cells - 1) * ppc - 0.5
    dst = np.array([[lo, lo], [hi, lo], [hi, hi], [lo, hi]], np.float32)
    hom = cv2.getPerspectiveTransform(quad.astype(np.float32), dst)
    warped = cv2.warpPerspective(gray, hom, (cells * ppc,) * 2, flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
    q = ppc // 4
    mean = [
        [float(warped[r * ppc + q : (r + 1) * ppc - q, c * ppc + q : (c + 1) * ppc - q].mean()) for c in range(cells)]
        for r in range(cells)
    ]
    ring = [mean[r][c] for r in range(cells) for c in range(cells) if min(r, c) == 0 or max(r, c) == cells - 1]
    border = [
        mean[r][c] for r in range(1, cells - 1) for c in range(1, cells - 1) if min(r, c) == 1 or max(r, c) == cells - 2
    ]
    threshold = (float(np.median(ring)) + float(np.median(border))) / 2.0

    def v(r: int, c: int) -> float:  # a data cell's distance from the threshold; 0 outside the data
        return mean[r + 2][c + 2] - threshold if 0 <= r < n and 0 <= c < n else 0.0

    sharp = [
        (v(r, c) + 0.25 * (4 * v(r, c) - v(r - 1, c) - v(r + 1, c) - v(r, c - 1) - v(r, c + 1)), bool(code[r, c]))
        for r in range(n)
        for c in range(n)
    ]
    hamming = sum((x > 0) != white for x, white in sharp)
    above = [x for x, _ in sharp if x > 0]
    below = [-x for x, _ in sharp if x <= 0]
    return hamming, min(float(np.mean(side)) for side in (above, below) if side)


def test_the_opencv_backends_decode_quality_is_the_cell_by_cell_definition():
    """Eight rendered tags per frame (perspective, blur, noise), at full and at low contrast, and tags with
    1–3 flipped bits: the batched sampling reports exactly the hamming and margin of the definition."""
    from mission.perception_plugins.apriltag_backends import OpenCvBackend, dictionary_codes

    rng = np.random.default_rng(11)
    k = sv.default_intrinsics()
    frames, background = [], None
    for i in range(8):
        pos = np.array([(i % 4 - 1.5) * 0.35, (i // 4 - 0.5) * 0.4, 1.5])
        truth = sv.pose_facing_camera(pos, rng.uniform(0, 2 * math.pi), math.radians(rng.uniform(0, 25)), 0.0)
        view = sv.render_marker_view(
            truth,
            marker_id=i,
            marker_size_m=0.12,
            dictionary=OPENCV_DICT["tag36h11"],
            intrinsics=k,
            rng=rng,
            background=background,
        )
        background = cv2.cvtColor(view.image, cv2.COLOR_BGR2GRAY).astype(np.float32)
    grey = background.astype(np.uint8)
    frames += [grey, (grey * 0.3 + 90).astype(np.uint8)]
    frames += [cv2.cvtColor(_flipped(n), cv2.COLOR_BGR2GRAY) for n in (1, 2, 3)]
    backend = OpenCvBackend("tag36h11", max_hamming=3, refine_edges=True)
    codes = dictionary_codes("DICT_APRILTAG_36h11")
    seen = []
    for frame in frames:
        for tag in backend.detect(frame):
            assert (tag.hamming, tag.decision_margin) == _cell_by_cell(frame, tag.corners, codes[tag.tag_id])
            seen.append(tag.hamming)
    assert len(seen) == 2 * 8 + 3 and sorted(seen)[-3:] == [1, 2, 3]
