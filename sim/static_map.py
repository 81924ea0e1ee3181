"""The pre-built occupancy grid of a scenario: what the pre-mapping phase (SLAM) would have recorded.

Only the static world is in it — walls, static obstacles, the dock board — never the unknown obstacles
or the target. Cells inside the walls' outer boundary are free (0) or occupied (100); cells outside
the room are unknown (-1), as in a SLAM map. A cell is occupied when an obstacle reaches within half a
cell of its centre, so thin walls never fall between cells.
"""

from __future__ import annotations

import numpy as np

from mission.core.types import OccupancyGrid, Pose2D
from mission.sim.scenario import Scenario
from mission.sim.scene import static_footprints

MARGIN_M = 0.25  # map border beyond the room's inner walls


def static_map(sc: Scenario) -> OccupancyGrid:
    res = sc.map.resolution
    sx, sy = sc.room.size
    ox = oy = -MARGIN_M
    w = int(np.ceil((sx + 2 * MARGIN_M) / res))
    h = int(np.ceil((sy + 2 * MARGIN_M) / res))
    xs = ox + (np.arange(w) + 0.5) * res
    ys = oy + (np.arange(h) + 0.5) * res
    X, Y = np.meshgrid(xs, ys)  # rows = y, cols = x
    dist = np.full(X.shape, np.inf)
    for fp in static_footprints(sc):
        np.minimum(dist, fp.distance_grid(X, Y), out=dist)
    t = sc.room.wall_thickness
    inside = (np.abs(X - sx / 2) <= sx / 2 + t) & (np.abs(Y - sy / 2) <= sy / 2 + t)
    data = np.full(X.shape, -1, dtype=np.int8)
    data[inside] = 0
    data[dist <= res / 2] = 100
    return OccupancyGrid(data=data, resolution=res, origin=Pose2D(ox, oy, 0.0))
