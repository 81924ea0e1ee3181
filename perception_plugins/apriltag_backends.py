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

OpenCV does not report AprilTag's decode quality, so this module measures it the way AprilTag defines
it: the tag is sampled cell by cell through its homography; the *hamming* distance is the number of
data bits that differ from the code of the decoded id, the *decision margin* is how far the data cells'
grey levels sit from the black/white threshold (the smaller of the white and the black side's mean).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import Any

import cv2
import numpy as np
import pupil_apriltags

# Families per backend (what each library can decode), in the order the docs list them.
APRILTAG3_FAMILIES = ("tag36h11", "tag25h9", "tag16h5", "tagStandard41h12")
OPENCV_DICTIONARIES = {
    "tag36h11": "DICT_APRILTAG_36h11",
    "tag25h9": "DICT_APRILTAG_25h9",
    "tag16h5": "DICT_APRILTAG_16h5",
}
SUPPORTED_FAMILIES = {"apriltag3": APRILTAG3_FAMILIES, "opencv": tuple(OPENCV_DICTIONARIES)}
APRILTAG3_MAX_HAMMING = 2  # pupil-apriltags registers every family with 2 correctable bits


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
    """pupil-apriltags (AprilTag 3)."""

    name = "apriltag3"

    def __init__(self, family: str, *, decimate: float, threads: int, refine_edges: bool) -> None:
        self.family = family
        self._detector = SafeDetector(
            families=family, nthreads=threads, quad_decimate=decimate, refine_edges=int(refine_edges)
        )

    def detect(self, gray: np.ndarray) -> list[RawTag]:
        out = []
        order = list(pupil_corner_order())
        for d in self._detector.detect(np.ascontiguousarray(gray)):
            corners = np.asarray(d.corners, dtype=np.float64)[order] - 0.5
            out.append(RawTag(int(d.tag_id), corners, int(d.hamming), float(d.decision_margin)))
        return out

    def close(self) -> None:
        self._detector = None


class OpenCvBackend:
    """OpenCV ArUco with the matching DICT_APRILTAG_* dictionary (sub-pixel corner refinement)."""

    name = "opencv"

    def __init__(self, family: str, *, max_hamming: int, refine_edges: bool) -> None:
        self.family = family
        self.dictionary = cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, OPENCV_DICTIONARIES[family]))
        params = cv2.aruco.DetectorParameters()
        params.cornerRefinementMethod = (
            cv2.aruco.CORNER_REFINE_SUBPIX if refine_edges else cv2.aruco.CORNER_REFINE_NONE
        )
        # Let OpenCV correct at least `max_hamming` bits; the measured hamming then filters precisely.
        max_bits = max(1, int(self.dictionary.maxCorrectionBits))
        params.errorCorrectionRate = float(min(1.0, (max_hamming + 0.5) / max_bits))
        # OpenCV's default 0.125 drops a large marker whose quiet zone shows as a second contour
        # (opencv_contrib#2913); the aruco source measured the same fix.
        params.minMarkerDistanceRate = 0.025
        self._detector = cv2.aruco.ArucoDetector(self.dictionary, params)
        n = int(self.dictionary.markerSize)
        self._n = n
        self._codes = {}  # id → expected bits, filled lazily

    def _expected_bits(self, tag_id: int) -> np.ndarray:
        if tag_id not in self._codes:
            row = self.dictionary.bytesList[tag_id : tag_id + 1]
            self._codes[tag_id] = cv2.aruco.Dictionary.getBitsFromByteList(row, self._n).astype(bool)
        return self._codes[tag_id]

    def detect(self, gray: np.ndarray) -> list[RawTag]:
        corners, ids, _ = self._detector.detectMarkers(gray)
        if ids is None:
            return []
        out = []
        for c, i in zip(corners, ids.reshape(-1), strict=True):
            quad = np.asarray(c, dtype=np.float64).reshape(4, 2)
            bits, margin = sample_bits(gray, quad, self._n)
            hamming = int(np.count_nonzero(bits != self._expected_bits(int(i))))
            out.append(RawTag(int(i), quad, hamming, margin))
        return out

    def close(self) -> None:
        self._detector = None


def sample_bits(gray: np.ndarray, corners: np.ndarray, n: int, ppc: int = 8) -> tuple[np.ndarray, float]:
    """(n×n data bits, decision margin) of a square tag whose black border has `corners` (TL TR BR BL).

    The tag plus one quiet-zone cell around it is warped to a grid of (n + 4) cells of `ppc` px; each
    cell's grey level is the mean of its central half. The threshold is midway between the black border
    and the white quiet zone (what AprilTag's decoder models); white = 1, as OpenCV's dictionaries store it.
    """
    cells = n + 4
    side = cells * ppc
    # The black square spans cells 1 … n+3; OpenCV's corners sit on its outer edge.
    lo, hi = ppc - 0.5, (cells - 1) * ppc - 0.5
    dst = np.array([[lo, lo], [hi, lo], [hi, hi], [lo, hi]], dtype=np.float32)
    hom = cv2.getPerspectiveTransform(np.asarray(corners, dtype=np.float32), dst)
    warped = cv2.warpPerspective(gray, hom, (side, side), flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
    q = ppc // 4
    means = warped.reshape(cells, ppc, cells, ppc)[:, q : ppc - q, :, q : ppc - q].mean(axis=(1, 3))
    ring = np.zeros((cells, cells), bool)
    ring[0, :] = ring[-1, :] = ring[:, 0] = ring[:, -1] = True
    border = np.zeros((cells, cells), bool)
    border[1:-1, 1:-1] = True
    border[2:-2, 2:-2] = False
    white, black = float(np.median(means[ring])), float(np.median(means[border]))
    threshold = (white + black) / 2.0
    data = means[2:-2, 2:-2]
    bits = data > threshold
    above, below = data[bits] - threshold, threshold - data[~bits]
    parts = [float(x.mean()) for x in (above, below) if x.size]
    return bits, min(parts) if parts else 0.0
