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
   more than 3 robust standard deviations off the first line), and each corner where its two lines meet.

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
_NEXT = np.array([1, 2, 3, 0])
_PREV = np.array([3, 0, 1, 2])


def module_size(quads: np.ndarray, cells: int) -> np.ndarray:
    """Mean side (px) of each quad (M×4×2) divided by the cells across the marker (data bits + black border)."""
    d = quads[:, _NEXT] - quads
    return np.sqrt((d * d).sum(axis=2)).mean(axis=1) / float(cells)


def _fit_lines(points: np.ndarray, weights: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Weighted total-least-squares lines through ``points`` (M×4×K×2): (centroids, unit directions), M×4×2."""
    total = np.maximum(weights.sum(axis=2), 1e-9)
    centre = np.einsum("msk,mskc->msc", weights, points) / total[..., None]
    d = points - centre[:, :, None, :]
    wd = weights[..., None] * d
    sxx = (wd[..., 0] * d[..., 0]).sum(axis=2)
    syy = (wd[..., 1] * d[..., 1]).sum(axis=2)
    sxy = (wd[..., 0] * d[..., 1]).sum(axis=2)
    angle = 0.5 * np.arctan2(2.0 * sxy, sxx - syy)  # the principal axis of the 2×2 scatter matrix
    return centre, np.stack([np.cos(angle), np.sin(angle)], axis=-1)


def refine_corners(grey: np.ndarray, quads: np.ndarray, cells: int) -> np.ndarray:
    """Refined corners (M×4×2 float64) of the M quads (M×4×2, corners in order round the quad) found in
    `grey` (H×W uint8) for markers `cells` modules across; a corner that cannot be refined within its
    uncertainty is returned unrefined."""
    quads = np.asarray(quads, dtype=np.float64).reshape(-1, 4, 2)
    m_count = len(quads)
    if m_count == 0:
        return quads.copy()
    along = quads[:, _NEXT] - quads
    length = np.sqrt((along * along).sum(axis=2))
    module = length.mean(axis=1) / float(cells)  # as module_size(), from the sides computed here anyway
    reach = np.clip(REACH_MODULES * module, MIN_REACH_PX, MAX_REACH_PX)  # (M,)
    normal = np.stack([along[..., 1], -along[..., 0]], axis=-1) / np.maximum(length, 1e-9)[..., None]
    outward = ((quads + 0.5 * along - quads.mean(axis=1, keepdims=True)) * normal).sum(axis=2)
    normal[outward < 0] *= -1.0  # from the black border out into the quiet zone

    base = quads[:, :, None, :] + _T[None, None, :, None] * along[:, :, None, :]  # (M, 4, K, 2)
    offsets = (_S[None, :] * reach[:, None])[:, None, None, :, None] * normal[:, :, None, None, :]
    pts = (base[:, :, :, None, :] + offsets).astype(np.float32).reshape(-1, STEPS, 2)  # (M·4·K, S, 2)
    profiles = cv2.remap(grey, pts[..., 0], pts[..., 1], cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
    grad = np.diff(profiles.astype(np.float32), axis=1)  # (N, S−1), positive on a dark → bright edge
    peak = grad.argmax(axis=1)
    interior = (peak > 0) & (peak < STEPS - 2)
    g1 = grad[np.arange(len(grad)), peak]
    # The edge is the gradient's centroid over the profile (only its rising part counts), as AprilTag's
    # refine_edges takes it: steadier under noise than the peak alone.
    weight = np.maximum(grad, 0.0)
    weight = weight * weight
    centres = (np.arange(STEPS - 1, dtype=np.float32) + 0.5)[None, :]
    where = (weight * centres).sum(axis=1) / np.maximum(weight.sum(axis=1), 1e-9)
    reach_n = np.repeat(reach, 4 * SAMPLES)
    position = reach_n * (where * (2.0 / (STEPS - 1)) - 1.0)  # px along the normal
    edges = base + position.reshape(m_count, 4, SAMPLES, 1) * normal[:, :, None, :]
    weights = (interior & (g1 >= MIN_EDGE_STEP)).reshape(m_count, 4, SAMPLES).astype(np.float64)

    centre, direction = _fit_lines(edges, weights)
    across = np.stack([-direction[..., 1], direction[..., 0]], axis=-1)
    residual = np.abs(((edges - centre[:, :, None, :]) * across[:, :, None, :]).sum(axis=3))
    count = weights.sum(axis=2).astype(int)
    ranked = np.sort(np.where(weights > 0, residual, np.inf), axis=2)
    median = np.take_along_axis(ranked, np.clip(count // 2, 0, SAMPLES - 1)[..., None], axis=2)[..., 0]
    sigma = np.maximum(0.25, 1.4826 * np.where(count > 0, median, 0.0))
    weights = weights * (residual <= 3.0 * sigma[..., None])
    centre, direction = _fit_lines(edges, weights)
    enough = weights.sum(axis=2) >= MIN_SIDE_FRACTION * SAMPLES  # (M, 4), per side

    # Corner i is where side i−1 (which ends at it) meets side i (which starts at it).
    p1, v1 = centre[:, _PREV], direction[:, _PREV]
    cross = v1[..., 0] * direction[..., 1] - v1[..., 1] * direction[..., 0]
    d = centre - p1
    safe = np.where(np.abs(cross) > 1e-3, cross, 1.0)
    meet = p1 + ((d[..., 0] * direction[..., 1] - d[..., 1] * direction[..., 0]) / safe)[..., None] * v1
    ok = enough & enough[:, _PREV] & (np.abs(cross) > 0.05)
    return within_uncertainty(np.where(ok[..., None], meet, quads), quads, module)


def within_uncertainty(refined: np.ndarray, quads: np.ndarray, module: np.ndarray) -> np.ndarray:
    """`refined` corners where they lie within ``max(1.5 px, half a module)`` of the unrefined `quads`
    (M×4×2, `module` px per module for each), the unrefined corner elsewhere (and where not finite)."""
    shift = refined - quads
    limit = np.maximum(MIN_SHIFT_PX, SHIFT_MODULES * np.asarray(module, dtype=np.float64))[:, None]
    ok = np.isfinite(refined).all(axis=2) & ((shift * shift).sum(axis=2) <= limit * limit)
    return np.where(ok[..., None], refined, quads)


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
