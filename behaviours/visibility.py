"""IsTargetVisible: is the target being seen right now (tolerating a few dropped frames)?"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import py_trees

from mission.behaviours.leaf import MissionLeaf
from mission.behaviours.line_of_sight import TARGET_RADIUS_M, predicted_position, sight_blockage
from mission.behaviours.ports import port
from mission.behaviours.search_leaf import GLANCE_EDGE_RAD, GLANCE_RANGE_M
from mission.core import blackboard as bbk
from mission.core import se3
from mission.core.docking import floor_pose
from mission.core.types import LaserScan, OccupancyGrid, Pose2D, TargetTrack

# The view's side and the range are the glance's (search_leaf): a target this close inside the side has its marker
# partly off the image (hide_and_wait seed 10, ideal: its place was 1-3° inside when the marker was lost), and one
# farther off does not leave the view because the robot turned a little.
TURNED_RAD = math.radians(1.0)  # the robot's own motion moved the place toward the side by at least this


class IsTargetVisible(MissionLeaf):
    """SUCCESS when the track has been seen and its consecutive misses ≤ max_misses.

    ``max_misses`` lets FOLLOW ride through a few frames where the detector blinks (the design notes ask for
    tolerance of 1–2 frame intermittent occlusions) instead of flickering into LOST/SEARCH.

    ``grace_s`` lets it ride through a loss the robot caused itself: the navigator's path round an obstacle's
    corner turns the robot away from a target at the image's edge, and the target, in clear sight and
    in range, is only off the image's side. Handing over to LOST or SEARCH there turns the robot back,
    FOLLOW turns it away again, and the robot stands at the corner while the target walks on (aisle seed 14,
    ideal: 12 s, then a 10.7 s loss). Counted visible only while the visibility has not lapsed since the last
    sighting, so a search that turns the target's place out of the view does not hand back to FOLLOW.
    """

    @dataclass(frozen=True, kw_only=True)
    class Params:
        target: str = port("target", "name of the target (a key of perception.targets)")
        max_misses: int = port(0, "consecutive missed frames still counted as visible")
        grace_s: float = port(
            0.0,
            "a target the robot's own turn put off the image's side (its place in clear sight, in range) counts "
            "as visible this long after it was last seen; 0 = never",
        )
        visible: bool = port(doc="the answer, as true/false (for scripts and other nodes)", direction="output")
        last_seen_pose: Pose2D = port(
            doc="where the target was last seen (map frame; heading = its face normal's)", direction="output"
        )

        def __post_init__(self) -> None:
            if self.max_misses < 0 or self.grace_s < 0:
                raise ValueError(f"expected max_misses ≥ 0 and grace_s ≥ 0 (got {self.max_misses}, {self.grace_s})")

    NODE_TYPE = "Condition"
    READS = (bbk.TRACKS, bbk.MAP, bbk.SCAN, bbk.FRAME)
    params: Params

    def __init__(self, name: str | None = None, **ports: Any) -> None:
        super().__init__(name, **ports)
        self._lapsed = True  # the answer has been "not visible" since the last sighting

    def update(self) -> py_trees.common.Status:
        target, max_misses = self.params.target, self.params.max_misses
        tr = self.track(target)
        if tr is None or tr.last_seen is None:
            self.set_output("visible", False)
            self._lapsed = True
            self.feedback_message = f"{target} never seen"
            return py_trees.common.Status.FAILURE
        if tr.pose_map is not None and self.output_connected("last_seen_pose"):
            self.set_output("last_seen_pose", floor_pose(tr.pose_map))
        age = self.now() - tr.last_seen
        if tr.misses <= max_misses:
            self._lapsed = False
            self.set_output("visible", True)
            self.feedback_message = f"{target} visible (seen {age:.1f} s ago, {tr.misses} miss(es) ≤ {max_misses})"
            return py_trees.common.Status.SUCCESS
        if not self._lapsed and age <= self.params.grace_s:
            off = self.turned_away_by(tr)
            if off is not None:
                self.set_output("visible", True)
                self.feedback_message = (
                    f"{target} pushed to the image's side by the robot's own turn ({math.degrees(off):+.0f}° past "
                    f"it), in clear sight: counted visible ({age:.1f} of {self.params.grace_s:g} s grace)"
                )
                return py_trees.common.Status.SUCCESS
        self._lapsed = True
        self.set_output("visible", False)
        self.feedback_message = f"{target} not visible: {tr.misses} misses > {max_misses}, last seen {age:.1f} s ago"
        return py_trees.common.Status.FAILURE

    def turned_away_by(self, tr: TargetTrack) -> float | None:
        """How far (rad) past the view's side the robot's own motion has put the target's place (negative:
        still inside, but within GLANCE_EDGE_RAD, where its marker is partly off the image), when that is why it is not
        seen: from where the robot stood at the last sighting the place would be in view, the robot's motion
        since moved it toward the side, it is within GLANCE_RANGE_M, and neither the map nor the lidar puts
        anything between. None otherwise (it walked out of the view, or behind something, or it is well in
        view and simply not detected)."""
        state = self.robot()
        then = tr.robot_at_last_seen
        if state is None or then is None or tr.pose_map is None:
            return None
        last = (float(tr.pose_map[0, 3]), float(tr.pose_map[1, 3]))
        where = predicted_position(tr, self.now()) or last
        half = self.hfov() / 2
        cx, cy, cam_yaw = self.camera_pose(state.pose)
        tx, ty, then_yaw = self.camera_pose(then)
        off_now = abs(se3.wrap_angle(math.atan2(where[1] - cy, where[0] - cx) - cam_yaw)) - half
        off_then = abs(se3.wrap_angle(math.atan2(where[1] - ty, where[0] - tx) - then_yaw)) - half
        if off_then > 0 or off_now <= max(-GLANCE_EDGE_RAD, off_then + TURNED_RAD):
            return None
        if math.hypot(where[0] - cx, where[1] - cy) > GLANCE_RANGE_M:
            return None
        grid: OccupancyGrid | None = self.read(bbk.MAP)
        scan: LaserScan | None = self.read(bbk.SCAN)
        for place in {where, last}:
            if sight_blockage(grid, scan, (cx, cy), state.pose, place, (last, where), TARGET_RADIUS_M) is not None:
                return None
        return off_now
