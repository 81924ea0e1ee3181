"""How real the simulated robot's senses are: the profiles a scenario's ``realism:`` key names (issue 33).

* ``ideal`` — the perfect pinhole camera and the true pose: what every figure before issue 33 was measured in.
* ``typical`` — a robot a careful team would build: a calibrated camera with a mild lens, good light, wheel
  odometry corrected by AMCL.
* ``harsh`` — a cheap webcam with an uncorrected wide lens, dim light and compression, on a slippery floor.

A profile is a set of scenario keys laid *under* the scenario's own (:func:`effective`, which the simulation
applies when it starts): any key the scenario (or a config's
``sim:`` section, or ``--set``) gives wins, so a team writes its own robot as ``realism: typical`` plus the
numbers from its calibration file and odometry specs. Markers are not part of a profile (a marker printed
off-size is a key of that marker: ``printed_scale``).

Where the numbers come from:

* [D1] the design notes, seed 001: wheel odometry tuned to drift less than 30 cm over 30 s; AMCL corrects it;
* [N1] Nav2 amcl's defaults: ``update_min_d`` 0.25 m, ``update_min_a`` 0.2 rad;
* [I33] issue 33's field figures: indoor auto-exposure 10–30 ms; intrinsics off by 1–2 % uncalibrated; an
  uncorrected wide lens k1 ≈ −0.3; stereo depth error ≈ 2 % at 2 m for common models; images delivered
  30–100 ms after exposure.
"""

from __future__ import annotations

from typing import Any

from mission.sim.scenario import Scenario

PROFILES: dict[str, dict[str, Any]] = {
    "ideal": {},
    "typical": {
        "camera": {
            "distortion": (-0.05, 0.01, 0.0, 0.0, 0.0),  # a mild lens, calibrated: the detector is told it
            "calibration_focal_pct": 0.5,  # a checkerboard calibration, not exact ([I33]: 1–2 % is uncalibrated)
            "calibration_center_px": 2.0,
            "calibration_k1": 0.01,
            "exposure_s": 0.010,  # the short end of indoor auto-exposure [I33]
            "latency_s": 0.030,  # delivered 30–50 ms after exposure [I33]
            "latency_jitter_s": 0.020,
            "depth_noise_pct_at_2m": 2.0,  # a common stereo camera [I33]
            "depth_edge_holes_m": 0.3,
            "light_variation": 0.2,  # good, even light; the auto-exposure keeps up
            "auto_exposure_s": 0.3,
        },
        "localization": {
            "odom_scale_error_pct": 1.0,  # 1 % of 0.3 m/s × 30 s ≈ 9 cm, inside [D1]'s 30 cm over 30 s
            "odom_yaw_error_pct": 1.0,
            "odom_noise_m_per_m": 0.002,
            "amcl": True,  # [D1]; updates after 0.25 m or 0.2 rad [N1]
            "amcl_sigma_m": 0.03,
            "amcl_sigma_rad": 0.02,
            "relocalize_every_m": 30.0,  # a bad update once a mission or so ([D1]: AMCL corrects in jumps)
            "relocalize_sigma_m": 0.15,
            "relocalize_sigma_rad": 0.08,
        },
    },
    "harsh": {
        "camera": {
            "distortion": (-0.30, 0.08, 0.0, 0.0, 0.0),  # a wide lens [I33] ...
            "lens_calibrated": False,  # ... that nobody calibrated: the detector is told a pinhole [I33]
            "calibration_focal_pct": 2.0,  # intrinsics off by up to 2 % [I33]
            "calibration_center_px": 8.0,
            "calibration_k1": 0.05,
            "exposure_s": 0.030,  # the long end of indoor auto-exposure [I33]
            "latency_s": 0.080,  # up to 100 ms after exposure [I33]
            "latency_jitter_s": 0.020,
            "depth_noise_pct_at_2m": 4.0,
            "depth_edge_holes_m": 0.2,
            "scene_brightness": 0.4,  # dim: the gain lifts noise with the picture
            "light_variation": 0.4,
            "auto_exposure_s": 1.0,
            "jpeg_quality": 60,  # a compressed topic
        },
        "localization": {
            "odom_scale_error_pct": 3.0,  # a slippery floor: 3 × [D1]'s budget
            "odom_yaw_error_pct": 3.0,
            "odom_noise_m_per_m": 0.01,
            "amcl": True,  # [N1]
            "amcl_sigma_m": 0.06,
            "amcl_sigma_rad": 0.05,
            "relocalize_every_m": 10.0,  # a repetitive or changing room: bad updates every few metres
            "relocalize_sigma_m": 0.3,
            "relocalize_sigma_rad": 0.15,
        },
    },
}


def effective(scenario: Scenario) -> Scenario:
    """The scenario with its ``realism`` profile filling every key of those sections it did not set itself
    (a file, a config's ``sim:`` or ``--set`` win over the profile)."""
    profile = PROFILES[scenario.realism]
    if not profile:
        return scenario
    update = {}
    for section, keys in profile.items():
        current = getattr(scenario, section)
        unset = {k: v for k, v in keys.items() if k not in current.model_fields_set}
        update[section] = current.model_copy(update=unset)
    return scenario.model_copy(update=update)
