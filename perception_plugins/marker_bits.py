"""Whether a quad still holds the marker it held: its cells read where the quad says they are (issue 34).

Tracking follows a marker from frame to frame by refining its predicted quad onto the edges in the new frame
(marker_tracking._follow). A refined quad is only the marker's if the marker's own pattern is inside it, so
each is checked here the way a detector decodes one — but for one known id, at the rotation it had:

* each cell is the mean grey of a few points in its central half (a cell's edge is where blur and a quad a
  fraction of a pixel off mix it with its neighbour);
* black is the median of the border's cells, white the quiet zone's ring half a module outside; a cell is
  white above half-way between;
* the quad holds the marker when black and white differ by MIN_CONTRAST grey levels, no data cell differs
  from the id's pattern, and at most MAX_BORDER_ERRORS border cells are white;
* and when each of its sides lies on the marker's edge: read BAND_PX either side of it (at most
  BAND_MODULES), black inside and white outside at BAND_FRACTION of the points along it. The cells alone
  pass a quad up to half a module off, and on a 190 px marker that moved 14 px between two frames, the
  refiner's profiles (5 px either way) never reached the true edge and fitted the noise of the border's
  black instead: the quad came back where it was predicted, 14 px off, with every cell still read right.

Stricter than OpenCV's decoding, which corrects bit errors and tolerates a third of the border: a quad
that fails is not lost, it is detected again as before (marker_tracking.detect_tracked), so a false "no"
costs a window pass and a false "yes" would cost a wrong pose.
"""

from __future__ import annotations

from collections.abc import Callable

import cv2
import numba
import numpy as np

from mission.perception_plugins.corner_refinement import refine_corners, refined_corners

SUBSAMPLES = 3  # points across a cell, each way, in its central half
MIN_CONTRAST = 20.0  # grey levels between the border's black and the quiet zone's white
MAX_BORDER_ERRORS = 2  # border cells read white that still pass (glare, a corner clipped by blur)
SETTLED_PX = 0.5  # a followed quad whose corners moved less than this on refining needs no second pass
RING_MODULES = 0.5  # the quiet zone is read this far outside the marker's outline
BAND_PX = 1.5  # each side is read this far inside and outside it …
BAND_MODULES = 0.35  # … or this many modules where that is less (a small marker's black border)
BAND_POINTS = 8  # points along each side
BAND_FRACTION = 0.75  # of them must read black inside and white outside

Pattern = Callable[[int], np.ndarray]  # id → its cells (cells × cells bool, white True, border included)


def _cell_points(cells: int) -> np.ndarray:
    """Sample points (cells²·SUBSAMPLES², 2) in marker units (0 … cells each way), cell by cell, row-major."""
    offsets = (np.arange(SUBSAMPLES) + 0.5) / SUBSAMPLES * 0.5 + 0.25  # the central half of a cell
    u = (np.arange(cells)[:, None] + offsets[None, :]).reshape(-1)  # cells·S
    ys, xs = np.meshgrid(u, u, indexing="ij")  # row-major over (cell row, sub-row) × (cell col, sub-col)
    pts = np.stack([xs, ys], axis=-1).reshape(cells, SUBSAMPLES, cells, SUBSAMPLES, 2)
    return pts.transpose(0, 2, 1, 3, 4).reshape(-1, 2)


def _side_points(cells: int) -> tuple[np.ndarray, np.ndarray]:
    """Points (4·BAND_POINTS, 2) in marker units along the four sides, and the inward normal (same shape) at each."""
    t = np.linspace(0.15, 0.85, BAND_POINTS) * cells
    lo, hi = np.zeros(BAND_POINTS), np.full(BAND_POINTS, float(cells))
    pts = np.concatenate([np.stack([t, lo], 1), np.stack([hi, t], 1), np.stack([t, hi], 1), np.stack([lo, t], 1)])
    inward = np.repeat(np.array([[0.0, 1.0], [-1.0, 0.0], [0.0, -1.0], [1.0, 0.0]]), BAND_POINTS, axis=0)
    return pts, inward


def _ring_points(cells: int) -> np.ndarray:
    """Points (4·cells, 2) in marker units round the outline, RING_MODULES outside it."""
    t = np.arange(cells) + 0.5
    lo, hi = np.full(cells, -RING_MODULES), np.full(cells, cells + RING_MODULES)
    return np.concatenate(
        [np.stack([t, lo], 1), np.stack([hi, t], 1), np.stack([t, hi], 1), np.stack([lo, t], 1)], axis=0
    )


class PatternCheck:
    """Checks quads against the patterns of the ids they are expected to hold, for markers `cells` modules
    across (data bits + the border), whose pattern for an id is `pattern(id)`."""

    def __init__(self, cells: int, pattern: Pattern) -> None:
        self.cells = cells
        self._pattern = pattern
        self._patterns: dict[int, np.ndarray] = {}
        self._points = np.concatenate([_cell_points(cells), _ring_points(cells)])
        self._sides, self._inward = _side_points(cells)
        self._border = np.ones((cells, cells), dtype=bool)
        self._border[1:-1, 1:-1] = False
        self._warm_up()

    def _warm_up(self) -> None:
        """Compile the check (numba) now, not on a running loop's first frame: a quad on a blank image."""
        side = 2.0 * self.cells
        quad = np.array([[[4.0, 4.0], [4.0 + side, 4.0], [4.0 + side, 4.0 + side], [4.0, 4.0 + side]]])
        self(np.zeros((8 + int(side), 8 + int(side)), np.uint8), quad, np.zeros(1, dtype=np.int64))

    def pattern(self, marker_id: int) -> np.ndarray:
        if marker_id not in self._patterns:
            self._patterns[marker_id] = np.asarray(self._pattern(marker_id), dtype=bool)
        return self._patterns[marker_id]

    def __call__(self, grey: np.ndarray, quads: np.ndarray, ids: np.ndarray) -> np.ndarray:
        """Which of the M quads (M×4×2 px, corners in the detector's order) hold their id's pattern (M bool).

        Every point of every quad is sampled by one ``cv2.remap``; the arithmetic round it is compiled (numba),
        as the corner refinement's is (perception_plugins/corner_refinement.py): it runs on every followed
        marker of every frame, and in numpy it was ~110 µs for one marker, nearly all per-call overhead."""
        quads = np.ascontiguousarray(np.asarray(quads, dtype=np.float64).reshape(-1, 4, 2))
        if len(quads) == 0:
            return np.zeros(0, dtype=bool)
        c = self.cells
        unit = np.array([[0, 0], [c, 0], [c, c], [0, c]], dtype=np.float32)
        homs = np.stack([cv2.getPerspectiveTransform(unit, q.astype(np.float32)) for q in quads])  # M×3×3
        x, y = _sample_maps(quads, homs, float(c), self._points, self._sides, self._inward)
        values = cv2.remap(grey, x, y, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
        patterns = np.stack([self.pattern(int(i)) for i in ids])
        return _holds(values, patterns, self._border, c, len(self._points))


@numba.njit(cache=True)
def _sample_maps(
    quads: np.ndarray, homs: np.ndarray, cells: float, points: np.ndarray, sides: np.ndarray, inward: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:  # pragma: no cover - compiled
    """Where to sample each quad (M×P float32 x and y, a row per quad: cv2.remap takes no row of 32,767 points or
    more, which one row for all 33 AprilTag 36h11 tags' would be): the cell and ring `points`, then the band
    across each side, BAND_PX inside and outside it (at most BAND_MODULES), through each quad's homography."""
    m_count, n_fixed, n_side = quads.shape[0], points.shape[0], sides.shape[0]
    per = n_fixed + 2 * n_side
    x, y = np.empty((m_count, per), np.float32), np.empty((m_count, per), np.float32)
    for m in range(m_count):
        total = 0.0
        for i in range(4):
            j = (i + 1) % 4
            dx, dy = quads[m, j, 0] - quads[m, i, 0], quads[m, j, 1] - quads[m, i, 1]
            total += np.sqrt(0.0 + dx * dx + dy * dy)
        module = total / 4 / cells
        across = min(BAND_PX / max(module, 1e-6), BAND_MODULES)
        h = homs[m]
        for k in range(per):
            if k < n_fixed:
                u, v = points[k, 0], points[k, 1]
            else:
                j = (k - n_fixed) % n_side
                du, dv = across * inward[j, 0], across * inward[j, 1]
                if k - n_fixed < n_side:  # inside the side, then outside it
                    u, v = sides[j, 0] + du, sides[j, 1] + dv
                else:
                    u, v = sides[j, 0] - du, sides[j, 1] - dv
            w = h[2, 0] * u + h[2, 1] * v + h[2, 2]
            x[m, k] = np.float32((h[0, 0] * u + h[0, 1] * v + h[0, 2]) / w)
            y[m, k] = np.float32((h[1, 0] * u + h[1, 1] * v + h[1, 2]) / w)
    return x, y


@numba.njit(cache=True)
def _holds(
    values: np.ndarray, patterns: np.ndarray, border: np.ndarray, cells: int, n_fixed: int
) -> np.ndarray:  # pragma: no cover - compiled
    """The check itself, on the sampled grey levels (M×P, as :func:`_sample_maps` laid them out): see the module
    for each condition."""
    m_count = patterns.shape[0]
    sub = SUBSAMPLES * SUBSAMPLES
    n_border = 4 * cells - 4
    out = np.zeros(m_count, np.bool_)
    cell = np.empty((cells, cells))
    edge = np.empty(n_border)
    for m in range(m_count):
        n_edge = 0
        for r in range(cells):
            for q in range(cells):
                first = (r * cells + q) * sub
                total = 0.0
                for k in range(sub):
                    total += values[m, first + k]
                cell[r, q] = total / sub
                if border[r, q]:
                    edge[n_edge] = cell[r, q]
                    n_edge += 1
        ring = 0.0
        for k in range(cells * cells * sub, n_fixed):
            ring += values[m, k]
        white = ring / (n_fixed - cells * cells * sub)
        ordered = np.sort(edge)
        half = n_border // 2
        black = ordered[half] if n_border % 2 else (ordered[half - 1] + ordered[half]) / 2
        mid = (black + white) / 2
        if not white - black >= MIN_CONTRAST:
            continue
        on_edges = True
        for side in range(4):
            good = 0
            for k in range(BAND_POINTS):
                inside = values[m, n_fixed + side * BAND_POINTS + k]
                outside = values[m, n_fixed + 4 * BAND_POINTS + side * BAND_POINTS + k]
                good += inside < mid and outside > mid
            on_edges = on_edges and good / BAND_POINTS >= BAND_FRACTION
        border_errors = 0
        data_error = False
        for r in range(cells):
            for q in range(cells):
                if (cell[r, q] > mid) != patterns[m, r, q]:
                    if border[r, q]:
                        border_errors += 1
                    else:
                        data_error = True
        out[m] = on_edges and not data_error and border_errors <= MAX_BORDER_ERRORS
    return out


def aruco_pattern(dictionary: cv2.aruco.Dictionary) -> Pattern:
    """An OpenCV dictionary's pattern for an id, as its detector reads it (the corners' order: top-left first)."""
    cells = int(dictionary.markerSize) + 2
    return lambda marker_id: cv2.aruco.generateImageMarker(dictionary, marker_id, cells, borderBits=1) > 127


def follow_quads(
    grey: np.ndarray, quads: np.ndarray, ids: np.ndarray, cells: int, check: PatternCheck
) -> list[np.ndarray | None]:
    """Tracked markers' predicted quads (N×4×2) refined onto this frame's edges, each kept where all four
    corners refined and `check` finds its id's pattern and edges in it (marker_tracking._follow), else None.

    The corners come back final. Refined from a prediction a pixel or more off, a corner is where the
    profiles laid across the predicted edges put it; once more from there they are centred on the true edge
    (rendered missions: corners p95 0.898 px with one pass, 0.858 with two, 0.827 with tracking off). A quad
    whose corners moved less than SETTLED_PX was predicted that well already, and is not refined again."""
    refined, ok = refined_corners(grey, quads, cells)
    held = ok.all(axis=1)
    held[held] = check(grey, refined[held], ids[held])
    again = held & (np.abs(refined - quads).max(axis=(1, 2)) >= SETTLED_PX)
    if again.any():
        refined[again] = refine_corners(grey, refined[again], cells)
    return [refined[k] if held[k] else None for k in range(len(ids))]
