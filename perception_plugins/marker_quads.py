"""One quad per marker: OpenCV's ArUco detector can report the same id twice in one image (issue 34).

With ``minMarkerDistanceRate`` lowered to 0.025 — which keeps a large rendered marker whose white quiet zone
shows as a second contour (opencv_contrib#2913) — candidates closer together than OpenCV's default allows both
survive: the marker's outer square and a contour inside it (the inner edge of its black border, 7–9 px in on
an 85 px marker), or two quads a pixel apart. When both decode, both are reported, and the inner one is a pose
several per cent too far away. A quad that decodes is the marker or a contour inside it (the quiet zone's
contour outside it does not decode), so of the same id's quads that overlap, the largest is the marker.
Quads of the same id that do not overlap are two printed markers and are both kept.
"""

from __future__ import annotations

import numpy as np

_NEXT = [1, 2, 3, 0]  # each corner's successor round the quad

Box = tuple[int, int, int, int]  # x0, y0, x1, y1: an axis-aligned region of a frame (px; x1 and y1 exclusive)


def area(quad: np.ndarray) -> float:
    """The area (px²) inside a 4×2 quad."""
    x, y = quad[:, 0], quad[:, 1]
    return 0.5 * abs(float(np.dot(x, y[_NEXT]) - np.dot(y, x[_NEXT])))


def perimeter(quad: np.ndarray) -> float:
    """The length (px) round a 4×2 quad."""
    return float(np.linalg.norm(quad[_NEXT] - quad, axis=1).sum())


def shortest_side(quad: np.ndarray) -> float:
    """The shortest of a 4×2 quad's sides (px): how narrow a marker seen obliquely is."""
    return float(np.linalg.norm(quad[_NEXT] - quad, axis=1).min())


def side(quad: np.ndarray) -> float:
    """The mean side (px) of a 4×2 quad."""
    return perimeter(quad) / 4


def one_quad_per_marker(quads: np.ndarray, ids: np.ndarray) -> np.ndarray:
    """Indices (in input order) of the quads to keep: of the same id's quads whose centres lie within half the
    larger one's side of each other, only the largest. `quads` is N×4×2 px, `ids` N ints."""
    ids = np.asarray(ids).reshape(-1)
    if len(np.unique(ids)) == len(ids):
        return np.arange(len(ids))  # no id twice: nothing to choose between (the usual frame)
    quads = np.asarray(quads, dtype=np.float64).reshape(-1, 4, 2)
    centres = quads.mean(axis=1)
    areas = [area(q) for q in quads]
    sides = [side(q) for q in quads]
    dropped: set[int] = set()
    for i in sorted(range(len(ids)), key=lambda k: -areas[k]):  # largest first: it absorbs what lies inside it
        if i in dropped:
            continue
        for j in range(len(ids)):
            same_marker = ids[j] == ids[i] and np.linalg.norm(centres[j] - centres[i]) < 0.5 * max(sides[i], sides[j])
            if j != i and j not in dropped and areas[j] <= areas[i] and same_marker:
                dropped.add(j)
    return np.array([k for k in range(len(ids)) if k not in dropped], dtype=int)
