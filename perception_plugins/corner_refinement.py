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

Everything is computed for all markers of a frame at once (one ``cv2.remap`` for every profile), so the
refinement costs a fraction of the detection it follows (bench: perception).
"""

from __future__ import annotations

import cv2
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
_CENTRES = np.arange(STEPS - 1, dtype=np.float32) + 0.5  # where each gradient sample sits on the profile
_NEXT = np.array([1, 2, 3, 0])
_PREV = np.array([3, 0, 1, 2])


def module_size(quads: np.ndarray, cells: int) -> np.ndarray:
    """Mean side (px) of each quad (M×4×2) divided by the cells across the marker (data bits + black border)."""
    d = quads[:, _NEXT] - quads
    return np.sqrt((d * d).sum(axis=2)).mean(axis=1) / float(cells)


def _fit_lines(x: np.ndarray, y: np.ndarray, w: np.ndarray) -> tuple[np.ndarray, ...]:
    """Weighted total-least-squares lines through the points (`x`, `y`), M×4×K with weights `w`:
    (centroid x, centroid y, direction x, direction y), each M×4."""
    total = np.maximum(w.sum(axis=2), 1e-9)
    mx, my = (w * x).sum(axis=2) / total, (w * y).sum(axis=2) / total
    dx, dy = x - mx[..., None], y - my[..., None]
    wdx = w * dx
    angle = 0.5 * np.arctan2(2.0 * (wdx * dy).sum(axis=2), (wdx * dx).sum(axis=2) - (w * dy * dy).sum(axis=2))
    return mx, my, np.cos(angle), np.sin(angle)  # the principal axis of the 2×2 scatter matrix


def refine_corners(grey: np.ndarray, quads: np.ndarray, cells: int) -> np.ndarray:
    """Refined corners (M×4×2 float64) of the M quads (M×4×2, corners in order round the quad) found in
    `grey` (H×W uint8) for markers `cells` modules across; a corner that cannot be refined within its
    uncertainty is returned unrefined."""
    return refined_corners(grey, quads, cells)[0]


def refined_corners(grey: np.ndarray, quads: np.ndarray, cells: int) -> tuple[np.ndarray, np.ndarray]:
    """:func:`refine_corners`, and which corners (M×4 bool) were refined: the others are returned as given.

    Written as few whole-array operations as it can be (x and y kept apart): it runs for every marker
    of every frame, and its cost is numpy's per-call overhead more than arithmetic (bench: perception)."""
    quads = np.asarray(quads, dtype=np.float64).reshape(-1, 4, 2)
    m_count = len(quads)
    if m_count == 0:
        return quads.copy(), np.zeros((0, 4), dtype=bool)
    along = quads[:, _NEXT] - quads
    length = np.maximum(np.hypot(along[..., 0], along[..., 1]), 1e-9)  # (M, 4)
    module = length.mean(axis=1) / float(cells)  # as module_size(), from the sides computed here anyway
    reach = np.clip(REACH_MODULES * module, MIN_REACH_PX, MAX_REACH_PX)  # (M,)
    nx, ny = along[..., 1] / length, -along[..., 0] / length
    centre = quads.mean(axis=1, keepdims=True)
    mid = quads + 0.5 * along - centre
    flip = np.where(mid[..., 0] * nx + mid[..., 1] * ny < 0, -1.0, 1.0)  # outward: into the quiet zone
    nx, ny = nx * flip, ny * flip

    bx = quads[:, :, None, 0] + _T * along[:, :, None, 0]  # (M, 4, K): where the profiles cross the sides
    by = quads[:, :, None, 1] + _T * along[:, :, None, 1]
    step = _S * reach[:, None]  # (M, S)
    mapx = (bx[..., None] + step[:, None, None, :] * nx[..., None, None]).astype(np.float32).reshape(-1, STEPS)
    mapy = (by[..., None] + step[:, None, None, :] * ny[..., None, None]).astype(np.float32).reshape(-1, STEPS)
    profiles = cv2.remap(grey, mapx, mapy, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
    grad = np.diff(profiles.astype(np.float32), axis=1)  # (N, S−1), positive on a dark → bright edge
    peak = grad.argmax(axis=1)
    strong = (peak > 0) & (peak < STEPS - 2) & (grad.max(axis=1) >= MIN_EDGE_STEP)
    # The edge is the gradient's centroid over the profile (only its rising part counts), as AprilTag's
    # refine_edges takes it: steadier under noise than the peak alone.
    weight = np.square(np.maximum(grad, 0.0))
    where = (weight @ _CENTRES) / np.maximum(weight.sum(axis=1), 1e-9)
    position = (np.repeat(reach, 4 * SAMPLES) * (where * (2.0 / (STEPS - 1)) - 1.0)).reshape(m_count, 4, SAMPLES)
    ex, ey = bx + position * nx[..., None], by + position * ny[..., None]
    w = strong.reshape(m_count, 4, SAMPLES).astype(np.float64)

    mx, my, ux, uy = _fit_lines(ex, ey, w)
    residual = np.abs((ex - mx[..., None]) * uy[..., None] - (ey - my[..., None]) * ux[..., None])
    count = np.maximum(w.sum(axis=2), 1.0)
    sigma = np.maximum(0.25, 1.25 * (w * residual).sum(axis=2) / count)  # mean absolute deviation → σ
    w = w * (residual <= 3.0 * sigma[..., None])
    mx, my, ux, uy = _fit_lines(ex, ey, w)
    enough = w.sum(axis=2) >= MIN_SIDE_FRACTION * SAMPLES  # (M, 4), per side

    # Corner i is where side i−1 (which ends at it) meets side i (which starts at it).
    px, py, vx, vy = mx[:, _PREV], my[:, _PREV], ux[:, _PREV], uy[:, _PREV]
    cross = vx * uy - vy * ux
    t = ((mx - px) * uy - (my - py) * ux) / np.where(np.abs(cross) > 1e-3, cross, 1.0)
    meet = np.stack([px + t * vx, py + t * vy], axis=-1)
    ok = enough & enough[:, _PREV] & (np.abs(cross) > 0.05)
    ok &= _within(meet, quads, module)
    return np.where(ok[..., None], meet, quads), ok


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
