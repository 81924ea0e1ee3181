"""OpenCV's ArUco detector, made to choose the marker's own quad (issue 34): shared by the `aruco` source and
the OpenCV backend of the `apriltag` source.

OpenCV groups candidate quads closer together than ``minMarkerDistanceRate`` × their perimeter and keeps one
of each group. Two settings each fail somewhere:

* **OpenCV's default, 0.125**, keeps the marker's outer square where a lower rate also keeps the inner edge
  of its black border as a second quad. But a large marker (~80 px and more) whose white quiet zone shows as a
  contour of its own can lose its group to that contour, which does not decode, and is dropped
  (opencv_contrib#2913): 1–5 % of views of such markers in our renders, none under 60 px.
* **0.025** keeps those large markers, and reports an ~85 px marker by the inner edge of its border instead
  of its outline: corners 6–9 px inside the true ones (p95 9.0 px on a rendered sequence whose truth is
  exact, against 1.6 px at the default), a pose 17 % too far, and a ChArUco photo's worst corner at 9.8 px
  where raw OpenCV is within 1.8 px.

So :class:`QuadDetector` takes OpenCV's default quads, and then looks for what only the default drops: a
*rescue pass* on every third pixel, at 0.025, keeping only markers of at least :data:`RESCUE_MIN_SIDE_PX`
(the only ones the default loses), with the markers the default found filled flat: ~5 % of the full pass. A
marker it finds that the default did not is detected again at full resolution in a window round it, and moved
out to its outline (:func:`outline`): at 0.025 OpenCV may report it by the inner edge of its border.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import cv2
import numpy as np

from mission.perception_plugins.marker_quads import Box, one_quad_per_marker, side

RESCUE_SCALE = 3  # the rescue pass looks at 1 / RESCUE_SCALE of the image's width and height
RESCUE_MIN_SIDE_PX = 60.0  # markers smaller than this (full-resolution px) are never dropped by the default
RESCUE_RATE = 0.025  # minMarkerDistanceRate of the rescue pass and its windows (what #2913 needs)
RESCUE_THRESHOLD_PX = 7  # the rescue pass's one adaptive-threshold window (px of the sampled image)
WINDOW_MARGIN = 0.5  # a rescued marker is re-detected in a window this many sides beyond its quad

WINDOW_SIDE_PX = 64.0  # a tracking window is searched scaled so its expected marker is at most this wide
WINDOW_THRESHOLD_PX = 13  # and thresholded with this one window (OpenCV's default tries 3, 13 and 23 px)

SEARCH_SIDE_PX = 480  # tracking's search pass looks at the frame sampled down to about this on its longer side
SEARCH_THRESHOLD_PX = 7  # with this one adaptive-threshold window
SEARCH_MIN_SIDE_PX = 12.0  # and keeps markers from this side (sampled px): 36 px at 1280×720, 48 at 1920×1080
SEARCH_BORDER_PX = 1  # and this close to the sampled image's edge (OpenCV's default, 3, is 6–12 px of the frame)

Configure = Callable[[Any], None]  # sets a DetectorParameters' refinement and error-correction fields


def _detector(
    dictionary: cv2.aruco.Dictionary,
    configure: Configure,
    distance_rate: float | None = None,
    threshold_px: int | None = None,
) -> tuple[Any, Any]:
    """An ArucoDetector and its DetectorParameters (kept, to change its perimeter floor): `configure`'s
    fields, then `distance_rate` as minMarkerDistanceRate and `threshold_px` as its one adaptive-threshold
    window where given."""
    params = cv2.aruco.DetectorParameters()
    configure(params)
    if distance_rate is not None:
        params.minMarkerDistanceRate = distance_rate
    if threshold_px is not None:
        params.adaptiveThreshWinSizeMin = params.adaptiveThreshWinSizeMax = threshold_px
    return cv2.aruco.ArucoDetector(dictionary, params), params


def _as_arrays(corners: Any, ids: Any) -> tuple[np.ndarray, np.ndarray]:
    if ids is None or len(ids) == 0:
        return np.zeros((0, 4, 2)), np.zeros(0, dtype=np.int64)
    return np.asarray(corners, dtype=np.float64).reshape(-1, 4, 2), np.asarray(ids, dtype=np.int64).reshape(-1)


class QuadDetector:
    """(grey image, minimum marker perimeter rate or None for OpenCV's) → (N×4×2 float64 corners, N ids), with
    one quad per marker and that quad the marker's outline (see the module).

    The perimeter rate is what a tracking mosaic of windows sets (marker_tracking.py), and there the rescue
    pass is skipped: a window holds markers it expects, and one the default drops is missed there, which sends
    the frame to the full-frame detection, rescue pass included (the pass cost ~10 % of a window frame).
    ``rescues`` counts the markers the rescue pass added, for the benches.
    """

    def __init__(self, dictionary: cv2.aruco.Dictionary, configure: Configure) -> None:
        self._detector, self._params = _detector(dictionary, configure)
        self._default_rate = float(self._params.minMarkerPerimeterRate)
        self._rescue, self._rescue_params = _detector(dictionary, configure, RESCUE_RATE)
        # The sampled pass thresholds with one window (OpenCV's default tries 3, 13 and 23 px): a marker of
        # RESCUE_MIN_SIDE_PX or more has cells of 3+ px there, and one pass costs a third as much.
        self._small, self._small_params = _detector(dictionary, configure, RESCUE_RATE, RESCUE_THRESHOLD_PX)
        self._window, self._window_params = _detector(dictionary, configure, threshold_px=WINDOW_THRESHOLD_PX)
        self._search, self._search_params = _detector(dictionary, configure, threshold_px=SEARCH_THRESHOLD_PX)
        # OpenCV keeps quads minDistanceToBorder (3) px from the image's edge: 3 sampled px are 6–12 of the
        # frame's, so a marker coming into view within that of the edge, which the full frame finds, was left
        # to the next full-frame pass. The search only says where to look; the full-resolution window decides.
        self._search_params.minDistanceToBorder = SEARCH_BORDER_PX
        self._search.setDetectorParameters(self._search_params)
        self._cells = int(dictionary.markerSize) + 2  # data bits + the black border, in modules
        self.rescues = 0

    def __call__(self, grey: np.ndarray, min_perimeter_rate: float | None = None) -> tuple[np.ndarray, np.ndarray]:
        rate = self._rate(min_perimeter_rate)
        quads, ids = self._detect(self._detector, self._params, grey, rate)
        if min_perimeter_rate is not None:
            return quads, ids
        rescued_quads, rescued_ids = self._rescue_pass(grey, rate, quads)
        extra = [k for k in range(len(rescued_ids)) if not _already_found(rescued_quads[k], rescued_ids[k], quads, ids)]
        if not extra:
            return quads, ids
        add_quads, add_ids = [], []
        for k in extra:
            found = self._full_resolution(grey, rescued_quads[k], int(rescued_ids[k]))
            if found is not None:
                add_quads.append(found)
                add_ids.append(int(rescued_ids[k]))
        if not add_ids:
            return quads, ids
        self.rescues += len(add_ids)
        return np.concatenate([quads, np.stack(add_quads)]), np.concatenate([ids, np.array(add_ids, dtype=np.int64)])

    def window(self, grey: np.ndarray, min_perimeter_rate: float) -> tuple[np.ndarray, np.ndarray]:
        """The markers in tracking windows scaled so their marker is WINDOW_SIDE_PX wide (marker_tracking):
        one threshold window, and no rescue pass (a marker lost there to #2913 is recovered by `recover`). The
        quads are ~0.5 / scale px off, for a refiner at full resolution to finish."""
        return self._detect(self._window, self._window_params, grey, min_perimeter_rate)

    def recover(self, grey: np.ndarray, min_perimeter_rate: float | None) -> tuple[np.ndarray, np.ndarray]:
        """The markers in one tracking window where a tracked marker was missed, read as the rescue pass reads
        them: at RESCUE_RATE, each quad moved out to its outline. On a dark floor the sim's target, shrunk to
        ~70 px in its window, lost its group to its white quiet zone's contour (#2913) on 45 of 452 frames of a
        follow_occlusion run, each of which then cost a full-frame pass."""
        quads, ids = self._detect(self._rescue, self._rescue_params, grey, self._rate(min_perimeter_rate))
        return np.array([outline(grey, q, self._cells) for q in quads]).reshape(-1, 4, 2), ids

    def search(self, grey: np.ndarray, skip: Sequence[Box] = (), finer: bool = False) -> tuple[np.ndarray, np.ndarray]:
        """Tracking's search pass (marker_tracking.detect_tracked): the markers in the whole frame sampled down
        (search_step; one step finer with `finer`) with one threshold window, in the frame's pixels — for
        finding markers that came into view, not for their corners (they are detected again at full
        resolution). The `skip` boxes (x0, y0, x1, y1 frame px: windows searched already) are filled flat, each
        with its own mean, in the sampled image: the pass then spends nothing on the markers found there (a
        marker costs it ~0.1 ms, a flat box one candidate), and filling the sampled image costs a ninth of
        filling a copy of the frame."""
        step = max(1, search_step(grey) - 1) if finer else search_step(grey)
        small = sampled(grey, step)
        for x0, y0, x1, y1 in skip:
            region = small[_first(y0, step) : _first(y1, step), _first(x0, step) : _first(x1, step)]
            if region.size:
                region[...] = int(region[::2, ::2].mean())
        rate = 4 * SEARCH_MIN_SIDE_PX / max(small.shape)  # no smaller candidate: noise contours cost most
        quads, ids = self._detect(self._search, self._search_params, small, rate)
        return quads * step + step // 2, ids

    def _rate(self, min_perimeter_rate: float | None) -> float:
        """The perimeter rate to detect at: OpenCV's default for a frame (None), else a tracking window's."""
        return self._default_rate if min_perimeter_rate is None else float(min_perimeter_rate)

    @staticmethod
    def _detect(detector: Any, params: Any, grey: np.ndarray, rate: float) -> tuple[np.ndarray, np.ndarray]:
        if rate != params.minMarkerPerimeterRate:
            params.minMarkerPerimeterRate = rate
            detector.setDetectorParameters(params)
        corners, ids, _ = detector.detectMarkers(grey)
        quads, ids = _as_arrays(corners, ids)
        if len(ids) > 1:
            keep = one_quad_per_marker(quads, ids)
            quads, ids = quads[keep], ids[keep]
        return quads, ids

    def _rescue_pass(self, grey: np.ndarray, rate: float, found: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Markers of at least RESCUE_MIN_SIDE_PX at 1/RESCUE_SCALE resolution, at RESCUE_RATE, in full-res px.
        The markers the default `found` (N×4×2) are filled flat first: decoding them again would cost the
        pass more than its pixels do."""
        h, w = grey.shape[:2]
        longest = max(h, w)
        if longest * 0.9 < 4 * RESCUE_MIN_SIDE_PX:  # no marker that large fits: nothing the default can drop
            return _as_arrays(None, None)
        small = sampled(grey, RESCUE_SCALE)
        for quad in found:
            lo, hi = quad.min(axis=0), quad.max(axis=0)
            x0, y0 = np.maximum((lo - 0.25 * (hi - lo)) // RESCUE_SCALE, 0).astype(int)
            x1, y1 = ((hi + 0.25 * (hi - lo)) // RESCUE_SCALE + 1).astype(int)
            region = small[y0:y1, x0:x1]
            if region.size:
                region[...] = int(region.mean())
        min_rate = max(rate, 4 * RESCUE_MIN_SIDE_PX / longest)  # a perimeter rate is scale-free
        quads, ids = self._detect(self._small, self._small_params, small, min_rate)
        return quads * RESCUE_SCALE + RESCUE_SCALE // 2, ids

    def _full_resolution(self, grey: np.ndarray, quad: np.ndarray, marker_id: int) -> np.ndarray | None:
        """The quad of `marker_id` near `quad`, detected again at full resolution in a window round it."""
        h, w = grey.shape[:2]
        reach = WINDOW_MARGIN * side(quad)
        lo, hi = quad.min(axis=0) - reach, quad.max(axis=0) + reach
        x0, y0 = max(0, int(np.floor(lo[0]))), max(0, int(np.floor(lo[1])))
        x1, y1 = min(w, int(np.ceil(hi[0]))), min(h, int(np.ceil(hi[1])))
        window = grey[y0:y1, x0:x1]
        rate = 0.5 * 4 * side(quad) / max(x1 - x0, y1 - y0, 1)  # half the rescued marker's perimeter
        quads, ids = self._detect(self._rescue, self._rescue_params, window, rate)
        quads = quads + np.array([x0, y0], dtype=np.float64)
        best = None
        for q, i in zip(quads, ids, strict=True):
            offset = float(np.linalg.norm(q.mean(axis=0) - quad.mean(axis=0)))
            if i == marker_id and offset < 0.25 * side(quad) and (best is None or offset < best[0]):
                best = (offset, q)
        return None if best is None else outline(grey, best[1], self._cells)


def _already_found(quad: np.ndarray, marker_id: int, quads: np.ndarray, ids: np.ndarray) -> bool:
    centre, reach = quad.mean(axis=0), 0.5 * side(quad)
    near = [np.linalg.norm(q.mean(axis=0) - centre) < reach for q in quads]
    return any(i == marker_id and close for i, close in zip(ids, near, strict=True))


OUTLINE_GROW = np.arange(-0.6, 1.001, 0.02)  # modules: squares grown this far from a quad are read
PLATEAU = 0.9  # squares scoring this fraction of the best are on its plateau
_ALONG = np.linspace(0.1, 0.9, 17)  # where along each side the outline's contrast is sampled
_ACROSS = 0.3  # modules either side of a candidate outline where white (outside) and black (inside) are read


def outline(grey: np.ndarray, quad: np.ndarray, cells: int) -> np.ndarray:
    """`quad` moved to its marker's outline: of the squares grown from it by OUTLINE_GROW modules (in the
    marker's own plane, through the quad's homography), the one with the most white outside and black inside.

    A quad at 0.025 may be the inner edge of the black border, ~0.4 module inside the outline; the outline is
    the only nearby square with the quiet zone's white outside and the border's black inside (the border's
    inner edge has data cells inside, the quiet zone's edge white inside, both beyond the searched range's
    contrast). Exact under perspective, since the growth is in the marker's plane."""
    unit = np.array([[0, 0], [cells, 0], [cells, cells], [0, cells]], dtype=np.float64)
    hom = cv2.getPerspectiveTransform(unit.astype(np.float32), np.asarray(quad, dtype=np.float32))
    scores = _outline_contrasts(grey, hom, cells)
    if not np.isfinite(scores).any():
        return np.asarray(quad, dtype=np.float64)
    # Reading ±_ACROSS either side, every square within ±_ACROSS of the outline scores alike: the outline is
    # the middle of the plateau round the best score, not its (noise-chosen) peak.
    top = int(np.argmax(scores))
    lo = hi = top
    while lo > 0 and scores[lo - 1] >= PLATEAU * scores[top]:
        lo -= 1
    while hi < len(scores) - 1 and scores[hi + 1] >= PLATEAU * scores[top]:
        hi += 1
    best_grow = float(OUTLINE_GROW[lo] + OUTLINE_GROW[hi]) / 2
    grown = np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]], dtype=np.float64) * best_grow + unit
    return cv2.perspectiveTransform(grown[None].astype(np.float64), hom)[0]


def _outline_contrasts(grey: np.ndarray, hom: np.ndarray, cells: int) -> np.ndarray:
    """For each growth in OUTLINE_GROW: the mean grey just outside the square grown that many modules, minus just
    inside it (−inf where the square leaves the image: it cannot be read, so it is not chosen). Every growth's
    points go through one transform and one lookup (per growth, the Python calls cost ~5 ms a marker)."""
    h, w = grey.shape[:2]
    lo, hi = -OUTLINE_GROW[:, None], cells + OUTLINE_GROW[:, None]  # G×1
    t = lo + (hi - lo) * _ALONG[None, :]  # G×S: positions along each side

    def sides(inset: float) -> np.ndarray:  # G×4S×2: the four sides of each square, `inset` modules inside it
        a, b = np.broadcast_to(lo + inset, t.shape), np.broadcast_to(hi - inset, t.shape)
        return np.concatenate(
            [np.stack([t, a], -1), np.stack([b, t], -1), np.stack([t, b], -1), np.stack([a, t], -1)], axis=1
        )

    pts = np.concatenate([sides(_ACROSS), sides(-_ACROSS)], axis=1)  # G×8S×2: inside, then outside
    shape = pts.shape
    pts = cv2.perspectiveTransform(pts.reshape(1, -1, 2), hom)[0].reshape(shape)
    off = (pts < 0).any(axis=(1, 2)) | (pts[..., 0] > w - 1).any(axis=1) | (pts[..., 1] > h - 1).any(axis=1)
    values = _bilinear(grey, pts.reshape(-1, 2)).reshape(shape[:2])
    half = shape[1] // 2
    scores = values[:, half:].mean(axis=1) - values[:, :half].mean(axis=1)
    scores[off] = -np.inf
    return scores


def _bilinear(grey: np.ndarray, pts: np.ndarray) -> np.ndarray:
    x = pts[:, 0].astype(np.float32).reshape(1, -1)
    y = pts[:, 1].astype(np.float32).reshape(1, -1)
    return cv2.remap(grey, x, y, cv2.INTER_LINEAR).astype(np.float64).reshape(-1)


def search_step(grey: np.ndarray) -> int:
    """Every how many pixels the search pass samples `grey`: about SEARCH_SIDE_PX on its longer side, at least
    every second pixel (so a 640×480 frame is searched at 320×240)."""
    return max(2, round(max(grey.shape[:2]) / SEARCH_SIDE_PX))


def _first(x: int, step: int) -> int:
    """The first sampled pixel at or right of frame pixel `x` (sampled pixel u is pixel step·u + step // 2)."""
    return max(0, -(-(x - step // 2) // step))


def sampled(grey: np.ndarray, step: int) -> np.ndarray:
    """Every `step`-th pixel of `grey` (sampled pixel u is pixel step·u + step // 2): cheaper than a resize,
    which costs more than the detection it feeds."""
    return np.ascontiguousarray(grey[step // 2 :: step, step // 2 :: step])
