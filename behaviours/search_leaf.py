"""What the LOST and SEARCH leaves share: the loss's belief, the camera's pose and field of view, turning.

Every leaf that runs while the target is lost keeps the one :class:`~mission.behaviours.belief.TargetBelief`
of the loss up to date (it grows with time, the camera's view clears it), so each rung of the search ladder
starts from what the ones before it saw. The camera is where the robot pose and the camera extrinsics put
it; its horizontal field of view comes from the newest frame's intrinsics.
"""

from __future__ import annotations

import math
from typing import Any, ClassVar

import numpy as np

from mission.behaviours.belief import DEFAULT_SPEED_MPS, DEFAULT_VIEW_RANGE_M, TargetBelief
from mission.behaviours.leaf import MissionLeaf
from mission.behaviours.line_of_sight import fitted_velocity
from mission.behaviours.search_grid import SearchGrid, dilate, line_clear, search_grid, walk
from mission.core import blackboard as bbk
from mission.core import se3
from mission.core.blackboard import Key
from mission.core.types import Frame, LaserScan, OccupancyGrid, Pose2D, TargetTrack

# The velocity a lost target walks on with is fitted over its last 0.6 s: a second (what the line-of-sight
# check uses) still holds the leg before a corner the target has just turned, and points the search there.
HEADING_WINDOW_S = 0.6
# A place a mover (mission.core.movers) will drive over within this is no place to look from, nor to drive
# through to get there: the robot goes behind a crossing cart, not along in front of it. Long enough for the
# drive there and a look round (a shorter one left the place just beyond it, still in the cart's way).
MOVER_HORIZON_S = 5.0
# Narrower movers may be the target itself (a person-sized box seen corner-on is 0.57 m wide): its own
# path is where the search wants to look, not a place to keep out of.
MOVER_MIN_WIDTH_M = 0.7
MOVER_STEP_S = 0.25  # a mover's predicted positions this far apart in time (0.09 m at a cart's 0.35 m/s)
# A target last seen this close to the view's edge (or beyond it, by now), with nothing between it and the
# camera, left through the side of the image: it is most likely just past that edge.
GLANCE_EDGE_RAD = math.radians(8.0)
GLANCE_BODY_M = 0.4  # the lidar's returns this close to the last position are the target's own body
GLANCE_HORIZON_S = 1.0  # … and where it walked on to, at its last velocity, for at most this long since
GLANCE_RANGE_M = 4.0  # farther than this, a target does not leave the view by walking across it in a moment
# A last reading whose marker reached this close (a fraction of the image's width) to the image's side left
# the view that way, wherever its map position lies: the placing lags the picture (latency, a biased
# calibration, the marker on the face rather than the centre). Under `typical`, targets last read 7–57 px
# from the left side of a 640 px image were placed 9–14° inside the view, and no glance was taken
# (hide_and_wait seeds 5012, 5016, 5021).
GLANCE_EDGE_FRACTION = 0.10


class SearchLeaf(MissionLeaf):
    """A leaf of the LOST / SEARCH states: commands the base and keeps the loss's belief."""

    READS: ClassVar[tuple[Key, ...]] = (bbk.TRACKS, bbk.MAP, bbk.SCAN, bbk.FRAME, bbk.MOVERS)
    WRITES: ClassVar[tuple[Key, ...]] = (bbk.BELIEFS,)
    COMMANDS = True

    def __init__(self, name: str | None = None, **ports: Any) -> None:
        super().__init__(name, **ports)
        self._looked_at: float | None = None

    # -- the camera (its pose and field of view: MissionLeaf) ------------------------------------------
    def left_through_the_images_side(self, track: TargetTrack) -> bool:
        """Did the target's last reading touch the image's left or right side (within GLANCE_EDGE_FRACTION of
        its width)? False without the image's width or the reading's corners."""
        frame: Frame | None = self.read(bbk.FRAME)
        width = None if frame is None or frame.intrinsics is None else frame.intrinsics.width
        det = track.detection
        if not width or det is None or det.corners is None or len(det.corners) == 0:
            return False
        xs = np.asarray(det.corners, dtype=float)[:, 0]
        edge = GLANCE_EDGE_FRACTION * width
        return float(xs.min()) <= edge or float(xs.max()) >= width - edge

    def glance_heading(self, track: TargetTrack, robot: Pose2D) -> float | None:
        """The robot heading that centres where the target has walked on to (its last velocity, up to
        GLANCE_HORIZON_S) in the view, when it left the view through its side: its last reading touched the
        image's side, or its last position is at or past the view's edge now; it is within GLANCE_RANGE_M,
        nothing the map or the lidar holds stands between it and the camera, and the map hides neither where
        it has walked on to since. None otherwise (it went behind something, or round a corner, or it is in
        view and simply not detected): turning is then no quick way to see it again.

        Following close behind a target that turns a corner, the robot loses it at the image's edge as often
        as behind the corner; the glance is the cheap first look a person would take."""
        sg = self.grid()
        if sg is None or track.pose_map is None:
            return None
        last = (float(track.pose_map[0, 3]), float(track.pose_map[1, 3]))
        cx, cy, cam_yaw = self.camera_pose(robot)
        d = math.hypot(last[0] - cx, last[1] - cy)
        if d > GLANCE_RANGE_M:
            return None
        off = abs(se3.wrap_angle(math.atan2(last[1] - cy, last[0] - cx) - cam_yaw))
        if off < self.hfov() / 2 - GLANCE_EDGE_RAD and not self.left_through_the_images_side(track):
            return None
        # up to the target's body: the lidar sees the target itself, which hides nothing
        short = max(0.0, d - GLANCE_BODY_M) / max(d, 1e-9)
        near = (cx + short * (last[0] - cx), cy + short * (last[1] - cy))
        if not line_clear(sg.occupied, sg, (cx, cy), last) or not line_clear(
            self.sight_blocked(sg, robot), sg, (cx, cy), near
        ):
            return None
        # and where it has walked on to since, if it kept going: round a corner is behind it, not off the side
        since = 0.0 if track.last_seen is None else min(GLANCE_HORIZON_S, max(0.0, self.now() - track.last_seen))
        _, ahead = predicted_walk(sg, sg.target_free(), track, since)
        if not line_clear(sg.occupied, sg, (cx, cy), ahead):
            return None
        return math.atan2(ahead[1] - robot.y, ahead[0] - robot.x)

    # -- the map ------------------------------------------------------------------------------------
    def grid(self) -> SearchGrid | None:
        occupancy: OccupancyGrid | None = self.read(bbk.MAP)
        return None if occupancy is None else search_grid(occupancy)

    def sight_blocked(self, sg: SearchGrid, robot: Pose2D) -> np.ndarray:
        """What hides things from the camera now: the map's obstacles and whatever the lidar sees."""
        scan: LaserScan | None = self.read(bbk.SCAN)
        return sg.occupied | sg.scan_cells(scan, robot)

    def mover_paths(self, sg: SearchGrid) -> np.ndarray:
        """Cells a mover wider than the target will cover within MOVER_HORIZON_S if it keeps going: no place to
        be, and nothing to be seen through, by the time the robot has got somewhere and looked."""
        paths = np.zeros(sg.shape, dtype=bool)
        for mover in self.read(bbk.MOVERS) or ():
            if mover.width_m >= MOVER_MIN_WIDTH_M:
                paths |= sg.point_cells(mover.swept(MOVER_HORIZON_S))
        return paths

    def movers_then(self, sg: SearchGrid, after_s: float, for_s: float) -> np.ndarray:
        """Cells the wide movers' near faces (their lidar returns, a cell deep) will cover from `after_s` to
        `after_s + for_s` from now if they keep going: what hides things from a look taken then."""
        cells = np.zeros(sg.shape, dtype=bool)
        now = self.now()
        for mover in self.read(bbk.MOVERS) or ():
            if mover.width_m >= MOVER_MIN_WIDTH_M:
                steps = (now - mover.stamp) + np.arange(after_s, after_s + for_s + 1e-9, MOVER_STEP_S)
                v = np.asarray(mover.velocity)
                cells |= sg.point_cells((mover.points[None, :, :] + steps[:, None, None] * v).reshape(-1, 2))
        return dilate(cells, 1) if cells.any() else cells

    def in_movers_way(self, sg: SearchGrid, clearance_m: float) -> np.ndarray:
        """mover_paths grown by the robot's `clearance_m`: no place to stop and look from, the robot's own
        included (a viewpoint beside the robot in a cart's path had it drive along in front of the cart)."""
        paths = self.mover_paths(sg)
        if not paths.any():
            return paths
        return dilate(paths, math.ceil(clearance_m / sg.resolution))

    def ahead_of_movers(self, sg: SearchGrid, robot: Pose2D, clearance_m: float) -> np.ndarray:
        """in_movers_way without the robot's own surroundings: where not to drive (it must be able to drive
        off from where it stands, even just in front of a cart)."""
        ahead = self.in_movers_way(sg, clearance_m)
        if not ahead.any():
            return ahead
        xs, ys = sg.centres()
        return ahead & (np.hypot(xs - robot.x, ys - robot.y) > clearance_m + sg.resolution)

    def with_room_to_leave(
        self, sg: SearchGrid, robot: Pose2D, drivable: np.ndarray, solid: np.ndarray, clearance_m: float
    ) -> np.ndarray:
        """`drivable` and the cells within `clearance_m` (and a cell) of the robot that nothing `solid` is in:
        what to measure the way from the robot through. Where the robot stands is free whatever the masks say,
        and it must be able to drive off: with its pose estimated 0.1–0.2 m off (AMCL under `typical`), the
        robot beside a wall was inside the wall's margin, and the lidar's returns of that wall, drawn from the
        estimated pose, fell in cells the map holds free; every cell round it was then undrivable, and SEARCH b
        swept the same place six times in 24 s (follow_occlusion seed 1019, `typical`)."""
        xs, ys = sg.centres()
        near = np.hypot(xs - robot.x, ys - robot.y) <= clearance_m + sg.resolution
        return drivable | (near & ~solid)

    # -- the belief ---------------------------------------------------------------------------------
    def belief(
        self,
        track: TargetTrack,
        speed_mps: float | None = None,
        view_range_m: float | None = None,
    ) -> TargetBelief | None:
        """This loss's belief (made now if no leaf made it yet), brought up to this tick's camera view.

        `speed_mps` / `view_range_m`, when given, are the ones the rest of the loss uses (SearchBelief's
        ports); until then the belief grows at DEFAULT_SPEED_MPS. None without a map or a robot pose."""
        state = self.robot()
        sg = self.grid()
        if state is None or sg is None or track.last_seen is None or track.pose_map is None:
            return None
        beliefs: dict[str, TargetBelief] = dict(self.read(bbk.BELIEFS) or {})
        belief = beliefs.get(track.name)
        now = self.now()
        if belief is None or belief.episode != track.last_seen or belief.grid is not sg:
            last = (float(track.pose_map[0, 3]), float(track.pose_map[1, 3]))
            belief = TargetBelief.start(
                track.name,
                track.last_seen,
                last,
                fitted_velocity(track, HEADING_WINDOW_S, steady=True),
                sg,
                now,
                speed_mps=DEFAULT_SPEED_MPS if speed_mps is None else speed_mps,
                view_range_m=DEFAULT_VIEW_RANGE_M if view_range_m is None else view_range_m,
            )
            beliefs[track.name] = belief
            self.write(bbk.BELIEFS, beliefs)
            self._looked_at = None
        if speed_mps is not None:
            belief.speed_mps = speed_mps
        if view_range_m is not None:
            belief.view_range_m = view_range_m
        if self._looked_at != now:
            cx, cy, yaw = self.camera_pose(state.pose)
            belief.look(now, (cx, cy), yaw, self.hfov(), self.sight_blocked(sg, state.pose))
            self._looked_at = now
        return belief


def turn_rate(error: float, max_rate: float, min_rate: float = 0.25) -> float:
    """A turn command toward `error` (rad): proportional near the end, `max_rate` far from it."""
    rate = min(max_rate, max(min_rate, 2.0 * abs(error)))
    return math.copysign(rate, error)


def predicted_walk(
    sg: SearchGrid, free: np.ndarray, track: TargetTrack, horizon_s: float
) -> tuple[tuple[float, float], tuple[float, float]]:
    """(last position, where the target is after walking on along its last velocity for `horizon_s`, stopped
    at the first place it cannot walk through). The same point twice when it stood still.

    A last position inside the margin `free` keeps round the map's obstacles (a placing off by the
    localisation's few centimetres in a doorway, or the marker on the target's face rather than at its
    centre) walks on through that margin, stopped by the obstacles themselves: stopped at its first cell,
    the walk was taken for a target that stood still (two_rooms seed 1012, typical: placed 0.28 m off in
    the doorway it was walking through, LOST looked the other way)."""
    assert track.pose_map is not None
    last = (float(track.pose_map[0, 3]), float(track.pose_map[1, 3]))
    v = fitted_velocity(track, HEADING_WINDOW_S, steady=True)
    if v is None:
        return last, last
    end = (last[0] + v[0] * horizon_s, last[1] + v[1] * horizon_s)
    r, c = sg.cell(*last)
    inside = 0 <= r < free.shape[0] and 0 <= c < free.shape[1]
    if inside and not free[r, c]:
        free = free | sg.target_free(0.0)
    return last, walk(free, sg, last, end)
