"""Exact AprilTag images for the apriltag tests: any family's real bit pattern, placed upright in an image.

Families OpenCV has are drawn by OpenCV; tagStandard41h12 comes from the AprilTag 3 C library's family
table (codes and bit layout, read through pupil-apriltags). Tags are placed
fronto-parallel at an integer scale, so the true corners are known exactly in OpenCV's pixel convention
(pixel k spans [k − ½, k + ½]).
"""

from __future__ import annotations

import ctypes

import cv2
import numpy as np

from mission.perception_plugins.apriltag_backends import OPENCV_DICTIONARIES, SafeDetector, pupil_corner_order


def tag_cells(family: str, tag_id: int) -> tuple[np.ndarray, int, int]:
    """(cells image uint8, 1 px per cell incl. one white margin cell, total_width, width_at_border).

    Upright in the convention the sources report (TL TR BR BL of the marker as OpenCV draws it): OpenCV
    draws the families it has; tagStandard41h12 is drawn from AprilTag 3's code and bit layout the way
    its ``apriltag_to_image`` does (black everywhere, a white ring of width ``width_at_border (+ 2 unless
    reversed_border)``, set data bits white at (bit_x, bit_y) + border_start), then turned to OpenCV's
    orientation (180° for OpenCV ≤ 5.0.0, see pupil_corner_order).
    """
    if family in OPENCV_DICTIONARIES:
        d = cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, OPENCV_DICTIONARIES[family]))
        n = int(d.markerSize) + 2
        img = cv2.aruco.generateImageMarker(d, tag_id, n, borderBits=1)
        return cv2.copyMakeBorder(img, 1, 1, 1, 1, cv2.BORDER_CONSTANT, value=255), n + 2, n
    det = SafeDetector(families=family)
    fam = det.tag_families[family].contents
    tw, wab = int(fam.total_width), int(fam.width_at_border)
    cells = np.zeros((tw, tw), np.uint8)
    ring_w = wab + (0 if fam.reversed_border else 2)
    r0 = (tw - ring_w) // 2
    cells[r0, r0 : r0 + ring_w] = cells[r0 + ring_w - 1, r0 : r0 + ring_w] = 255
    cells[r0 : r0 + ring_w, r0] = cells[r0 : r0 + ring_w, r0 + ring_w - 1] = 255
    border_start = (tw - wab) // 2
    code = int(fam.codes[tag_id])
    nbits = int(fam.nbits)
    for i in range(nbits):
        if code & (1 << (nbits - i - 1)):
            x = ctypes.c_int32(fam.bit_x[i]).value + border_start
            y = ctypes.c_int32(fam.bit_y[i]).value + border_start
            cells[y, x] = 255
    if pupil_corner_order() == (1, 0, 3, 2):
        cells = np.rot90(cells, 2).copy()
    return cells, tw, wab


def place_tag(
    cells: np.ndarray,
    width_at_border: int,
    *,
    cell_px: int = 12,
    origin: tuple[int, int] = (200, 120),
    size: tuple[int, int] = (640, 480),
    black: int = 20,
    white: int = 235,
    background: int = 150,
) -> tuple[np.ndarray, np.ndarray]:
    """(BGR image, true corners TL TR BR BL of the tag's border square in OpenCV's pixel convention)."""
    w, h = size
    img = np.full((h, w), background, np.uint8)
    tag = np.where(cells > 127, white, black).astype(np.uint8)
    big = np.kron(tag, np.ones((cell_px, cell_px), np.uint8))
    x0, y0 = origin
    img[y0 : y0 + big.shape[0], x0 : x0 + big.shape[1]] = big
    b = (cells.shape[0] - width_at_border) / 2 * cell_px
    lo_x, lo_y = x0 + b - 0.5, y0 + b - 0.5
    side = width_at_border * cell_px
    corners = np.array([[lo_x, lo_y], [lo_x + side, lo_y], [lo_x + side, lo_y + side], [lo_x, lo_y + side]])
    return np.repeat(img[:, :, None], 3, axis=2), corners


def flip_data_cells(cells: np.ndarray, positions: list[tuple[int, int]]) -> np.ndarray:
    """A copy with the given (row, col) cells inverted (bit errors for hamming tests)."""
    out = cells.copy()
    for r, c in positions:
        out[r, c] = 255 - out[r, c]
    return out
