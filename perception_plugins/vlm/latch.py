"""The one-shot latch of the VLM pipeline: consensus of a few model answers, then a pose held in the
anchor (odom/map) frame; and the circuit breaker that stops calling the model after repeated failed
attempts — no anchor (the design notes' case), or a model call that gave no answer — keeping the reason.

A VLM answer is expensive (a rate-limited, quota-counted remote call) and noisy (~cm to dm), so the
design notes' node asks until `min_consecutive` answers agree within `tolerance_m` *in the anchor frame*
(so the robot may move between answers), then caches anchor←target. From then on the target's pose in
the camera is ``inv(T_anchor_camera_now) @ T_anchor_target`` — no model calls — which is only right for
a static target; `reset()` (the /redetect request) starts over.

An answer read from noisy depth (a stereo camera far away: its error grows with distance squared) carries
its standard error, and its range. Two answers agree when they are within the tolerance, within three of
their combined standard errors, or within the arc a small bearing error spans at their range (a robot's
heading, as AMCL knows it, is off by ~0.02 rad: 12 cm sideways at 6 m). The latch is their mean weighted by
inverse variance, so a far, noisy answer neither blocks the consensus nor drags it.

Pure logic, no threads and no clock: source.py drives it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from mission.core import se3


@dataclass(frozen=True)
class Candidate:
    """One model answer turned into a pose in the anchor frame."""

    T_anchor_target: np.ndarray
    confidence: float
    stamp: float  # of the frame the model saw
    sigma_m: float = 0.0  # the position's standard error from the depth noise (0: as exact as the tolerance)
    range_m: float = 0.0  # how far from the camera it was answered


AGREE_SIGMAS = 3.0  # two answers within this many combined standard errors agree


def agree_within_m(a: Candidate, b: Candidate, tolerance_m: float, bearing_rad: float = 0.0) -> float:
    """How far apart two answers may be and still be the same place: the tolerance; or three combined
    standard errors of their depth noise; or, far away, the arc `bearing_rad` spans at the farther answer's
    range (the robot's heading error between two answers moves a far answer sideways) — whichever is more."""
    return max(tolerance_m, AGREE_SIGMAS * math.hypot(a.sigma_m, b.sigma_m), bearing_rad * max(a.range_m, b.range_m))


def mean_pose(candidates: list[Candidate], floor_sigma_m: float = 0.0) -> np.ndarray:
    """Mean position (weighted by inverse variance, each σ at least `floor_sigma_m`) and chordal-mean
    rotation of candidates.

    The in-plane axis of a rectangular surface is known modulo 90°, so each rotation is first turned
    about its own z by the multiple of 90° that brings it closest to the first candidate's.
    """
    ref = candidates[0].T_anchor_target[:3, :3]
    acc = np.zeros((3, 3))
    for c in candidates:
        r = c.T_anchor_target[:3, :3]
        best = min((r @ se3.rot_z(k * math.pi / 2) for k in range(4)), key=lambda q: se3.rotation_angle(ref, q))
        acc += best
    u, _, vt = np.linalg.svd(acc)
    rot = u @ np.diag([1.0, 1.0, np.sign(np.linalg.det(u @ vt))]) @ vt
    sigmas = np.array([max(c.sigma_m, floor_sigma_m, 1e-6) for c in candidates])
    pos = np.average([c.T_anchor_target[:3, 3] for c in candidates], axis=0, weights=1.0 / sigmas**2)
    return se3.transform(rot, pos)


class OneShotLatch:
    """Consensus → latch, plus the circuit breaker of failed attempts."""

    def __init__(
        self, *, min_consecutive: int, tolerance_m: float, max_failed_attempts: int, bearing_tolerance_rad: float = 0.0
    ) -> None:
        self.min_consecutive = min_consecutive
        self.tolerance_m = tolerance_m
        self.bearing_tolerance_rad = bearing_tolerance_rad
        self.max_failed_attempts = max_failed_attempts
        self.reset()

    def reset(self) -> None:
        """Forget the latch, the candidates and the breaker (a redetect request)."""
        self.run: list[Candidate] = []
        self.T_anchor_target: np.ndarray | None = None
        self.confidence = 0.0
        self.latched_at: float | None = None
        self.failed_attempts = 0
        self.breaker_open = False
        self.breaker_reason = ""  # why the breaker opened ("" while closed)

    @property
    def latched(self) -> bool:
        return self.T_anchor_target is not None

    def add(self, candidate: Candidate) -> bool:
        """Add an answer; True when this answer completed the consensus and the pose is now latched.

        An answer that is farther than the tolerance from any answer of the current run starts a new
        run with itself (the run is of *consecutive* agreeing answers).
        """
        if self.latched:
            return False
        p = candidate.T_anchor_target[:3, 3]
        agrees = all(
            np.linalg.norm(p - c.T_anchor_target[:3, 3])
            <= agree_within_m(candidate, c, self.tolerance_m, self.bearing_tolerance_rad)
            for c in self.run
        )
        self.run = [*self.run, candidate] if agrees else [candidate]
        if len(self.run) < self.min_consecutive:
            return False
        chosen = self.run[-self.min_consecutive :]
        self.T_anchor_target = mean_pose(chosen, floor_sigma_m=self.tolerance_m / AGREE_SIGMAS)
        self.confidence = float(np.mean([c.confidence for c in chosen]))
        self.latched_at = candidate.stamp
        return True

    def spread_m(self) -> float:
        """Largest distance between two answers of the current run (0 with fewer than two)."""
        pts = [c.T_anchor_target[:3, 3] for c in self.run]
        return max((float(np.linalg.norm(a - b)) for i, a in enumerate(pts) for b in pts[i + 1 :]), default=0.0)

    def attempt_failed(self, why: str, *, permanent: bool = False) -> bool:
        """Count a failed attempt (`why`: one line); True when the breaker is open. A `permanent` failure — one
        that every further attempt would repeat — opens it at once."""
        self.failed_attempts += 1
        if not self.breaker_open and (permanent or self.failed_attempts >= self.max_failed_attempts):
            self.breaker_open = True
            count = "" if permanent else f"{self.failed_attempts} consecutive failed attempts, the last: "
            self.breaker_reason = count + why
        return self.breaker_open

    def attempt_ok(self) -> None:
        """An attempt got the model's answer: failures must be consecutive to open the breaker."""
        self.failed_attempts = 0

    def unlatch(self) -> None:
        """Drop the held pose but keep the breaker state (the target moved; ask the model again)."""
        self.run = []
        self.T_anchor_target = None
        self.latched_at = None

    def camera_pose(self, T_anchor_camera: np.ndarray) -> np.ndarray:
        """The latched target in the current camera frame: inv(T_anchor_camera) @ T_anchor_target."""
        assert self.T_anchor_target is not None
        return se3.compose(se3.invert(T_anchor_camera), self.T_anchor_target)
