"""Mission metrics from ground truth, tick by tick: the design notes' success criteria, measured.

The recorder only needs what any simulated world can give (a ground-truth sample per tick) and what the
tree wrote on the blackboard (state, goal, tracks). It knows nothing about pybullet.
"""

from __future__ import annotations

import math
from array import array
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np

from mission.core import blackboard as bbk
from mission.core import se3
from mission.core.blackboard import MissionState
from mission.core.docking import dock_offsets
from mission.core.observers import RunObserver, Tick
from mission.core.types import NavGoal, Pose2D, TargetTrack

RANGE_BUCKETS = ((0.0, 1.0), (1.0, 2.0), (2.0, 3.0), (3.0, 5.0), (5.0, 100.0))
LOSS_STATES = (MissionState.LOST, MissionState.SEARCH)
TRACKING_STATES = (MissionState.FOLLOW, *LOSS_STATES)  # the coordinator is in charge
TARGET = "target"  # the followed target's name (perception.targets): the one ground truth's target is
OCCLUSION_MIN_S = 0.5  # an occlusion this long must be detected (the design notes' latency bound)


class GroundTruthSample(Protocol):
    """The ground truth a world gives per tick (mission.sim.ground_truth.GroundTruth satisfies it)."""

    stamp: float
    robot: Pose2D
    T_map_optical: np.ndarray
    target: Pose2D | None
    target_moving: bool
    T_map_target_marker: np.ndarray | None
    target_in_los: bool
    target_in_fov: bool
    T_map_dock: np.ndarray | None
    collisions: int


@dataclass
class DockErrors:
    """How far a dock ended from the wanted pose (magnitudes; signed offsets come from mission.core.docking)."""

    lateral_m: float
    distance_m: float  # |stand-off − wanted stand-off|
    standoff_m: float  # measured stand-off (camera optical centre to tag plane along its normal)
    skew_deg: float

    def within(self, lateral: float = 0.03, distance: float = 0.025, skew_deg: float = 10.0) -> bool:
        return self.lateral_m <= lateral and self.distance_m <= distance and self.skew_deg <= skew_deg


def dock_errors(T_map_optical: np.ndarray, T_map_dock: np.ndarray, robot_yaw: float, standoff: float) -> DockErrors:
    """Docking errors of the camera relative to the tag, from ground truth.

    Measured with the same geometry the docking behaviours steer by (mission.core.docking.dock_offsets),
    so the score and the controller cannot disagree about what "docked" means.
    """
    off = dock_offsets(T_map_optical, T_map_dock, robot_yaw)
    return DockErrors(
        lateral_m=abs(off.lateral_m),
        distance_m=abs(off.standoff_m - standoff),
        standoff_m=off.standoff_m,
        skew_deg=abs(off.skew_deg),
    )


@dataclass
class LossEvent:
    start: float
    state: str  # the first loss state entered (LOST or SEARCH)
    end: float | None = None  # back in FOLLOW

    @property
    def recovered(self) -> bool:
        return self.end is not None


@dataclass
class Occlusion:
    """Ground truth: the line of sight to the target broke while the tree was following it.

    Detected means the tree said so — entered LOST (the occlusion state); going to SEARCH instead is a
    misclassification ("it left the view"), not a detection. A tree can call LOST a moment before the
    marker's centre is hidden (the marker's edge goes first, or the target turns away behind the obstacle):
    that occlusion counts, detected with latency 0. A sight line that breaks during SEARCH is not an
    occlusion of a followed target. The other way round, ground truth's line to the marker's centre can
    graze an edge while the camera still reads the whole marker (the target walking past a door frame):
    until the camera stops detecting it the tree cannot know, so the occlusion starts at the last detection
    of the target when that comes after the line broke.
    """

    start: float  # ground truth: line of sight blocked while following (or already LOST)
    end: float | None = None  # line of sight clear again
    detected_at: float | None = None  # the tree entered LOST (= start when it was LOST before the line broke)


def _floats() -> array:
    return array("d")


def _flags() -> array:
    return array("b")


@dataclass
class MetricsRecorder(RunObserver):
    """An observer of the run, fed once per tick with the world's ground truth; read `summary()` at the end.

    The per-tick history (for the report's pictures) is kept in packed arrays, ~60 bytes a tick, so a
    30-minute soak grows by ~2 MB instead of the ~15 MB that lists of tuples of floats cost. A missing
    target is NaN in ``target_x``/``target_y``/``target_distance``.
    """

    dock_standoff_m: float = 0.30
    times: array = field(default_factory=_floats)
    robot_x: array = field(default_factory=_floats)
    robot_y: array = field(default_factory=_floats)
    target_x: array = field(default_factory=_floats)
    target_y: array = field(default_factory=_floats)
    states: list[str] = field(default_factory=list)  # references to the few state strings
    los: array = field(default_factory=_flags)
    fov: array = field(default_factory=_flags)
    target_distance: array = field(default_factory=_floats)
    transitions: list[tuple[float, str]] = field(default_factory=list)
    losses: list[LossEvent] = field(default_factory=list)
    occlusions: list[Occlusion] = field(default_factory=list)
    # follow goals: time, x, y, and whether the target stood still (1) — one entry per new goal
    goal_t: array = field(default_factory=_floats)
    goal_x: array = field(default_factory=_floats)
    goal_y: array = field(default_factory=_floats)
    goal_still: array = field(default_factory=_flags)
    pose_errors: dict[str, tuple[array, array]] = field(default_factory=dict)  # name → (ranges m, errors m)
    dock: DockErrors | None = None
    collisions: int = 0
    target_gone_at: float | None = None  # ground truth: the target left the map (GroundTruth.target_gone)
    gave_up_at: float | None = None  # the tree went from a loss state to FAILED (the search gave up)
    gave_up_loss_start: float | None = None  # when that loss began
    _last_goal_seq: int = -1
    _last_det_stamp: dict[str, float] = field(default_factory=dict)
    _target_seen: float | None = None  # stamp of the followed target's newest detection
    last_ground_truth: GroundTruthSample | None = None

    def on_tick(self, run: Any, tick: Tick) -> None:
        if tick.ground_truth is None:  # a world without ground truth (ROS, a bag): nothing to measure
            return
        self.last_ground_truth = tick.ground_truth
        self.record(tick.ground_truth, run.get(bbk.STATE, ""), run.get(bbk.NAV_GOAL), run.get(bbk.TRACKS))

    def record(
        self,
        gt: GroundTruthSample,
        state: str,
        nav_goal: NavGoal | None,
        tracks: dict[str, TargetTrack] | None,
    ) -> None:
        t = gt.stamp
        prev = self.states[-1] if self.states else ""
        self.times.append(t)
        self.robot_x.append(gt.robot.x)
        self.robot_y.append(gt.robot.y)
        self.target_x.append(math.nan if gt.target is None else gt.target.x)
        self.target_y.append(math.nan if gt.target is None else gt.target.y)
        self.states.append(state)
        self.los.append(bool(gt.target_in_los))
        self.fov.append(bool(gt.target_in_fov))
        self.target_distance.append(math.nan if gt.target is None else gt.robot.distance_to(gt.target))
        self.collisions = int(gt.collisions)
        if self.target_gone_at is None and getattr(gt, "target_gone", False):
            self.target_gone_at = t
        if state != prev:
            self.transitions.append((t, state))
            self._on_transition(t, prev, state, gt)
        self._track_occlusion(t, state, gt, self._target_detected(tracks))
        if nav_goal is not None and nav_goal.seq != self._last_goal_seq:
            self._last_goal_seq = nav_goal.seq
            if state == MissionState.FOLLOW:
                self.goal_t.append(t)
                self.goal_x.append(nav_goal.pose.x)
                self.goal_y.append(nav_goal.pose.y)
                self.goal_still.append(not gt.target_moving)
        for name, track in (tracks or {}).items():
            self._record_pose_error(name, track, gt)

    def _on_transition(self, t: float, prev: str, state: str, gt: GroundTruthSample) -> None:
        if state in LOSS_STATES and prev not in LOSS_STATES:
            self.losses.append(LossEvent(start=t, state=state))
        if state == MissionState.FAILED and prev in LOSS_STATES and self.gave_up_at is None and self.losses:
            self.gave_up_at, self.gave_up_loss_start = t, self.losses[-1].start
        if state == MissionState.FOLLOW and self.losses and self.losses[-1].end is None:
            self.losses[-1].end = t
        if prev == MissionState.DOCK and state != MissionState.FAILED and gt.T_map_dock is not None:
            self.dock = dock_errors(gt.T_map_optical, gt.T_map_dock, gt.robot.yaw, self.dock_standoff_m)

    def _target_detected(self, tracks: dict[str, TargetTrack] | None) -> float | None:
        """The stamp of a detection of the followed target new this tick (None: no new one)."""
        track = (tracks or {}).get(TARGET)
        det = None if track is None else track.detection
        if det is None or det.stamp == self._target_seen:
            return None
        self._target_seen = det.stamp
        return det.stamp

    def _track_occlusion(self, t: float, state: str, gt: GroundTruthSample, detected: float | None = None) -> None:
        open_occ = self.occlusions[-1] if self.occlusions and self.occlusions[-1].end is None else None
        if open_occ is not None and open_occ.detected_at is None and detected is not None:
            open_occ.start = max(open_occ.start, min(detected, t))  # still seen: not hidden from the camera yet
        if open_occ is None and not gt.target_in_los and gt.target is not None:
            prev_los = self.los[-2] if len(self.los) > 1 else True
            if prev_los and state == MissionState.FOLLOW:
                self.occlusions.append(Occlusion(start=t))
            elif prev_los and state == MissionState.LOST:  # called before the sight line broke: latency 0
                self.occlusions.append(Occlusion(start=t, detected_at=t))
            return
        if open_occ is not None:
            if open_occ.detected_at is None and state == MissionState.LOST:
                open_occ.detected_at = t
            if gt.target_in_los:
                open_occ.end = t

    def _record_pose_error(self, name: str, track: TargetTrack, gt: GroundTruthSample) -> None:
        det = track.detection
        if det is None or self._last_det_stamp.get(name) == det.stamp:
            return
        self._last_det_stamp[name] = det.stamp
        truth = gt.T_map_dock if name == "dock" else gt.T_map_target_marker
        if truth is None:
            return
        est = se3.apply(gt.T_map_optical, det.position)
        rng = float(np.linalg.norm(truth[:3, 3] - gt.T_map_optical[:3, 3]))
        ranges, errors = self.pose_errors.setdefault(name, (_floats(), _floats()))
        ranges.append(rng)
        errors.append(float(np.linalg.norm(est - truth[:3, 3])))

    def finish(self, gt: GroundTruthSample | None, final_state: str, tree_failed: bool = False) -> None:
        """Close open events at the end of the run (a dock that ends the run is measured here; a tree that
        failed while the target was lost gave up then, whatever state its last leaf wrote)."""
        lost = final_state in (*LOSS_STATES, MissionState.FAILED)
        if tree_failed and lost and self.gave_up_at is None and self.losses and self.times:
            self.gave_up_at, self.gave_up_loss_start = self.times[-1], self.losses[-1].start
        docked = final_state in (MissionState.DONE, MissionState.DOCK)
        if gt is not None and self.dock is None and docked and gt.T_map_dock is not None:
            self.dock = dock_errors(gt.T_map_optical, gt.T_map_dock, gt.robot.yaw, self.dock_standoff_m)

    # -- the history as arrays ------------------------------------------------------------------------
    @property
    def robot_xy(self) -> np.ndarray:
        """(N, 2) robot positions, one per tick."""
        return _xy(self.robot_x, self.robot_y)

    @property
    def target_xy(self) -> np.ndarray:
        """(N, 2) target positions, one per tick; NaN rows where the world has no target."""
        return _xy(self.target_x, self.target_y)

    # -- summary -----------------------------------------------------------------------------------
    def goal_jitter_sd(self) -> float | None:
        """Largest s.d. (m) of follow goals within one stretch where the target stood still (≥ 5 goals)."""
        still = np.array(self.goal_still, dtype=bool)
        xy = _xy(self.goal_x, self.goal_y)
        sds = []
        for run in _runs(still):
            if len(run) >= 5:
                a = xy[run[2:]]  # skip the first goals while the average settles
                sds.append(float(math.sqrt(a[:, 0].var() + a[:, 1].var())))
        return max(sds) if sds else None

    def tracking(self) -> tuple[float, float]:
        """(seconds in FOLLOW with the target in view, seconds of the follow phase): the follow phase runs
        from the first tick the coordinator was in charge (FOLLOW, LOST or SEARCH) to the end of the run;
        "in view" is ground truth's — in the field of view and in line of sight."""
        start = next((i for i, s in enumerate(self.states) if s in TRACKING_STATES), None)
        if start is None or len(self.times) < 2:
            return 0.0, 0.0
        tracked = 0.0
        for i in range(start, len(self.times) - 1):
            if self.states[i] == MissionState.FOLLOW and self.los[i] and self.fov[i]:
                tracked += self.times[i + 1] - self.times[i]
        return tracked, self.times[-1] - self.times[start]

    def summary(self, duration: float) -> dict[str, Any]:
        latencies = [o.detected_at - o.start for o in self.occlusions if o.detected_at is not None]
        long_occl = [o for o in self.occlusions if (o.end or duration) - o.start >= OCCLUSION_MIN_S]
        missed = [o for o in long_occl if o.detected_at is None]
        reacq = [e.end - e.start for e in self.losses if e.end is not None]
        open_losses = [e for e in self.losses if e.end is None]
        pose: dict[str, Any] = {}
        for name, (ranges, errors) in self.pose_errors.items():
            r, e = np.array(ranges, dtype=float), np.array(errors, dtype=float)
            buckets = {}
            for lo, hi in RANGE_BUCKETS:
                inside = (r >= lo) & (r < hi) & (r > 0)
                errs = 100.0 * e[inside] / r[inside]
                if len(errs):
                    buckets[f"{lo:g}-{hi:g}m"] = {
                        "n": len(errs),
                        "median_pct": round(float(np.median(errs)), 3),
                        "p90_pct": round(float(np.percentile(errs, 90)), 3),
                    }
            pose[name] = buckets
        time_in: dict[str, float] = {}
        for i in range(1, len(self.times)):
            time_in[self.states[i - 1]] = time_in.get(self.states[i - 1], 0.0) + self.times[i] - self.times[i - 1]
        return {
            "duration_s": round(duration, 3),
            "state_transitions": [{"t": round(t, 3), "state": s} for t, s in self.transitions],
            "time_in_state_s": {k: round(v, 2) for k, v in time_in.items() if k},
            "occlusions": len(self.occlusions),
            "occlusions_over_0_5s": len(long_occl),
            "occlusions_detected": len(latencies),
            "occlusions_missed": len(missed),
            "occlusion_detection_latency_s": _stats(latencies),
            "loss_events": len(self.losses),
            "loss_events_recovered": len(self.losses) - len(open_losses),
            "loss_recovery_fraction": None if not self.losses else round(1 - len(open_losses) / len(self.losses), 3),
            "reacquisition_time_s": _stats(reacq),
            "goal_jitter_sd_m": _round(self.goal_jitter_sd()),
            **self._tracking_summary(),
            **self._give_up_summary(),
            "detection_pose_error_by_range": pose,
            "dock": None if self.dock is None else {k: round(v, 4) for k, v in self.dock.__dict__.items()},
            "collisions": self.collisions,
        }

    def _tracking_summary(self) -> dict[str, Any]:
        tracked, phase = self.tracking()
        return {
            "tracking_s": round(tracked, 2),
            "follow_phase_s": round(phase, 2),
            "tracking_fraction": round(tracked / phase, 3) if phase > 0 else None,
        }

    def _give_up_summary(self) -> dict[str, Any]:
        """When the target left the map and when (and how long after) the search gave up."""
        out: dict[str, Any] = {
            "target_gone_at_s": _round(self.target_gone_at, 3),
            "gave_up_at_s": None,
            "give_up_after_loss_s": None,
            "give_up_after_gone_s": None,
        }
        if self.gave_up_at is not None:
            out["gave_up_at_s"] = round(self.gave_up_at, 3)
            if self.gave_up_loss_start is not None:
                out["give_up_after_loss_s"] = round(self.gave_up_at - self.gave_up_loss_start, 3)
            if self.target_gone_at is not None:
                out["give_up_after_gone_s"] = round(self.gave_up_at - self.target_gone_at, 3)
        return out


def _xy(xs: array, ys: array) -> np.ndarray:
    """(N, 2) float copy of two packed columns (a copy: the arrays keep growing while it is in use)."""
    return np.column_stack([np.array(xs, dtype=float), np.array(ys, dtype=float)]).reshape(-1, 2)


def _runs(flags: np.ndarray) -> list[np.ndarray]:
    """Index arrays of the maximal stretches where `flags` is true."""
    edges = np.diff(np.concatenate([[0], flags.astype(np.int8), [0]]))
    return [np.arange(a, b) for a, b in zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1), strict=True)]


def _round(v: float | None, nd: int = 4) -> float | None:
    return None if v is None else round(v, nd)


def _stats(values: list[float]) -> dict[str, float] | None:
    if not values:
        return None
    a = np.asarray(values)
    return {
        "n": len(values),
        "median": round(float(np.median(a)), 3),
        "max": round(float(a.max()), 3),
        "mean": round(float(a.mean()), 3),
    }
