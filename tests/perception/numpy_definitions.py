"""The edge refinement and the pattern check written as numpy expressions: the definitions the compiled
versions (perception_plugins/corner_refinement.py, marker_bits.py) must reproduce to the bit. These were
the sources' code until the loops were compiled (issue 34); they stay here as the specification the tests
hold the compiled code to, so a change to either is seen as a change to what the refinement computes."""

from __future__ import annotations

import cv2
import numpy as np

from mission.perception_plugins import corner_refinement as cr
from mission.perception_plugins import marker_bits as mb

_CENTRES = np.arange(cr.STEPS - 1, dtype=np.float32) + 0.5
_NEXT = np.array([1, 2, 3, 0])
_PREV = np.array([3, 0, 1, 2])


def _fit_lines(x: np.ndarray, y: np.ndarray, w: np.ndarray) -> tuple[np.ndarray, ...]:
    total = np.maximum(w.sum(axis=2), 1e-9)
    mx, my = (w * x).sum(axis=2) / total, (w * y).sum(axis=2) / total
    dx, dy = x - mx[..., None], y - my[..., None]
    wdx = w * dx
    angle = 0.5 * np.arctan2(2.0 * (wdx * dy).sum(axis=2), (wdx * dx).sum(axis=2) - (w * dy * dy).sum(axis=2))
    return mx, my, np.cos(angle), np.sin(angle)


def refined_corners(grey: np.ndarray, quads: np.ndarray, cells: int) -> tuple[np.ndarray, np.ndarray]:
    """corner_refinement.refined_corners, as numpy."""
    quads = np.asarray(quads, dtype=np.float64).reshape(-1, 4, 2)
    m_count = len(quads)
    along = quads[:, _NEXT] - quads
    length = np.maximum(np.hypot(along[..., 0], along[..., 1]), 1e-9)
    module = length.mean(axis=1) / float(cells)
    reach = np.clip(cr.REACH_MODULES * module, cr.MIN_REACH_PX, cr.MAX_REACH_PX)
    nx, ny = along[..., 1] / length, -along[..., 0] / length
    centre = quads.mean(axis=1, keepdims=True)
    mid = quads + 0.5 * along - centre
    flip = np.where(mid[..., 0] * nx + mid[..., 1] * ny < 0, -1.0, 1.0)
    nx, ny = nx * flip, ny * flip
    bx = quads[:, :, None, 0] + cr._T * along[:, :, None, 0]
    by = quads[:, :, None, 1] + cr._T * along[:, :, None, 1]
    step = cr._S * reach[:, None]
    mapx = (bx[..., None] + step[:, None, None, :] * nx[..., None, None]).astype(np.float32).reshape(-1, cr.STEPS)
    mapy = (by[..., None] + step[:, None, None, :] * ny[..., None, None]).astype(np.float32).reshape(-1, cr.STEPS)
    profiles = cv2.remap(grey, mapx, mapy, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
    grad = np.diff(profiles.astype(np.float32), axis=1)
    peak = grad.argmax(axis=1)
    strong = (peak > 0) & (peak < cr.STEPS - 2) & (grad.max(axis=1) >= cr.MIN_EDGE_STEP)
    weight = np.square(np.maximum(grad, 0.0))
    where = (weight @ _CENTRES) / np.maximum(weight.sum(axis=1), 1e-9)
    position = (np.repeat(reach, 4 * cr.SAMPLES) * (where * (2.0 / (cr.STEPS - 1)) - 1.0)).reshape(
        m_count, 4, cr.SAMPLES
    )
    ex, ey = bx + position * nx[..., None], by + position * ny[..., None]
    w = strong.reshape(m_count, 4, cr.SAMPLES).astype(np.float64)
    mx, my, ux, uy = _fit_lines(ex, ey, w)
    residual = np.abs((ex - mx[..., None]) * uy[..., None] - (ey - my[..., None]) * ux[..., None])
    count = np.maximum(w.sum(axis=2), 1.0)
    sigma = np.maximum(0.25, 1.25 * (w * residual).sum(axis=2) / count)
    w = w * (residual <= 3.0 * sigma[..., None])
    mx, my, ux, uy = _fit_lines(ex, ey, w)
    enough = w.sum(axis=2) >= cr.MIN_SIDE_FRACTION * cr.SAMPLES
    px, py, vx, vy = mx[:, _PREV], my[:, _PREV], ux[:, _PREV], uy[:, _PREV]
    cross = vx * uy - vy * ux
    t = ((mx - px) * uy - (my - py) * ux) / np.where(np.abs(cross) > 1e-3, cross, 1.0)
    meet = np.stack([px + t * vx, py + t * vy], axis=-1)
    ok = enough & enough[:, _PREV] & (np.abs(cross) > 0.05)
    shift = meet - quads
    limit = np.maximum(cr.MIN_SHIFT_PX, cr.SHIFT_MODULES * module)[:, None]
    ok &= np.isfinite(meet).all(axis=2) & ((shift * shift).sum(axis=2) <= limit * limit)
    return np.where(ok[..., None], meet, quads), ok


def pattern_holds(check: mb.PatternCheck, grey: np.ndarray, quads: np.ndarray, ids: np.ndarray) -> np.ndarray:
    """PatternCheck.__call__, as numpy."""
    quads = np.asarray(quads, dtype=np.float64).reshape(-1, 4, 2)
    m_count = len(quads)
    c = check.cells
    points, sides, inward, border = check._points, check._sides, check._inward, check._border
    unit = np.array([[0, 0], [c, 0], [c, c], [0, c]], dtype=np.float32)
    homs = np.stack([cv2.getPerspectiveTransform(unit, q.astype(np.float32)) for q in quads])
    module = np.linalg.norm(quads[:, [1, 2, 3, 0]] - quads, axis=2).mean(axis=1) / c
    across = np.minimum(mb.BAND_PX / np.maximum(module, 1e-6), mb.BAND_MODULES)[:, None, None]
    band = np.concatenate([sides + across * inward, sides - across * inward], axis=1)
    unit_pts = np.concatenate([np.broadcast_to(points, (m_count, *points.shape)), band], axis=1)
    u, v = unit_pts[..., 0], unit_pts[..., 1]
    h = homs[..., None]
    w = h[:, 2, 0] * u + h[:, 2, 1] * v + h[:, 2, 2]
    x = ((h[:, 0, 0] * u + h[:, 0, 1] * v + h[:, 0, 2]) / w).astype(np.float32)
    y = ((h[:, 1, 0] * u + h[:, 1, 1] * v + h[:, 1, 2]) / w).astype(np.float32)
    values = cv2.remap(
        grey, x.reshape(1, -1), y.reshape(1, -1), cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE
    ).reshape(m_count, -1)
    n_cells = c * c * mb.SUBSAMPLES * mb.SUBSAMPLES
    n_fixed = len(points)
    cell = values[:, :n_cells].reshape(m_count, c, c, mb.SUBSAMPLES * mb.SUBSAMPLES).mean(axis=3)
    white = values[:, n_cells:n_fixed].mean(axis=1)
    black = np.median(cell[:, border], axis=1)
    mid = ((black + white) / 2)[:, None, None]
    band_values = values[:, n_fixed:].reshape(m_count, 2, 4, mb.BAND_POINTS)
    on_edges = (((band_values[:, 0] < mid) & (band_values[:, 1] > mid)).mean(axis=2) >= mb.BAND_FRACTION).all(axis=1)
    wrong = (cell > mid) != np.stack([check.pattern(int(i)) for i in ids])
    return (
        (white - black >= mb.MIN_CONTRAST)
        & on_edges
        & ~wrong[:, ~border].any(axis=1)
        & (wrong[:, border].sum(axis=1) <= mb.MAX_BORDER_ERRORS)
    )
