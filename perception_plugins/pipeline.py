"""The perception stage: the newest camera frame → detections → per-target tracks, between sense and tick.

The runner calls :meth:`PerceptionStage.process` once per new frame (``FRAME_SEQ``) before the tree
ticks, and the ROS node may call it when an image arrives, so detector time is never tree-tick time and
a frame is perceived exactly once however fast the tree ticks. The stage is the one place that:

* checks a frame is usable: an image that is not an image is dropped and counted (``frames_dropped``);
  a frame older than the last processed one (late, out of order, or older than ``max_frame_age_s`` on
  the clock when set) is dropped and counted (``frames_stale``); the same frame re-sent is dropped and
  counted (``frames_duplicate``), so stale detections never move a goal;
* runs every source and isolates a source that raises: counted as ``source_errors:<name>``, logged once
  per (source, exception type); the other sources' detections still land;
* matches detections to the configured targets and applies the source policy (target_matching.py);
* keeps one :class:`~mission.core.types.TargetTrack` per target: last seen, consecutive misses, the last
  detection, its map pose, a short position history and an edge-triggered ``visible`` flag.

A detection is placed in the map with the frame's own ``T_anchor_camera`` — where the camera was when
the image was taken — so a frame that arrives late is placed where it was seen, not where the robot is
now. A world that does not know it (``T_anchor_camera is None``) gets the robot pose at processing
time through the camera extrinsics, and the summary says so.
"""

from __future__ import annotations

import logging
import math

import numpy as np
import py_trees

from mission.core import blackboard as bbk
from mission.core import se3
from mission.core.config import TargetSpec
from mission.core.perception import Perceived, PerceptionSource
from mission.core.types import Detection, Frame, RobotState, TargetTrack
from mission.perception_plugins.target_matching import SourcedDetection, assign, detection_problem

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


def source_name(src: object) -> str:
    """The instance name a source reports under (its ``name``, else its class name)."""
    return str(getattr(src, "name", None) or type(src).__name__)


def source_statuses(sources: list[PerceptionSource]) -> dict[str, dict]:
    """Each source's own account of itself, by name: its ``status()`` where it keeps one (the VLM: state,
    budget, circuit breaker and why it opened, what its model calls cost). For the ROS heartbeat and the
    run report. A status that cannot be read is reported as such, never raised: observers must not fail."""
    out: dict[str, dict] = {}
    for src in sources:
        status = getattr(src, "status", None)
        if not callable(status):
            continue
        try:
            out[source_name(src)] = dict(status())
        except Exception as err:
            out[source_name(src)] = {"status_error": f"{type(err).__name__}: {err}"}
    return out


def _keep_recent(points: list[tuple[float, float, float]], point: tuple[float, float, float]) -> None:
    """Append (stamp, x, y) and drop what is older than HISTORY_S before it (at most HISTORY_MAX kept)."""
    points.append(point)
    points[:] = [h for h in points[-HISTORY_MAX:] if h[0] >= point[0] - HISTORY_S]


def body_centre(
    T_map_target: np.ndarray, T_map_camera: np.ndarray, det: Detection, depth_m: float
) -> tuple[float, float]:
    """The target's centre in the map (x, y): `depth_m` behind what was detected (TargetSpec.body_depth_m).

    A fiducial's pose gives its face's normal (marker z, out of the face): the centre is behind the face along
    it, wherever the target has turned. A coarse source (a VLM's back-projected point) gives no orientation to
    trust, and a marker lying flat no horizontal normal: the centre is then behind the point along the line
    of sight."""
    x, y = float(T_map_target[0, 3]), float(T_map_target[1, 3])
    back = (-float(T_map_target[0, 2]), -float(T_map_target[1, 2]))
    if det.marker_id is None or math.hypot(*back) < 0.5:
        back = (x - float(T_map_camera[0, 3]), y - float(T_map_camera[1, 3]))
    n = math.hypot(*back)
    if n < 1e-6:
        return x, y
    return x + depth_m * back[0] / n, y + depth_m * back[1] / n


class PerceptionStage:
    """Sources → target matching → tracks, once per frame (see the module doc)."""

    def __init__(
        self,
        sources: list[PerceptionSource],
        targets: dict[str, TargetSpec],
        policy: str = "hybrid",
        *,
        max_frame_age_s: float = 0.0,
    ) -> None:
        self.sources = sources  # the runner's list (fault wrappers may replace items in place)
        self.targets = dict(targets)
        self.policy = policy
        # Frames older than this on the clock are stale (s); 0 = off: ROS camera stamps need not share the
        # clock's time base.
        self.max_frame_age_s = float(max_frame_age_s)
        self.tracks: dict[str, TargetTrack] = {name: TargetTrack(name=name) for name in self.targets}
        self.stats: dict[str, int] = {}
        self.last: Perceived | None = None
        self._last_key: object = None  # FRAME_SEQ of the last frame taken from the blackboard
        self._last_stamp: float | None = None
        self._last_image: object = None
        self._logged: set[tuple[str, str]] = set()
        for src in self.sources:
            if not callable(getattr(src, "process", None)):
                raise TypeError(f"perception source {src!r} has no process(frame) method")

    def retarget(self, name: str, spec: TargetSpec) -> None:
        """Look for `name` as `spec` from the next frame on, with a fresh track: an action server's goal names
        the dock to dock at (its tag id), so what was seen of another dock must not count for this one."""
        self.targets[name] = spec
        self.tracks[name] = TargetTrack(name=name)  # in place: the blackboard's TRACKS is this dict

    def reset_time(self) -> None:
        """Forget the newest processed stamp: the clock jumped back (a simulation restarted, a bag looped), so
        frames stamped before it are new again, not stale."""
        self._last_stamp = None
        self._last_image = None

    def update(self, bb: py_trees.blackboard.Client) -> Perceived | None:
        """Perceive the newest frame on the blackboard, unless it was perceived already (None then).

        Reads the frame, the robot state, the extrinsics and the clock the world wrote; writes the
        detections (of a processed frame), the tracks and the counters — merged into whatever counters
        the world keeps there itself (transport drops). Safe to call more than once per tick: the ROS
        node may call it when an image arrives, and the runner again before the tick.
        """
        frame = bbk.get(bb, bbk.FRAME)
        if frame is None:
            return None
        seq = bbk.get(bb, bbk.FRAME_SEQ)
        key = seq if seq is not None else id(frame)
        if key == self._last_key:
            return None
        self._last_key = key
        perceived = self.process(
            frame,
            int(seq or 0),
            robot=bbk.get(bb, bbk.ROBOT_STATE),
            extrinsics=bbk.get(bb, bbk.CAMERA_EXTRINSICS),
            now=bbk.get(bb, bbk.CLOCK),
        )
        if perceived.processed:
            bbk.set_(bb, bbk.DETECTIONS, perceived.detections)
        bbk.set_(bb, bbk.TRACKS, self.tracks)
        counters = bbk.get(bb, bbk.PERCEPTION_STATS)
        stats = dict(counters) if isinstance(counters, dict) else {}
        stats.update(self.stats)
        bbk.set_(bb, bbk.PERCEPTION_STATS, stats)
        return perceived

    def _count(self, key: str, n: int = 1) -> int:
        self.stats[key] = self.stats.get(key, 0) + n
        return self.stats[key]

    def _log_once(self, who: str, kind: str, msg: str) -> None:
        if (who, kind) not in self._logged:
            self._logged.add((who, kind))
            log.warning("perception: %s (further %s from %s are counted, not logged)", msg, kind, who)

    def _stale_reason(self, frame: Frame, stamp: float, now: float | None) -> str | None:
        """Why a frame must not drive the robot although its image is fine (None: use it).

        A frame older than the newest processed one arrived late or out of order: its detections would
        place the target where it was, not where it is. The same image again with the same stamp is a
        duplicate (a driver re-sending). With ``max_frame_age_s`` > 0 a frame older than that on the
        clock is stale too (only meaningful when frame stamps and the clock share a time base).
        """
        last = self._last_stamp
        if last is not None and stamp < last:
            return f"stale (late or out of order: stamp {stamp:.3f} s is older than the last processed {last:.3f} s)"
        if last is not None and stamp == last and frame.image is self._last_image:
            return f"duplicate (same image and stamp {stamp:.3f} s as the last processed)"
        if self.max_frame_age_s > 0 and now is not None:
            age = now - stamp
            if age > self.max_frame_age_s:
                return f"stale (stamp {stamp:.3f} s is {age:.2f} s old > max_frame_age_s {self.max_frame_age_s:g})"
        return None

    def _run_sources(self, frame: Frame) -> tuple[list[SourcedDetection], list[str]]:
        found: list[SourcedDetection] = []
        errors: list[str] = []
        for src in self.sources:
            who = source_name(src)
            try:
                out = src.process(frame)
                if not isinstance(out, list | tuple):
                    raise TypeError(f"process() returned {type(out).__name__}, expected list[Detection]")
            except Exception as err:  # isolate any plugin failure: count, log once per kind, keep going
                self._count(f"source_errors:{who}")
                text = f"source {who!r} raised {type(err).__name__}: {err}"
                self._log_once(who, type(err).__name__, text)
                errors.append(text)
                continue
            for det in out:
                problem = detection_problem(det)
                if problem is not None:
                    self._count("detections_invalid")
                    self._log_once(who, "invalid detection", f"source {who!r} gave an unusable detection: {problem}")
                    continue
                found.append(SourcedDetection(who, det))
        return found, errors

    def process(
        self,
        frame: object,
        seq: int,
        *,
        robot: RobotState | None,
        extrinsics: np.ndarray | None,
        now: float | None = None,
    ) -> Perceived:
        """Perceive one new frame. `robot` and `extrinsics` (T_base_optical) place detections in the map
        when the frame carries no ``T_anchor_camera``; `now` is the clock, for ``max_frame_age_s``."""
        problem = frame_problem(frame)
        if problem is not None:
            self._count("frames_dropped")
            self._log_once("frame", problem.split(" ")[0], f"dropped frame {seq}: {problem}")
            return self._done(Perceived(None, seq, summary=f"dropped frame {seq}: {problem}", dropped="frames_dropped"))
        assert isinstance(frame, Frame)
        stamp = float(frame.stamp)
        why = self._stale_reason(frame, stamp, now)
        if why is not None:
            counter = "frames_duplicate" if why.startswith("duplicate") else "frames_stale"
            n = self._count(counter)
            return self._done(
                Perceived(frame, seq, summary=f"dropped {why} frame {seq} ({n} {counter[7:]} so far)", dropped=counter)
            )
        self._last_stamp = stamp
        self._last_image = frame.image

        found, errors = self._run_sources(frame)
        result = assign(found, self.targets, self.policy)
        if result.coarse_dropped:
            self._count("coarse_dropped", result.coarse_dropped)
        notes = self._update_tracks(frame, result.best, stamp, robot, extrinsics)
        self._count("frames_processed")
        summary = f"frame {seq} @ {stamp:.2f} s: {len(result.kept)} detection(s)"
        if notes:
            summary += "; " + ", ".join(notes)
        if errors:
            summary += "; " + "; ".join(errors)
        return self._done(Perceived(frame, seq, [d.det for d in result.kept], summary, errors))

    def _done(self, perceived: Perceived) -> Perceived:
        self.last = perceived
        return perceived

    def _camera_in_map(
        self, frame: Frame, robot: RobotState | None, extrinsics: np.ndarray | None, notes: list[str]
    ) -> np.ndarray | None:
        """T_map_camera for this frame: the frame's own, else the robot pose now through the extrinsics."""
        if frame.T_anchor_camera is not None:
            return np.asarray(frame.T_anchor_camera, dtype=np.float64)
        if robot is None:
            return None
        if extrinsics is None:
            notes.append("no camera extrinsics (camera assumed at the base origin)")
            extrinsics = se3.transform(se3.R_BODY_OPTICAL)
        p = robot.pose
        return se3.compose(se3.planar(p.x, p.y, p.yaw), np.asarray(extrinsics, dtype=np.float64))

    def _update_tracks(
        self,
        frame: Frame,
        best: dict[str, SourcedDetection],
        stamp: float,
        robot: RobotState | None,
        extrinsics: np.ndarray | None,
    ) -> list[str]:
        notes: list[str] = []
        T_map_camera = self._camera_in_map(frame, robot, extrinsics, notes) if best else None
        for name in self.targets:
            tr = self.tracks[name]
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
            if T_map_camera is None:
                tr.pose_map = None
                tr.robot_at_last_seen = None
                notes.append(
                    f"{name} seen {det.distance:.2f} m by {hit.source} (no camera pose: not placed in the map)"
                )
                continue
            tr.pose_map = se3.compose(T_map_camera, se3.from_pos_quat(det.position, det.orientation))
            tr.robot_at_last_seen = robot.pose if robot is not None else None
            _keep_recent(tr.history, (stamp, float(tr.pose_map[0, 3]), float(tr.pose_map[1, 3])))
            depth_m = self.targets[name].body_depth_m
            if depth_m > 0:  # at 0 the centre is the marker: the velocity is fitted from `history`
                _keep_recent(tr.centres, (stamp, *body_centre(tr.pose_map, T_map_camera, det, depth_m)))
            notes.append(
                f"{name} seen {det.distance:.2f} m by {hit.source} "
                f"at ({tr.pose_map[0, 3]:.2f}, {tr.pose_map[1, 3]:.2f})"
            )
        return notes
