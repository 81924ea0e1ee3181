"""A detector other than the robot's camera — a person tracker, another robot reporting where the target is —
as a scenario's ``external_detector`` describes it: at its own rate, it reports the target's pose when the
target is in line of sight of the robot's camera (all round) and in range, with seeded noise and dropouts.

One model for both worlds: ``mission sim-robot`` publishes its reports on a topic and as a TF frame (what a
node in server mode follows for a FollowObject goal), and the in-process simulation hands them to perception
on the next camera frame (``Frame.sightings``), so the same follow_object.xml runs in either and the two can be
compared run by run.
"""

from __future__ import annotations

import math

import numpy as np

from mission.core import se3
from mission.sim.ground_truth import GroundTruth
from mission.sim.scenario import ExternalDetector

REPORT_HEIGHT_M = 0.5  # about the height of a tracker's box centre on the target


class DetectorModel:
    """The scenario's external detector, seeded (module doc)."""

    def __init__(self, spec: ExternalDetector, seed: int) -> None:
        self.spec = spec
        self.rng = np.random.default_rng(np.random.SeedSequence([int(seed), 32]))
        self._next = 0.0
        self.reports = 0

    def due(self, t: float) -> bool:
        """Whether a report is due at sim time `t` (the caller then gets the ground truth and asks)."""
        return t >= self._next - 1e-9

    def report(self, gt: GroundTruth, t: float) -> np.ndarray | None:
        """T_map_target this detector reports at `t`, or None (not due, not seen, dropped, silent)."""
        d = self.spec
        if not self.due(t):
            return None
        self._next = t + 1.0 / d.rate_hz
        lost = self.rng.random() < d.dropout  # drawn every period, seen or not: the stream stays seeded
        noise = self.rng.normal(0.0, d.noise_m, 2)
        if gt.target is None or lost or (d.silent_after_s is not None and t >= d.silent_after_s):
            return None
        camera = gt.T_map_optical[:3, 3]
        if math.hypot(gt.target.x - camera[0], gt.target.y - camera[1]) > d.range_m:
            return None
        if d.line_of_sight and not gt.target_in_los:
            return None
        pose = se3.planar(gt.target.x + float(noise[0]), gt.target.y + float(noise[1]), gt.target.yaw)
        pose[2, 3] = REPORT_HEIGHT_M
        self.reports += 1
        return pose
