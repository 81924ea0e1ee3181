"""The two AprilTag detectors behind the `apriltag` source, made to agree on what a detection is.

* ``apriltag3`` — AprilTag 3 through pupil-apriltags (the C library of the AprilRobotics lab);
* ``opencv`` — OpenCV's ArUco module with its ``DICT_APRILTAG_*`` dictionaries (same codes).

They disagree on conventions (FIELD_NOTES): pupil-apriltags puts pixel centres at +0.5 and lists the
corners counter-clockwise from the official tag image's bottom-left, while OpenCV lists TL TR BR BL of
the marker *it* draws — which OpenCV ≤ 5.0.0 draws rotated 180° from the official images. Both
backends here return corners in OpenCV's convention (the one the aruco source and the sim's
OpenCV-drawn textures use), pupil's permutation measured once per process
(:func:`pupil_corner_order`), so the shared square-pose code (perception_plugins/square_pose.py) gives
the same pose for the same tag.

Small tags at the default settings. AprilTag's usual speed-up, ``quad_decimate`` 2, finds quads in an image
subsampled 2×: on real photos it missed 39 of 102 tags of 14–41 px that full resolution finds (BENCHMARKS.md,
real images), for a quarter of the time. Most of full resolution's extra time goes into the many small,
faint clusters of texture (gravel, carpet, sensor noise) that cannot be tags; AprilTag has two public
thresholds for them in its detector's ``qtp`` (apriltag.h), which pupil-apriltags does not expose (nor,
through a truncation, its decode sharpening: :data:`DECODE_SHARPENING`):
``min_white_black_diff`` (a region whose grey levels span less is not thresholded at all) and
``min_cluster_pixels``. :class:`Apriltag3Backend` runs at full resolution by default with both raised
(:data:`MIN_CLUSTER_PIXELS`, and a contrast floor of :data:`CONTRAST_FRACTION` of the frame's grey-level spread,
at most :data:`MAX_MIN_CONTRAST`), which finds what full resolution finds (with the sharpening, a little
more) at about the time of decimate 2.
The thresholds are set through a ctypes view of the C struct that is checked against the values
pupil-apriltags set before anything is written; a library whose struct differs is left at its defaults,
with a warning.

OpenCV does not report AprilTag's decode quality, so this module measures it the way AprilTag defines
it: the tag is sampled cell by cell through its homography; the *hamming* distance is the number of
data bits that differ from the code of the decoded id, the *decision margin* is how far the data cells'
grey levels sit from the black/white threshold (the smaller of the white and the black side's mean).
"""

from __future__ import annotations

import ctypes
import functools
import logging
import math
from dataclasses import dataclass
from typing import Any

import cv2
import numpy as np
import pupil_apriltags

from mission.perception_plugins.aruco_detection import QuadDetector
from mission.perception_plugins.corner_refinement import refine_corners

log = logging.getLogger(__name__)

# Families per backend (what each library can decode), in the order the docs list them.
APRILTAG3_FAMILIES = ("tag36h11", "tag25h9", "tag16h5", "tagStandard41h12")
OPENCV_DICTIONARIES = {
    "tag36h11": "DICT_APRILTAG_36h11",
    "tag25h9": "DICT_APRILTAG_25h9",
    "tag16h5": "DICT_APRILTAG_16h5",
}
SUPPORTED_FAMILIES = {"apriltag3": APRILTAG3_FAMILIES, "opencv": tuple(OPENCV_DICTIONARIES)}
APRILTAG3_MAX_HAMMING = 2  # pupil-apriltags registers every family with 2 correctable bits

MIN_CLUSTER_PIXELS = 30  # AprilTag's default 5; a 10 px tag's border already gives ~80
CONTRAST_FRACTION = 0.4  # min_white_black_diff = this × the frame's grey-level spread (1st–99th percentile) …
MAX_MIN_CONTRAST = 60  # … at most this (real photos lose tags above ~65) …
MIN_MIN_CONTRAST = 5  # … and never below AprilTag's own default
# AprilTag's default decode sharpening. pupil-apriltags 1.0.4 passes int(decode_sharpening), i.e. 0: the
# 0.25 it documents never reaches the C detector. With it, full resolution decodes the small tags that
# refine_edges had been needed for (2 of 23 rendered 20 px tags) and loses none (BENCHMARKS.md, real images).
DECODE_SHARPENING = 0.25


class _QuadThreshParams(ctypes.Structure):
    """``struct apriltag_quad_thresh_params`` (apriltag.h, AprilTag 3)."""

    _fields_ = [
        ("min_cluster_pixels", ctypes.c_int),
        ("max_nmaxima", ctypes.c_int),
        ("critical_rad", ctypes.c_float),
        ("cos_critical_rad", ctypes.c_float),
        ("max_line_fit_mse", ctypes.c_float),
        ("min_white_black_diff", ctypes.c_int),
        ("deglitch", ctypes.c_int),
    ]


class _DetectorHead(ctypes.Structure):
    """The first fields of ``struct apriltag_detector`` (apriltag.h, AprilTag 3), up to its ``qtp``."""

    _fields_ = [
        ("nthreads", ctypes.c_int),
        ("quad_decimate", ctypes.c_float),
        ("quad_sigma", ctypes.c_float),
        ("refine_edges", ctypes.c_bool),
        ("decode_sharpening", ctypes.c_double),
        ("debug", ctypes.c_bool),
        ("qtp", _QuadThreshParams),
    ]


def detector_head(detector: pupil_apriltags.Detector) -> _DetectorHead | None:
    """The detector's C struct up to its quad-threshold params, writable; None when it is not laid out as
    apriltag.h says (then nothing is written): its head must hold what pupil-apriltags was given and its
    ``qtp`` AprilTag's documented defaults."""
    ptr = getattr(detector, "tag_detector_ptr", None)
    if ptr is None:
        return None
    head = ctypes.cast(ptr, ctypes.POINTER(_DetectorHead)).contents
    q = head.qtp
    expected = detector.params
    same_head = (
        head.nthreads == expected["nthreads"]
        and abs(head.quad_decimate - expected["quad_decimate"]) < 1e-6
        and abs(head.quad_sigma - expected["quad_sigma"]) < 1e-6
        and bool(head.refine_edges) == bool(expected["refine_edges"])
    )
    defaults = (
        (q.max_nmaxima, q.max_line_fit_mse, q.min_white_black_diff, q.deglitch) == (10, 10.0, 5, 0)
        and abs(q.cos_critical_rad - math.cos(math.radians(10.0))) < 1e-4  # AprilTag's 10° corner limit
        and 0 < q.min_cluster_pixels < 1000
    )
    return head if same_head and defaults else None


def min_contrast_for(gray: np.ndarray) -> int:
    """AprilTag's ``min_white_black_diff`` for this frame: :data:`CONTRAST_FRACTION` of its grey-level spread.

    The spread (1st to 99th percentile, of every 8th pixel) is what a printed tag's black and white can
    span in this exposure: a dim frame gets a low floor, so its tags are still found; a bright, contrasty
    one a high floor, so its texture is skipped."""
    sample = gray[::8, ::8]
    hist = cv2.calcHist([np.ascontiguousarray(sample)], [0], None, [256], [0, 256]).ravel()
    cdf = np.cumsum(hist) / max(1.0, float(hist.sum()))
    lo, hi = int(np.searchsorted(cdf, 0.01)), int(np.searchsorted(cdf, 0.99))
    return int(min(MAX_MIN_CONTRAST, max(MIN_MIN_CONTRAST, round(CONTRAST_FRACTION * (hi - lo)))))


@dataclass(frozen=True)
class RawTag:
    """One decoded tag in one image, before any pose: OpenCV corner convention (TL TR BR BL, pixel centres
    at integer coordinates)."""

    tag_id: int
    corners: np.ndarray  # 4×2 float64
    hamming: int
    decision_margin: float


def release_detector(detector: Any) -> None:
    """Free a pupil_apriltags.Detector's C objects in the right order: the detector, then its families.

    pupil-apriltags 1.0.4 frees the families first, and the detector's destructor then reads a freed
    family (the same use-after-free duckietown/lib-dt-apriltags#26 fixed); with tag16h5 the heap is
    corrupted and the next detector aborts the process ("malloc(): mismatching next->prev_size").
    Idempotent: a released detector has nothing left to free.
    """
    if getattr(detector, "tag_detector_ptr", None) is None:
        return
    libc = detector.libc
    libc.apriltag_detector_destroy.restype = None
    libc.apriltag_detector_destroy(detector.tag_detector_ptr)
    detector.tag_detector_ptr = None
    for family, tf in detector.tag_families.items():
        destroy = getattr(libc, f"{family}_destroy")
        destroy.restype = None
        destroy(tf)
    detector.tag_families = {}


@functools.cache
def pupil_corner_order() -> tuple[int, int, int, int]:
    """The permutation taking pupil-apriltags' corners to OpenCV's (TL TR BR BL of the marker OpenCV draws).

    Measured once per process rather than hard-coded: OpenCV ≤ 5.0.0 draws (and reads) AprilTags rotated
    180° from the official apriltag-imgs images, which makes the permutation [1, 0, 3, 2] (FIELD_NOTES);
    opencv/opencv#28823 changes OpenCV's orientation in a later 5.x, which would make it [3, 2, 1, 0].
    Measuring it keeps both backends, the aruco source and the sim's OpenCV-drawn textures in one
    convention whichever OpenCV is installed.
    """
    d = cv2.aruco.getPredefinedDictionary(cv2.aruco.DICT_APRILTAG_36h11)
    cell = 12
    img = cv2.aruco.generateImageMarker(d, 0, 8 * cell, borderBits=1)
    img = cv2.copyMakeBorder(img, 2 * cell, 2 * cell, 2 * cell, 2 * cell, cv2.BORDER_CONSTANT, value=255)
    lo, hi = 2 * cell - 0.5, 10 * cell - 0.5  # the black square's edges, OpenCV pixel convention
    expected = np.array([[lo, lo], [hi, lo], [hi, hi], [lo, hi]])
    found = SafeDetector(families="tag36h11").detect(img)
    if len(found) == 1:
        raw = np.asarray(found[0].corners, dtype=np.float64) - 0.5
        order = tuple(int(np.argmin(np.linalg.norm(raw - e, axis=1))) for e in expected)
        if sorted(order) == [0, 1, 2, 3]:
            return order  # type: ignore[return-value]
    return (1, 0, 3, 2)  # the measured order of OpenCV ≤ 5.0.0 (FIELD_NOTES)


class SafeDetector(pupil_apriltags.Detector):
    """pupil_apriltags.Detector whose destructor frees the C objects in the right order."""

    def __del__(self) -> None:
        release_detector(self)


class Apriltag3Backend:
    """pupil-apriltags (AprilTag 3); `min_contrast` None = per frame (:func:`min_contrast_for`), 5 = AprilTag's
    default; `min_cluster_pixels` None = AprilTag's default (5).

    `refine_edges` refines the corners on their fitted edges (perception_plugins/corner_refinement.py,
    shared with the aruco source), after the library. AprilTag's own ``refine_edges`` is used only when
    decimating, where it is what recovers full-resolution corners: at full resolution it cost 2 of 120
    real tags (it moves a small tag's edges until it no longer decodes), and the fitted edges are more
    precise than it is on rendered tags (median corner error 0.04 px against 0.07).
    """

    name = "apriltag3"

    def __init__(
        self,
        family: str,
        *,
        decimate: float,
        threads: int,
        refine_edges: bool,
        min_contrast: int | None = None,
        min_cluster_pixels: int | None = MIN_CLUSTER_PIXELS,
    ) -> None:
        self.family = family
        self.refine_edges = refine_edges
        self._detector = SafeDetector(
            families=family, nthreads=threads, quad_decimate=decimate, refine_edges=int(refine_edges and decimate > 1)
        )
        self.cells = int(self._detector.tag_families[family].contents.width_at_border)  # the black square, in cells
        self.min_contrast = min_contrast
        head = detector_head(self._detector)
        self._qtp = None if head is None else head.qtp
        if head is None:
            log.warning(
                "apriltag3: this pupil-apriltags' detector struct is not AprilTag 3's; its quad thresholds stay at "
                "the library's defaults (full resolution is then ~3× slower than decimate 2)"
            )
        else:
            head.decode_sharpening = DECODE_SHARPENING
            if min_cluster_pixels is not None:
                head.qtp.min_cluster_pixels = int(min_cluster_pixels)
        self.last_min_contrast: int | None = None  # what the last frame used (for reports and tests)

    def detect(self, gray: np.ndarray, min_perimeter_rate: float | None = None, refine: bool = True) -> list[RawTag]:
        """The tags in `gray`. AprilTag 3 has no perimeter floor to set; a tracking window's is not used.
        `refine` False leaves the corners to the caller (tracking refines them in the frame, not a window)."""
        out = []
        order = list(pupil_corner_order())
        gray = np.ascontiguousarray(gray)
        if self._qtp is not None:
            contrast = self.min_contrast if self.min_contrast is not None else min_contrast_for(gray)
            self._qtp.min_white_black_diff = int(contrast)
            self.last_min_contrast = int(contrast)
        found = self._detector.detect(gray)
        if not found:
            return out
        quads = np.stack([np.asarray(d.corners, dtype=np.float64)[order] - 0.5 for d in found])
        if self.refine_edges and refine:
            quads = refine_corners(gray, quads, self.cells)
        for d, corners in zip(found, quads, strict=True):
            out.append(RawTag(int(d.tag_id), corners, int(d.hamming), float(d.decision_margin)))
        return out

    def close(self) -> None:
        self._qtp = None
        self._detector = None


class OpenCvBackend:
    """OpenCV ArUco with the matching DICT_APRILTAG_* dictionary (corners refined on their fitted edges,
    perception_plugins/corner_refinement.py, as the aruco source does)."""

    name = "opencv"

    def __init__(self, family: str, *, max_hamming: int, refine_edges: bool) -> None:
        self.family = family
        self.dictionary = cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, OPENCV_DICTIONARIES[family]))
        self.refine_edges = refine_edges
        # Let OpenCV correct at least `max_hamming` bits; the measured hamming then filters precisely.
        max_bits = max(1, int(self.dictionary.maxCorrectionBits))
        correction = float(min(1.0, (max_hamming + 0.5) / max_bits))

        def configure(params: Any) -> None:
            params.cornerRefinementMethod = cv2.aruco.CORNER_REFINE_NONE  # refined here, when refine_edges
            params.errorCorrectionRate = correction

        # The marker's own quad, not an inner contour, and large markers kept (aruco_detection.py).
        self._detector = QuadDetector(self.dictionary, configure)
        self._n = int(self.dictionary.markerSize)
        self.cells = self._n + 2  # data bits + the black border
        self._codes = dictionary_codes(OPENCV_DICTIONARIES[family])

    def detect(self, gray: np.ndarray, min_perimeter_rate: float | None = None, refine: bool = True) -> list[RawTag]:
        """The tags in `gray`; `min_perimeter_rate` is what a tracking window sets (marker_tracking.py). `refine`
        False leaves the corners to the caller (tracking refines them in the frame, not a window)."""
        quads, ids = self._detector(gray, min_perimeter_rate)
        if len(ids) == 0:
            return []
        if self.refine_edges and refine:
            quads = refine_corners(gray, quads, self.cells)
        corners = quads
        bits, margins = sample_bits(gray, corners, self._n)
        hamming = np.count_nonzero(bits != self._codes[ids], axis=(1, 2)).tolist()
        return [RawTag(i, c, h, m) for c, i, h, m in zip(corners, ids.tolist(), hamming, margins.tolist(), strict=True)]

    def close(self) -> None:
        self._detector = None


@functools.cache
def dictionary_codes(dictionary: str) -> np.ndarray:
    """Every id's n×n data bits of OpenCV dictionary `dictionary` (ids × n × n bool, white = 1).

    Built once per process (~6 ms for the 587 ids of 36h11) so a frame's hamming distances are one
    indexed comparison; read-only, as it is shared by every backend of that family.
    """
    d = cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, dictionary))
    n, rows = int(d.markerSize), d.bytesList
    codes = np.stack([cv2.aruco.Dictionary.getBitsFromByteList(rows[i : i + 1], n) for i in range(len(rows))])
    codes = codes.astype(bool)
    codes.flags.writeable = False
    return codes


@dataclass(frozen=True)
class _Grid:
    """The constants of :func:`sample_bits` for one (n, ppc): computed once, not per tag."""

    side: int  # px of the warped square (tag + one quiet-zone cell each side)
    dst: np.ndarray  # 4×2 float32: where the black square's corners go in the warped image
    pick: np.ndarray  # cells × side float32: 1 on each cell's central half (rows) — the cell sums
    area: float  # pixels summed per cell
    ring: np.ndarray  # flat indices of the quiet-zone cells
    border: np.ndarray  # flat indices of the black-border cells


@functools.cache
def _grid(n: int, ppc: int) -> _Grid:
    cells = n + 4
    side = cells * ppc
    # The black square spans cells 1 … n+3; OpenCV's corners sit on its outer edge.
    lo, hi = ppc - 0.5, (cells - 1) * ppc - 0.5
    dst = np.array([[lo, lo], [hi, lo], [hi, hi], [lo, hi]], dtype=np.float32)
    q = ppc // 4
    pick = np.zeros((cells, side), np.float32)
    for c in range(cells):
        pick[c, c * ppc + q : (c + 1) * ppc - q] = 1.0
    ring = np.zeros((cells, cells), bool)
    ring[0, :] = ring[-1, :] = ring[:, 0] = ring[:, -1] = True
    border = np.zeros((cells, cells), bool)
    border[1:-1, 1:-1] = True
    border[2:-2, 2:-2] = False
    area = float((ppc - 2 * q) ** 2)
    return _Grid(side, dst, pick, area, np.flatnonzero(ring), np.flatnonzero(border))


def _median(values: np.ndarray) -> np.ndarray:
    """np.median along the last axis, without its per-call overhead (same arithmetic: the middle value,
    or the half-sum of the two middle ones)."""
    s = np.sort(values, axis=-1)
    m = s.shape[-1]
    return s[..., m // 2] if m % 2 else (s[..., m // 2 - 1] + s[..., m // 2]) / 2.0


def sample_bits(gray: np.ndarray, corners: Any, n: int, ppc: int = 8) -> tuple[np.ndarray, np.ndarray]:
    """(T×n×n data bits, T decision margins) of T square tags in grey image `gray` whose black borders have
    `corners` (a sequence of T quadrilaterals TL TR BR BL, any shape that reshapes to 4×2, as detectMarkers returns).

    Each tag plus one quiet-zone cell around it is warped to a grid of (n + 4) cells of `ppc` px; each
    cell's grey level is the mean of its central half. The threshold is midway between the black border
    and the white quiet zone (the medians of their cells: what AprilTag's decoder models); white = 1, as
    OpenCV's dictionaries store it. The data cells' distances from the threshold are then sharpened as
    AprilTag's decoder sharpens them (``v + DECODE_SHARPENING · (4v − its four neighbours)``, on a grid
    where every cell but the data cells is 0), so the margins compare with the apriltag3 backend's. A bit
    is white where its sharpened value is > 0; the margin is the smaller of the mean sharpened distance of
    the white and of the black data cells.

    Batched because it runs for every tag of every frame (bench: perception): one warp per tag in C, then
    all the tags' cell means, medians and margins as whole-array operations. With the default ppc the
    cell means are multiples of 1/16, so every sum here is exact and the result does not depend on the
    order numpy adds in (the sharpening keeps them multiples of 1/128).
    """
    g = _grid(n, ppc)
    count = len(corners)
    warped = np.empty((count, g.side, g.side), np.uint8)
    for k, quad in enumerate(corners):
        hom = cv2.getPerspectiveTransform(np.asarray(quad, dtype=np.float32).reshape(4, 2), g.dst)
        warped[k] = cv2.warpPerspective(
            gray, hom, (g.side, g.side), flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE
        )
    cells = n + 4
    # Cell sums of whole grey levels are exact in float32 (< 2^24); the division is float64, as np.mean's.
    sums = g.pick @ warped.astype(np.float32) @ g.pick.T
    means = sums.astype(np.float64) / g.area  # count × cells × cells
    flat = means.reshape(count, cells * cells)
    threshold = (_median(flat[:, g.ring]) + _median(flat[:, g.border])) / 2.0
    values = np.zeros((count, n + 2, n + 2))  # the data cells and a ring of zeros round them
    values[:, 1:-1, 1:-1] = means[:, 2:-2, 2:-2] - threshold[:, None, None]
    neighbours = values[:, :-2, 1:-1] + values[:, 2:, 1:-1] + values[:, 1:-1, :-2] + values[:, 1:-1, 2:]
    inner = values[:, 1:-1, 1:-1]
    data = (inner + DECODE_SHARPENING * (4.0 * inner - neighbours)).reshape(count, n * n)
    bits = data > 0.0
    n_white = np.count_nonzero(bits, axis=1)
    n_black = n * n - n_white
    white = np.where(bits, data, 0.0).sum(axis=1) / np.maximum(n_white, 1)
    black = np.where(bits, 0.0, -data).sum(axis=1) / np.maximum(n_black, 1)
    margins = np.minimum(np.where(n_white > 0, white, np.inf), np.where(n_black > 0, black, np.inf))
    return bits.reshape(count, n, n), margins
