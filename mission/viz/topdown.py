"""The small top-down map: occupancy grid with the robot, its goal, the target and their trails.

:class:`MapView` owns the map → pixel transform. Recordings draw with it in OpenCV; the live page and the
log scrubber get the same background image and the same transform (as an affine matrix) and draw the
moving parts in SVG, so both agree on where everything is.
"""

from __future__ import annotations

import base64
import math
from collections.abc import Sequence
from typing import Any

import cv2
import numpy as np

from mission.core.types import OccupancyGrid, Pose2D
from mission.viz.overlay import put_label

FREE_BGR = (255, 255, 255)
OCCUPIED_BGR = (75, 67, 60)
UNKNOWN_BGR = (230, 225, 220)
ROBOT_BGR = (232, 115, 26)  # blue
TARGET_BGR = (37, 48, 217)  # red
GOAL_BGR = (0, 116, 227)  # amber
TRAIL_BGR = (240, 190, 150)


class MapView:
    """A map image `size` px on its longer side and the transform from map metres to its pixels."""

    def __init__(self, grid: OccupancyGrid | None, size: int = 320, fallback_extent_m: float = 10.0) -> None:
        if grid is None:  # no map (a robot without one): an empty square around the origin
            cells = 100
            res = fallback_extent_m / cells
            grid = OccupancyGrid(
                data=np.zeros((cells, cells), np.int8),
                resolution=res,
                origin=Pose2D(-fallback_extent_m / 2, -fallback_extent_m / 2, 0.0),
            )
        self.grid = grid
        h, w = grid.data.shape
        self.scale = size / max(h, w)  # px per cell
        self.width = max(1, round(w * self.scale))
        self.height = max(1, round(h * self.scale))
        cells = np.empty((h, w, 3), np.uint8)
        cells[:] = FREE_BGR
        cells[grid.data >= 50] = OCCUPIED_BGR
        cells[grid.data < 0] = UNKNOWN_BGR
        flipped = cells[::-1]  # row 0 (lowest y) at the bottom: +y up, as on a map
        interp = cv2.INTER_NEAREST if self.scale >= 1 else cv2.INTER_AREA
        self.background = cv2.resize(flipped, (self.width, self.height), interpolation=interp)
        # u = col·s, v = H_px − row·s, with (row, col) = world_to_grid(x, y) (affine in x, y)
        c, s = math.cos(-grid.origin.yaw), math.sin(-grid.origin.yaw)
        k = self.scale / grid.resolution
        ox, oy = grid.origin.x, grid.origin.y
        # lx = c·dx − s·dy ; ly = s·dx + c·dy
        self.affine = np.array(
            [
                [k * c, -k * s, -k * (c * ox - s * oy)],
                [-k * s, -k * c, self.height + k * (s * ox + c * oy)],
            ]
        )

    def to_px(self, x: float, y: float) -> tuple[int, int]:
        u, v = self.affine @ np.array([x, y, 1.0])
        return round(float(u)), round(float(v))

    def metres_to_px(self, m: float) -> float:
        return m * self.scale / self.grid.resolution

    def info(self) -> dict[str, Any]:
        """What a browser needs to draw on this map: the PNG background and the affine transform."""
        ok, png = cv2.imencode(".png", self.background)
        return {
            "png": base64.b64encode(png.tobytes()).decode() if ok else "",
            "width": self.width,
            "height": self.height,
            "affine": [[round(float(v), 6) for v in row] for row in self.affine],
            "px_per_m": round(self.metres_to_px(1.0), 6),
        }

    def _pose_arrow(self, img: np.ndarray, pose: Sequence[float], colour: tuple[int, int, int], r: float) -> None:
        x, y, yaw = pose
        u, v = self.to_px(x, y)
        tip = self.to_px(x + 2.2 * r * math.cos(yaw), y + 2.2 * r * math.sin(yaw))
        rp = max(3, round(self.metres_to_px(r)))
        cv2.circle(img, (u, v), rp, colour, -1, cv2.LINE_AA)
        cv2.line(img, (u, v), tip, (40, 40, 40), max(1, rp // 3), cv2.LINE_AA)

    def draw(
        self,
        robot: Sequence[float] | None = None,
        target: Sequence[float] | None = None,
        goal: Sequence[float] | None = None,
        robot_trail: Sequence[Sequence[float]] = (),
        target_trail: Sequence[Sequence[float]] = (),
        estimates: Sequence[Sequence[float]] = (),
    ) -> np.ndarray:
        """A BGR picture of the map with poses given as (x, y, yaw) and trails as (x, y) sequences."""
        img = self.background.copy()
        for trail, colour in ((target_trail, (170, 170, 240)), (robot_trail, TRAIL_BGR)):
            if len(trail) > 1:
                pts = np.array([self.to_px(p[0], p[1]) for p in trail], np.int32)
                cv2.polylines(img, [pts], False, colour, 2, cv2.LINE_AA)
        if goal is not None:
            u, v = self.to_px(goal[0], goal[1])
            cv2.drawMarker(img, (u, v), GOAL_BGR, cv2.MARKER_CROSS, 12, 2, cv2.LINE_AA)
        for est in estimates:
            u, v = self.to_px(est[0], est[1])
            cv2.circle(img, (u, v), 6, TARGET_BGR, 1, cv2.LINE_AA)
        if target is not None:
            self._pose_arrow(img, target, TARGET_BGR, 0.15)
        if robot is not None:
            self._pose_arrow(img, robot, ROBOT_BGR, 0.2)
        return img


def annotate_scale(img: np.ndarray, view: MapView) -> None:
    """A 1 m scale bar in the bottom-left corner."""
    px = round(view.metres_to_px(1.0))
    h = img.shape[0]
    cv2.line(img, (8, h - 10), (8 + px, h - 10), (40, 40, 40), 2)
    put_label(img, "1 m", (10 + px, h - 4), 0.4)
