"""PerceiveTargets: the newest camera frame → detections → per-target tracks on the blackboard.

Runs once per new FRAME_SEQ (ticking faster than the camera does not count extra misses). Bad input
never stops the tree: a frame whose image is not an image is dropped and counted (``frames_dropped``),
a frame older than the last processed one (late, out of order — or older than ``max_frame_age_s`` on the
clock when set) is dropped and counted (``frames_stale``), the same frame re-sent is dropped and counted
(``frames_duplicate``) — stale detections never move a goal — and a source that
raises is isolated — counted as ``source_errors:<name>``, logged once per (source, exception type), the
other sources' detections still land, and the leaf returns FAILURE for that tick only.

Tracks (TargetTrack, one per configured target) keep last_seen, consecutive misses, the last detection,
its map pose ``T_map_target = planar(robot) @ CAMERA_EXTRINSICS @ T_optical_marker``, a short position
history, and an edge-triggered ``visible`` flag that flips only on transitions (counted).
"""

from __future__ import annotations

import logging
from typing import ClassVar

import numpy as np
import py_trees

from mission.behaviours.leaf import MissionLeaf
from mission.behaviours.ports import Dependencies
from mission.behaviours.target_matching import SourcedDetection, assign, detection_problem
from mission.core import blackboard as bbk
from mission.core import se3
from mission.core.types import Detection, Frame, RobotState, TargetTrack

log = logging.getLogger(__name__)

HISTORY_S = 2.0  # how far back a track keeps map positions (goal smoothing, velocity for LOS prediction)
HISTORY_MAX = 60


def frame_problem(frame: object) -> str | None:
    """Why a frame cannot be processed (None when it looks like an image)."""
    if not isinstance(frame, Frame):
        return f"got {type(frame).__name__}, expected Frame"
    img = frame.image
    if not isinstance(img, np.ndarray):
        return f"image is {type(img).__name__}, expected an H×W or H×W×3 ndarray"
    # What every source accepts (Frame's contract): checked here so a 16-bit or BGRA frame from an adapter
    # is one dropped frame with its reason, not an error raised by each source in turn.
    if img.ndim not in (2, 3) or (img.ndim == 3 and img.shape[2] not in (1, 3)) or img.size == 0:
        return f"image has shape {img.shape}, expected H×W or H×W×3"
    if img.dtype != np.uint8:
        return f"image has dtype {img.dtype}, expected uint8"
    try:
        stamp = float(frame.stamp)
    except (TypeError, ValueError):
        return f"stamp {frame.stamp!r} is not a number"
    if not np.isfinite(stamp):
        return f"stamp {stamp} is not finite"
    return None


def target_pose_map(robot: RobotState, T_base_optical: np.ndarray, det: Detection) -> np.ndarray:
    """T_map_target: the detection's camera-frame pose carried through the robot pose and the extrinsics."""
    p = robot.pose
    return se3.compose(se3.planar(p.x, p.y, p.yaw), T_base_optical, se3.from_pos_quat(det.position, det.orientation))


class PerceiveTargets(MissionLeaf):
    """Run the injected perception sources on the newest frame and keep per-target tracks.

    SUCCESS when the frame was processed (or there was nothing new); FAILURE for a tick in which a source
    raised or the frame was unusable. Trees wrap it in ForceSuccess so perception trouble never stops a
    mission by itself — the tracks simply stop being refreshed.
    """

    NODE_TYPE = "Action"
    # Frames older than this on CLOCK are stale (s); 0 = off: ROS camera stamps need not share CLOCK's time
    # base. Set on the instance (``node.max_frame_age_s = 0.5``); not a port, so the catalogue is unchanged.
    MAX_FRAME_AGE_S: ClassVar[float] = 0.0
    READS = (bbk.FRAME, bbk.FRAME_SEQ)
    WRITES = (bbk.DETECTIONS, bbk.TRACKS, bbk.PERCEPTION_STATS)

    def __init__(self, name: str = "PerceiveTargets", *, deps: Dependencies | None = None) -> None:
        super().__init__(name)
        self.deps = deps if deps is not None else Dependencies()
        self.max_frame_age_s = self.MAX_FRAME_AGE_S
        self._last_key: object = None
        self._last_stamp: float | None = None
        self._last_image: object = None
        self._logged: set[tuple[str, str]] = set()

    def setup(self, **kwargs: object) -> None:
        """Check the injected sources look like PerceptionSources (wiring, before the first tick)."""
        for src in self.deps.sources:
            if not callable(getattr(src, "process", None)):
                raise TypeError(f"{self.name}: perception source {src!r} has no process(frame) method")

    # -- helpers --------------------------------------------------------------------------------------
    @staticmethod
    def source_name(src: object) -> str:
        return str(getattr(src, "name", None) or type(src).__name__)

    def _log_once(self, who: str, kind: str, msg: str) -> None:
        if (who, kind) not in self._logged:
            self._logged.add((who, kind))
            log.warning("%s: %s (further %s from %s are counted, not logged)", self.name, msg, kind, who)

    def _stats(self) -> dict[str, int]:
        stats = self.read(bbk.PERCEPTION_STATS)
        if not isinstance(stats, dict):
            stats = {}
        return stats

    def _tracks(self) -> dict[str, TargetTrack]:
        tracks = self.read(bbk.TRACKS)
        if not isinstance(tracks, dict):
            tracks = {}
        for name in self.deps.targets:
            tracks.setdefault(name, TargetTrack(name=name))
        return tracks

    def _run_sources(self, frame: Frame, stats: dict[str, int]) -> tuple[list[SourcedDetection], list[str]]:
        found: list[SourcedDetection] = []
        errors: list[str] = []
        for src in self.deps.sources:
            who = self.source_name(src)
            try:
                out = src.process(frame)
                if not isinstance(out, list | tuple):
                    raise TypeError(f"process() returned {type(out).__name__}, expected list[Detection]")
            except Exception as err:  # isolate any plugin failure: count, log once per kind, keep going
                key = f"source_errors:{who}"
                stats[key] = stats.get(key, 0) + 1
                text = f"source {who!r} raised {type(err).__name__}: {err}"
                self._log_once(who, type(err).__name__, text)
                errors.append(text)
                continue
            for det in out:
                problem = detection_problem(det)
                if problem is not None:
                    stats["detections_invalid"] = stats.get("detections_invalid", 0) + 1
                    self._log_once(who, "invalid detection", f"source {who!r} gave an unusable detection: {problem}")
                    continue
                found.append(SourcedDetection(who, det))
        return found, errors

    def _stale_reason(self, frame: Frame, stamp: float) -> str | None:
        """Why a frame must not drive the robot although its image is fine (None: use it).

        A frame older than the newest processed one arrived late or out of order: its detections would
        place the target where it was, not where it is. The same image again with the same stamp is a
        duplicate (a driver re-sending). With ``max_frame_age_s`` > 0 a frame older than that on the
        clock is stale too (only meaningful when frame stamps and CLOCK share a time base).
        """
        last = self._last_stamp
        if last is not None and stamp < last:
            return f"stale (late or out of order: stamp {stamp:.3f} s is older than the last processed {last:.3f} s)"
        if last is not None and stamp == last and frame.image is self._last_image:
            return f"duplicate (same image and stamp {stamp:.3f} s as the last processed)"
        if self.max_frame_age_s > 0:
            age = self.now() - stamp
            if age > self.max_frame_age_s:
                return f"stale (stamp {stamp:.3f} s is {age:.2f} s old > max_frame_age_s {self.max_frame_age_s:g})"
        return None

    # -- lifecycle ------------------------------------------------------------------------------------
    def update(self) -> py_trees.common.Status:
        frame = self.read(bbk.FRAME)
        seq = self.read(bbk.FRAME_SEQ)
        if frame is None:
            self.feedback_message = "no camera frame yet"
            return py_trees.common.Status.SUCCESS
        key = seq if seq is not None else id(frame)
        if key == self._last_key:
            self.feedback_message = f"waiting for a new frame (frame {seq} already processed)"
            return py_trees.common.Status.SUCCESS
        self._last_key = key
        stats = self._stats()

        problem = frame_problem(frame)
        if problem is not None:
            stats["frames_dropped"] = stats.get("frames_dropped", 0) + 1
            self.write(bbk.PERCEPTION_STATS, stats)
            self._log_once("frame", problem.split(" ")[0], f"dropped frame {seq}: {problem}")
            self.feedback_message = f"dropped frame {seq}: {problem}"
            return py_trees.common.Status.FAILURE
        stamp = float(frame.stamp)
        why = self._stale_reason(frame, stamp)
        if why is not None:
            counter = "frames_duplicate" if why.startswith("duplicate") else "frames_stale"
            stats[counter] = stats.get(counter, 0) + 1
            self.write(bbk.PERCEPTION_STATS, stats)
            self.feedback_message = f"dropped {why} frame {seq} ({stats[counter]} {counter[7:]} so far)"
            return py_trees.common.Status.SUCCESS
        self._last_stamp = stamp
        self._last_image = frame.image

        found, errors = self._run_sources(frame, stats)
        result = assign(found, dict(self.deps.targets), self.deps.policy)
        if result.coarse_dropped:
            stats["coarse_dropped"] = stats.get("coarse_dropped", 0) + result.coarse_dropped
        tracks = self._tracks()
        notes = self._update_tracks(tracks, result.best, stamp)
        stats["frames_processed"] = stats.get("frames_processed", 0) + 1
        self.write(bbk.DETECTIONS, [d.det for d in result.kept])
        self.write(bbk.TRACKS, tracks)
        self.write(bbk.PERCEPTION_STATS, stats)

        summary = f"frame {seq} @ {stamp:.2f} s: {len(result.kept)} detection(s)"
        if notes:
            summary += "; " + ", ".join(notes)
        if errors:
            self.feedback_message = f"{summary}; " + "; ".join(errors)
            return py_trees.common.Status.FAILURE
        self.feedback_message = summary
        return py_trees.common.Status.SUCCESS

    def _update_tracks(
        self, tracks: dict[str, TargetTrack], best: dict[str, SourcedDetection], stamp: float
    ) -> list[str]:
        robot = self.robot()
        notes: list[str] = []
        if self.read(bbk.CAMERA_EXTRINSICS) is None:
            notes.append("no camera extrinsics (camera assumed at the base origin)")
        extrinsics = self.extrinsics()
        for name in self.deps.targets:
            tr = tracks[name]
            hit = best.get(name)
            if hit is None:
                tr.misses += 1
                if tr.visible:
                    tr.visible = False
                    tr.transitions += 1
                notes.append(f"{name} missed ×{tr.misses}" if tr.last_seen is not None else f"{name} not seen yet")
                continue
            det = hit.det
            tr.misses = 0
            tr.last_seen = stamp
            tr.detection = det
            if not tr.visible:
                tr.visible = True
                tr.transitions += 1
            if robot is None:
                tr.pose_map = None
                tr.robot_at_last_seen = None
                notes.append(f"{name} seen {det.distance:.2f} m by {hit.source} (no robot pose: not placed in the map)")
                continue
            tr.pose_map = target_pose_map(robot, extrinsics, det)
            tr.robot_at_last_seen = robot.pose
            tr.history.append((stamp, float(tr.pose_map[0, 3]), float(tr.pose_map[1, 3])))
            tr.history[:] = [h for h in tr.history[-HISTORY_MAX:] if h[0] >= stamp - HISTORY_S]
            notes.append(
                f"{name} seen {det.distance:.2f} m by {hit.source} "
                f"at ({tr.pose_map[0, 3]:.2f}, {tr.pose_map[1, 3]:.2f})"
            )
        return notes
