"""Sub-pixel corners of square markers that stay on the marker: each corner is where two fitted edges meet.

OpenCV's ``CORNER_REFINE_SUBPIX`` (``cv2.cornerSubPix``) looks for a saddle of the grey levels in a small
window round each corner. Blur rounds a corner off and a marker's first data cell sits one module
inside it, so the saddle it converges to can lie inside the marker: on rendered views with 2 px of blur
it put 31 of 1,920 corners more than 2 px from the truth (unrefined: 50; this module: none, with a
median error of 0.07 px against SUBPIX's 0.41), and on real photos it sometimes moved corners 7–8.5 px
into the marker (issue 16). An edge does not move under a
symmetric blur, so this refiner uses the four edges instead (AprilTag's ``refine_edges`` does the same):

1. along each side of the unrefined quad (what ``detectMarkers`` finds without refinement), ``SAMPLES``
   profiles across the edge, from inside the black border out into the white quiet zone, each no
   longer than 0.45 of a module either way so it never reaches the border's inner edge or whatever lies
   beyond the quiet zone;
2. on each profile, the edge is the centroid of its dark → bright gradient (squared, as weights), as
   AprilTag's ``refine_edges`` places it; profiles whose steepest step is weak, or at either end of the
   profile, are left out;
3. one line per side through its edge points (total least squares, refitted once without the points
   more than 3 standard deviations off the first line, σ from their mean absolute deviation), and each
   corner where its two lines meet.

A corner moves at most as far as the unrefined corner can be wrong: ``max(1.5 px, half a module)``.
The unrefined corner is a contour pixel, rarely more than a pixel or so from the true corner; a
refined corner further away than that is not the same corner, and the unrefined one is kept. So are
corners whose sides had too few clear edge points (a marker partly hidden or cut by the image border).

Every profile of a frame's markers is sampled by one ``cv2.remap``; the arithmetic round it is compiled
(numba), because it runs for every marker of every frame, and tracking runs it again on every followed
marker (perception_plugins/marker_bits.py). Written in numpy it cost ~150 µs for one marker, nearly all of it
numpy's per-call overhead on arrays of a few hundred numbers; compiled, ~28 µs (bench: perception). The
compiled loops compute exactly what the numpy expressions did, to the bit (tests/perception/
test_corner_refinement.py holds that numpy definition and checks it): sums are numpy's pairwise sums
(:func:`_pairwise_sum`), and the lines' angles, cosines and sines are left to numpy (:func:`_axes`), whose SIMD
trigonometry differs from the C library's in the last bit.
"""

from __future__ import annotations

import cv2
import numba
import numpy as np

SAMPLES = 20  # profiles per side
STEPS = 13  # grey-level samples per profile
REACH_MODULES = 0.45  # a profile reaches this many modules inside and outside the edge
MIN_REACH_PX = 1.0
MAX_REACH_PX = 5.0  # … and never further than this: the unrefined edge is within a few px of the true one
MIN_SHIFT_PX = 1.5  # a corner may always move this far …
SHIFT_MODULES = 0.5  # … or this many modules, whichever is more
MIN_EDGE_STEP = 4.0  # grey levels per sample: a weaker step is no edge
MIN_SIDE_FRACTION = 1 / 3  # of a side's profiles must find its edge


_T = np.linspace(0.1, 0.9, SAMPLES)  # where the profiles cross a side: away from the corners
_S = np.linspace(-1.0, 1.0, STEPS)  # along a profile, in units of its reach
_NEXT = np.array([1, 2, 3, 0])


def module_size(quads: np.ndarray, cells: int) -> np.ndarray:
    """Mean side (px) of each quad (M×4×2) divided by the cells across the marker (data bits + black border)."""
    d = quads[:, _NEXT] - quads
    return np.sqrt((d * d).sum(axis=2)).mean(axis=1) / float(cells)


def refine_corners(grey: np.ndarray, quads: np.ndarray, cells: int) -> np.ndarray:
    """Refined corners (M×4×2 float64) of the M quads (M×4×2, corners in order round the quad) found in
    `grey` (H×W uint8) for markers `cells` modules across; a corner that cannot be refined within its
    uncertainty is returned unrefined."""
    return refined_corners(grey, quads, cells)[0]


def refined_corners(grey: np.ndarray, quads: np.ndarray, cells: int) -> tuple[np.ndarray, np.ndarray]:
    """:func:`refine_corners`, and which corners (M×4 bool) were refined: the others are returned as given."""
    quads = np.ascontiguousarray(np.asarray(quads, dtype=np.float64).reshape(-1, 4, 2))
    if len(quads) == 0:
        return quads.copy(), np.zeros((0, 4), dtype=bool)
    mapx, mapy, sides = _profile_maps(quads, float(cells), _T, _S)
    profiles = cv2.remap(grey, mapx, mapy, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
    ex, ey, weight, lines = _edge_points(quads, profiles, sides, _T)
    ux, uy = _axes(lines)
    weight, lines = _refit(ex, ey, weight, lines, ux, uy)
    ux, uy = _axes(lines)
    return _meet(quads, sides, weight, lines, ux, uy)


def warm_up() -> None:
    """Compile the refinement (numba; ~3 s the first time on a machine, ~0.3 s from its cache after), so a
    source pays it when it is made, not on the first frame of a running loop."""
    grey = np.zeros((16, 16), dtype=np.uint8)
    refined_corners(grey, np.array([[[4.0, 4.0], [11.0, 4.0], [11.0, 11.0], [4.0, 11.0]]]), 6)


def _axes(lines: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Each side's line direction (cos, sin; M×4 each) from its scatter (:func:`_scatter`): the principal axis
    of the 2×2 scatter matrix. In numpy, not in the compiled loops: numpy's SIMD arctan2, cos and sin differ
    from the C library's (which numba calls) in the last bit, and the corners are to stay numpy's exactly."""
    angle = 0.5 * np.arctan2(lines[..., 2], lines[..., 3])
    return np.cos(angle), np.sin(angle)


@numba.njit(cache=True)
def _pairwise_sum(a: np.ndarray) -> float:  # pragma: no cover - compiled
    """numpy's sum of a contiguous float64 vector, in numpy's order (pairwise: eight running sums, then the
    remainder), so the compiled fit adds exactly as ``ndarray.sum`` did (n ≤ 128, numpy's block)."""
    n = a.shape[0]
    if n < 8:
        res = 0.0
        for i in range(n):
            res += a[i]
        return res
    r0, r1, r2, r3, r4, r5, r6, r7 = a[0], a[1], a[2], a[3], a[4], a[5], a[6], a[7]
    i = 8
    while i < n - n % 8:
        r0 += a[i]
        r1 += a[i + 1]
        r2 += a[i + 2]
        r3 += a[i + 3]
        r4 += a[i + 4]
        r5 += a[i + 5]
        r6 += a[i + 6]
        r7 += a[i + 7]
        i += 8
    res = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
    while i < n:
        res += a[i]
        i += 1
    return res


@numba.njit(cache=True)
def _profile_maps(
    quads: np.ndarray, cells: float, t: np.ndarray, s: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:  # pragma: no cover - compiled
    """Step 1: the sampling maps of every profile (M×(4·SAMPLES·STEPS) float32 x and y: one row per quad,
    profile after profile, the layout cv2.remap samples fastest — 4 µs a quad, against 12 in rows of one
    profile — and never over its 32,767 columns) and each side's geometry (M×4×6: along x, along y, outward
    normal x, y, the marker's reach, its module)."""
    m_count, k_n, s_n = quads.shape[0], t.shape[0], s.shape[0]
    mapx = np.empty((m_count, 4 * k_n * s_n), np.float32)
    mapy = np.empty((m_count, 4 * k_n * s_n), np.float32)
    sides = np.empty((m_count, 4, 6))
    lengths = np.empty(4)
    for m in range(m_count):
        q = quads[m]
        total = 0.0
        for i in range(4):
            j = (i + 1) % 4
            lengths[i] = max(np.hypot(q[j, 0] - q[i, 0], q[j, 1] - q[i, 1]), 1e-9)
            total += lengths[i]
        module = total / 4 / cells
        reach = min(max(REACH_MODULES * module, MIN_REACH_PX), MAX_REACH_PX)
        cx = ((((0.0 + q[0, 0]) + q[1, 0]) + q[2, 0]) + q[3, 0]) / 4
        cy = ((((0.0 + q[0, 1]) + q[1, 1]) + q[2, 1]) + q[3, 1]) / 4
        for i in range(4):
            j = (i + 1) % 4
            ax, ay = q[j, 0] - q[i, 0], q[j, 1] - q[i, 1]
            nx, ny = ay / lengths[i], -ax / lengths[i]
            flip = -1.0 if (q[i, 0] + 0.5 * ax - cx) * nx + (q[i, 1] + 0.5 * ay - cy) * ny < 0 else 1.0
            nx, ny = nx * flip, ny * flip  # outward: into the quiet zone
            sides[m, i, 0], sides[m, i, 1], sides[m, i, 2], sides[m, i, 3] = ax, ay, nx, ny
            sides[m, i, 4], sides[m, i, 5] = reach, module
            for k in range(k_n):
                bx, by = q[i, 0] + t[k] * ax, q[i, 1] + t[k] * ay  # where the profile crosses the side
                first = (i * k_n + k) * s_n
                for p in range(s_n):
                    step = s[p] * reach
                    mapx[m, first + p] = np.float32(bx + step * nx)
                    mapy[m, first + p] = np.float32(by + step * ny)
    return mapx, mapy, sides


@numba.njit(cache=True)
def _scatter(x: np.ndarray, y: np.ndarray, w: np.ndarray) -> tuple[float, float, float, float]:  # pragma: no cover
    """A weighted total-least-squares line through (`x`, `y`): its centroid, and the two arguments of the
    arctan2 that gives twice its angle (:func:`_axes`)."""
    total = max(_pairwise_sum(w), 1e-9)
    mx, my = _pairwise_sum(w * x) / total, _pairwise_sum(w * y) / total
    dx, dy = x - mx, y - my
    wdx = w * dx
    return mx, my, 2.0 * _pairwise_sum(wdx * dy), _pairwise_sum(wdx * dx) - _pairwise_sum(w * dy * dy)


@numba.njit(cache=True)
def _edge_points(
    quads: np.ndarray, profiles: np.ndarray, sides: np.ndarray, t: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:  # pragma: no cover - compiled
    """Step 2 and the first fit of step 3: each profile's edge point (M×4×SAMPLES x, y), its weight (1 where
    the profile's steepest step is strong and inside it), and each side's line through them (M×4×4, as
    :func:`_scatter`). The gradient's centroid is taken in float32, as numpy took it from the uint8 profiles."""
    m_count, k_n = quads.shape[0], t.shape[0]
    s_n = profiles.shape[1] // (4 * k_n)
    ex, ey, w = np.empty((m_count, 4, k_n)), np.empty((m_count, 4, k_n)), np.empty((m_count, 4, k_n))
    lines = np.empty((m_count, 4, 4))
    scale = np.float32(2.0 / (s_n - 1))
    for m in range(m_count):
        for i in range(4):
            ax, ay, nx, ny, reach = sides[m, i, 0], sides[m, i, 1], sides[m, i, 2], sides[m, i, 3], sides[m, i, 4]
            for k in range(k_n):
                first = (i * k_n + k) * s_n
                best, peak = np.float32(-1e30), 0
                num, den = np.float32(0.0), np.float32(0.0)
                for p in range(s_n - 1):
                    d = np.float32(profiles[m, first + p + 1]) - np.float32(profiles[m, first + p])  # dark → bright
                    if d > best:
                        best, peak = d, p
                    if d > 0:
                        num += d * d * np.float32(p + 0.5)
                        den += d * d
                where = num / max(den, np.float32(1e-9))
                position = reach * np.float64(where * scale - np.float32(1.0))
                ex[m, i, k] = quads[m, i, 0] + t[k] * ax + position * nx
                ey[m, i, k] = quads[m, i, 1] + t[k] * ay + position * ny
                w[m, i, k] = 1.0 if 0 < peak < s_n - 2 and best >= MIN_EDGE_STEP else 0.0
            lines[m, i, 0], lines[m, i, 1], lines[m, i, 2], lines[m, i, 3] = _scatter(ex[m, i], ey[m, i], w[m, i])
    return ex, ey, w, lines


@numba.njit(cache=True)
def _refit(
    ex: np.ndarray, ey: np.ndarray, w: np.ndarray, lines: np.ndarray, ux: np.ndarray, uy: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:  # pragma: no cover - compiled
    """Step 3's refit: each side's points more than 3σ off its first line dropped (σ from their mean absolute
    deviation), and the line fitted again."""
    m_count, k_n = ex.shape[0], ex.shape[2]
    kept, out = np.empty_like(w), np.empty_like(lines)
    for m in range(m_count):
        for i in range(4):
            residual = np.abs((ex[m, i] - lines[m, i, 0]) * uy[m, i] - (ey[m, i] - lines[m, i, 1]) * ux[m, i])
            count = max(_pairwise_sum(w[m, i]), 1.0)
            sigma = max(0.25, 1.25 * _pairwise_sum(w[m, i] * residual) / count)
            for k in range(k_n):
                kept[m, i, k] = w[m, i, k] * (1.0 if residual[k] <= 3.0 * sigma else 0.0)
            out[m, i, 0], out[m, i, 1], out[m, i, 2], out[m, i, 3] = _scatter(ex[m, i], ey[m, i], kept[m, i])
    return kept, out


@numba.njit(cache=True)
def _meet(
    quads: np.ndarray, sides: np.ndarray, w: np.ndarray, lines: np.ndarray, ux: np.ndarray, uy: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:  # pragma: no cover - compiled
    """The corners: corner i where side i−1 (which ends at it) meets side i (which starts at it), kept where
    both sides had enough edge points, they cross clearly, and the corner moved within its uncertainty."""
    m_count, k_n = quads.shape[0], w.shape[2]
    out, ok = quads.copy(), np.zeros((m_count, 4), np.bool_)
    for m in range(m_count):
        limit = max(MIN_SHIFT_PX, SHIFT_MODULES * sides[m, 0, 5])
        for i in range(4):
            p = (i + 3) % 4
            px, py, vx, vy = lines[m, p, 0], lines[m, p, 1], ux[m, p], uy[m, p]
            cross = vx * uy[m, i] - vy * ux[m, i]
            t = ((lines[m, i, 0] - px) * uy[m, i] - (lines[m, i, 1] - py) * ux[m, i]) / (
                cross if abs(cross) > 1e-3 else 1.0
            )
            x, y = px + t * vx, py + t * vy
            sx, sy = x - quads[m, i, 0], y - quads[m, i, 1]
            enough = min(_pairwise_sum(w[m, i]), _pairwise_sum(w[m, p])) >= MIN_SIDE_FRACTION * k_n
            near = np.isfinite(x) and np.isfinite(y) and sx * sx + sy * sy <= limit * limit
            if enough and abs(cross) > 0.05 and near:
                out[m, i, 0], out[m, i, 1] = x, y
                ok[m, i] = True
    return out, ok


def _within(refined: np.ndarray, quads: np.ndarray, module: np.ndarray) -> np.ndarray:
    """Which `refined` corners (M×4) lie within ``max(1.5 px, half a module)`` of the unrefined `quads`
    (M×4×2, `module` px per module for each), and are finite."""
    shift = refined - quads
    limit = np.maximum(MIN_SHIFT_PX, SHIFT_MODULES * np.asarray(module, dtype=np.float64))[:, None]
    return np.isfinite(refined).all(axis=2) & ((shift * shift).sum(axis=2) <= limit * limit)


def within_uncertainty(refined: np.ndarray, quads: np.ndarray, module: np.ndarray) -> np.ndarray:
    """`refined` corners where they lie within ``max(1.5 px, half a module)`` of the unrefined `quads`
    (M×4×2, `module` px per module for each), the unrefined corner elsewhere (and where not finite)."""
    return np.where(_within(refined, quads, module)[..., None], refined, quads)


_SUBPIX_CRITERIA = (cv2.TERM_CRITERIA_MAX_ITER | cv2.TERM_CRITERIA_EPS, 30, 0.1)  # OpenCV's aruco defaults


def subpix_corners(grey: np.ndarray, quads: np.ndarray, cells: int) -> np.ndarray:
    """OpenCV's CORNER_REFINE_SUBPIX on the unrefined `quads` (the window it uses: 0.3 of a module, at
    most 5 px), each corner kept only within the same bound as :func:`refine_corners`'."""
    quads = np.asarray(quads, dtype=np.float64).reshape(-1, 4, 2)
    module = module_size(quads, cells)
    out = np.empty_like(quads)
    for i, (quad, m) in enumerate(zip(quads, module.tolist(), strict=True)):
        win = int(min(5, max(1, round(0.3 * m))))
        pts = quad.astype(np.float32).reshape(4, 1, 2)
        out[i] = cv2.cornerSubPix(grey, pts, (win, win), (-1, -1), _SUBPIX_CRITERIA).reshape(4, 2)
    return within_uncertainty(out, quads, module)
