"""Where a marker's corners really are in a photo of a ChArUco board — ground truth that no marker detector
made (issue 34).

A ChArUco board is a chessboard with a marker in each white square. The chessboard's saddle points are found
to a tenth of a pixel by a method that owes nothing to the markers' own corners (OpenCV's CharucoDetector
finds them, then refines each on the grey-level saddle, ``cornerSubPix``). The board says where every marker
sits between them, so each marker's true corners are its board corners carried into the image by a
homography fitted to the six saddle points nearest it: local enough that a lens's distortion is a fraction
of a pixel over it.

:func:`corner_errors` then measures any detector's corners against that truth, corner by corner (each in
the marker's own order), and :func:`duplicates` counts an id reported twice in one image.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

import cv2
import numpy as np

NEAREST = 6  # saddle points a marker's homography is fitted to
REACH_SQUARES = 1.6  # ... all within this many squares of its centre (else the marker has no truth)


@dataclass(frozen=True)
class Board:
    """A ChArUco board's layout, as cv2.aruco.CharucoBoard takes it."""

    squares: tuple[int, int]  # (columns, rows)
    square_m: float
    marker_m: float
    dictionary: str  # an OpenCV dictionary name

    def opencv(self) -> cv2.aruco.CharucoBoard:
        d = cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, self.dictionary))
        return cv2.aruco.CharucoBoard(self.squares, self.square_m, self.marker_m, d)


#: the board in OpenCV's ChArUco tutorial photos (../shared/data/real-aruco/contrib__ch*.jpg)
TUTORIAL_BOARD = Board((5, 7), 0.04, 0.02, "DICT_6X6_250")


def charuco_truth(grey: np.ndarray, board: Board) -> dict[int, np.ndarray]:
    """marker id → its true corners (4×2 px, in the marker's order) for every marker with enough saddle
    points around it in this image."""
    cv_board = board.opencv()
    corners, ids, _, _ = cv2.aruco.CharucoDetector(cv_board).detectBoard(grey)
    if ids is None:
        return {}
    saddles = {int(i): p.reshape(2) for i, p in zip(ids.ravel(), corners, strict=True)}
    chess = np.asarray(cv_board.getChessboardCorners())[:, :2]
    truth: dict[int, np.ndarray] = {}
    for obj, marker_id in zip(cv_board.getObjPoints(), cv_board.getIds().ravel(), strict=True):
        square = np.asarray(obj, dtype=np.float64)[:, :2]
        centre = square.mean(axis=0)
        near = sorted(saddles, key=lambda i: float(np.hypot(*(chess[i] - centre))))[:NEAREST]
        if len(near) < 4 or np.hypot(*(chess[near[3]] - centre)) > REACH_SQUARES * board.square_m:
            continue
        H, _ = cv2.findHomography(chess[near], np.array([saddles[i] for i in near]))
        if H is None:
            continue
        truth[int(marker_id)] = cv2.perspectiveTransform(square.reshape(-1, 1, 2), H).reshape(4, 2)
    return truth


def corner_errors(found: Iterable[tuple[int, np.ndarray]], truth: dict[int, np.ndarray]) -> np.ndarray:
    """The distance (px) of every found corner from its true place, for the markers the truth has."""
    errors: list[float] = []
    for marker_id, corners in found:
        if marker_id in truth:
            diff = np.asarray(corners, dtype=np.float64).reshape(4, 2) - truth[marker_id]
            errors += np.hypot(diff[:, 0], diff[:, 1]).tolist()
    return np.asarray(errors)


def duplicates(found: Iterable[tuple[int, np.ndarray]]) -> int:
    """How many detections repeat an id already reported in the same image."""
    ids = [marker_id for marker_id, _ in found]
    return len(ids) - len(set(ids))
