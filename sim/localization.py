"""Where a real robot thinks it is (issue 33): wheel odometry that drifts, and an AMCL-like corrector that
pulls it back in jumps.

The simulation's base moves exactly; a real robot only knows its wheels. Odometry here integrates each
step's true motion with a seeded scale error on distance and on rotation (a wheel radius a percent off, a
slippery floor), so the error grows with the distance driven. A localizer in the map — AMCL in Nav2 —
corrects it, but only after the robot has moved ``update_min_d`` (0.25 m) or turned ``update_min_a``
(0.2 rad) since its last update (Nav2's amcl defaults), and then with its own noise: the estimate jumps.
Now and then (``relocalize_every_m``) an update lands well off — a particle cloud converging on the wrong
spot for a while — and the next one brings it back: the jump a LOST target's last-seen point must survive.

What the robot believes — ``map → odom`` from the corrector, ``odom → base`` from odometry — is what the tree,
the goals and the simulated navigator see; the ground truth, and so every metric, keeps the true pose.
Each effect is a key of the scenario's ``localization:`` section; all zero (the default) is a perfect
localization, and no estimate is kept at all.
"""

from __future__ import annotations

import math

import numpy as np

from mission.core.types import Pose2D
from mission.sim.scenario import LocalizationSpec


def has_effects(spec: LocalizationSpec) -> bool:
    return spec.odom_scale_error_pct > 0 or spec.odom_yaw_error_pct > 0 or spec.odom_noise_m_per_m > 0


def _wrap(a: float) -> float:
    return math.atan2(math.sin(a), math.cos(a))


def compose(a: Pose2D, b: Pose2D) -> Pose2D:
    """a ∘ b: the pose b, given in a's frame, in a's parent frame."""
    c, s = math.cos(a.yaw), math.sin(a.yaw)
    return Pose2D(a.x + c * b.x - s * b.y, a.y + s * b.x + c * b.y, _wrap(a.yaw + b.yaw))


def inverse(a: Pose2D) -> Pose2D:
    c, s = math.cos(a.yaw), math.sin(a.yaw)
    return Pose2D(-(c * a.x + s * a.y), -(-s * a.x + c * a.y), _wrap(-a.yaw))


def between(a: Pose2D, b: Pose2D) -> Pose2D:
    """b in a's frame: the motion from a to b."""
    return compose(inverse(a), b)


class Localization:
    """The robot's belief about its pose: drifting odometry and a jumping corrector (module doc)."""

    def __init__(self, spec: LocalizationSpec, start: Pose2D, seed: int) -> None:
        self.spec = spec
        rng = np.random.default_rng(np.random.SeedSequence([int(seed), 331]))
        # one wheel-calibration error per run (the robot's own), drawn once: a scale on distance and on turning
        self.scale = 1.0 + float(rng.normal(0.0, spec.odom_scale_error_pct / 100.0))
        self.yaw_scale = 1.0 + float(rng.normal(0.0, spec.odom_yaw_error_pct / 100.0))
        self.rng = rng
        self.odom = start  # odom → base: starts where the robot starts (map → odom is the identity then)
        self.map_from_odom = Pose2D(0.0, 0.0, 0.0)
        self._last_true = start
        self._at_update = start  # the odometry pose at the corrector's last update
        self.updates = 0
        self.relocalizations = 0  # updates that landed off by relocalize_sigma (LocalizationSpec)
        self.distance_m = 0.0

    @property
    def estimate(self) -> Pose2D:
        """Where the robot believes it is in the map."""
        return compose(self.map_from_odom, self.odom)

    def step(self, true_pose: Pose2D) -> None:
        """Integrate the motion since the last step as the wheels measure it; let the corrector update."""
        d = between(self._last_true, true_pose)
        self._last_true = true_pose
        dist = math.hypot(d.x, d.y)
        self.distance_m += dist
        noise = self.spec.odom_noise_m_per_m * math.sqrt(dist) if dist > 0 else 0.0
        measured = Pose2D(
            d.x * self.scale + float(self.rng.normal(0.0, noise)) if noise else d.x * self.scale,
            d.y * self.scale,
            d.yaw * self.yaw_scale,
        )
        self.odom = compose(self.odom, measured)
        self._correct(true_pose)

    def _correct(self, true_pose: Pose2D) -> None:
        s = self.spec
        if not s.amcl:
            return
        moved = between(self._at_update, self.odom)
        if math.hypot(moved.x, moved.y) < s.update_min_d and abs(moved.yaw) < s.update_min_a:
            return
        self._at_update = self.odom
        self.updates += 1
        sigma_m, sigma_rad = s.amcl_sigma_m, s.amcl_sigma_rad
        if s.relocalize_every_m > 0:  # a particle cloud now and then converges off: a bigger jump, undone later
            travelled = math.hypot(moved.x, moved.y)
            if float(self.rng.uniform()) < travelled / s.relocalize_every_m:
                sigma_m, sigma_rad = s.relocalize_sigma_m, s.relocalize_sigma_rad
                self.relocalizations += 1
        # AMCL's estimate: the truth, with its own error
        believed = Pose2D(
            true_pose.x + float(self.rng.normal(0.0, sigma_m)),
            true_pose.y + float(self.rng.normal(0.0, sigma_m)),
            _wrap(true_pose.yaw + float(self.rng.normal(0.0, sigma_rad))),
        )
        self.map_from_odom = compose(believed, inverse(self.odom))
