"""Where the simulated robot believes it is (sim/localization.py, issue 33): drifting wheel odometry and an
AMCL-like corrector that updates only after motion, in jumps. The tree sees the belief; the truth stays true."""

from __future__ import annotations

import math

import pytest

from mission.core import blackboard as bbk
from mission.core.types import Pose2D, Twist
from mission.sim.localization import Localization
from mission.sim.scenario import LocalizationSpec, load_scenario
from mission.sim.sim_adapter import SimAdapter

START = Pose2D(1.0, 2.0, 0.0)


def drive(loc: Localization, poses: list[Pose2D]) -> None:
    for p in poses:
        loc.step(p)


def straight(metres: float, steps: int = 200) -> list[Pose2D]:
    return [Pose2D(START.x + metres * i / steps, START.y, 0.0) for i in range(1, steps + 1)]


def test_odometry_drift_over_a_measured_path_matches_the_configured_scale_error():
    loc = Localization(LocalizationSpec(odom_scale_error_pct=2.0, amcl=False), START, seed=3)
    assert loc.scale != 1.0 and abs(loc.scale - 1.0) < 0.08  # the run's own wheel error, drawn once
    drive(loc, straight(5.0))
    err = loc.estimate.x - (START.x + 5.0)
    assert err == pytest.approx((loc.scale - 1.0) * 5.0, abs=1e-9)  # grows with the distance driven
    loc2 = Localization(LocalizationSpec(odom_scale_error_pct=2.0, amcl=False), START, seed=3)
    assert loc2.scale == loc.scale  # seeded


def test_a_rotation_scale_error_bends_a_straight_drive_after_a_turn():
    loc = Localization(LocalizationSpec(odom_yaw_error_pct=5.0, amcl=False), START, seed=1)
    drive(loc, [Pose2D(START.x, START.y, math.pi / 2 * i / 50) for i in range(1, 51)])
    assert loc.estimate.yaw == pytest.approx(math.pi / 2 * loc.yaw_scale, abs=1e-9)


def test_the_corrector_jumps_only_after_the_robot_has_moved_or_turned_enough():
    spec = LocalizationSpec(odom_scale_error_pct=5.0, amcl_sigma_m=0.0, amcl_sigma_rad=0.0)
    loc = Localization(spec, START, seed=2)
    drive(loc, [START] * 100)  # standing still: nothing to correct
    assert loc.updates == 0
    drive(loc, [Pose2D(START.x, START.y, 0.15 * i / 10) for i in range(1, 11)])  # 0.15 rad < 0.2
    assert loc.updates == 0
    drive(loc, [Pose2D(START.x + 0.2 * i / 20, START.y, 0.15) for i in range(1, 21)])  # 0.2 m < 0.25
    assert loc.updates == 0
    before = loc.estimate
    drive(loc, [Pose2D(START.x + 0.2 + 0.1 * i / 10, START.y, 0.15) for i in range(1, 11)])  # past 0.25 m
    assert loc.updates == 1
    after = loc.estimate
    truth = Pose2D(START.x + 0.3, START.y, 0.15)
    # pulled onto the truth (no AMCL noise here), then a step or two of drift since
    assert math.hypot(after.x - truth.x, after.y - truth.y) < 0.001
    assert math.hypot(before.x - truth.x, before.y - truth.y) > 0.005  # from a drifted estimate: a jump


def test_now_and_then_an_update_lands_well_off_and_the_next_brings_it_back():
    spec = LocalizationSpec(amcl_sigma_m=0.0, amcl_sigma_rad=0.0, relocalize_every_m=2.0, relocalize_sigma_m=0.3)
    loc = Localization(spec, START, seed=4)
    errors = []
    for p in straight(20.0, steps=2000):
        loc.step(p)
        errors.append(math.hypot(loc.estimate.x - p.x, loc.estimate.y - p.y))
    assert 3 <= loc.relocalizations <= 25  # about one per 2 m over 20 m
    assert max(errors) > 0.1  # a jump well beyond AMCL's usual error (0 here) ...
    off = sum(1 for e in errors if e > 0.05) / len(errors)
    assert 0 < off < 0.3  # ... that does not stay: the next update (0.25 m on) brings it back
    steady = Localization(LocalizationSpec(amcl_sigma_m=0.0, amcl_sigma_rad=0.0), START, seed=4)
    drive(steady, straight(20.0, steps=2000))
    assert steady.relocalizations == 0


def test_the_tree_sees_the_belief_and_the_ground_truth_stays_true():
    scenario = load_scenario("explore_dock")
    scenario = scenario.model_copy(
        update={"localization": LocalizationSpec(odom_scale_error_pct=5.0, odom_yaw_error_pct=5.0, amcl=False)}
    )
    sim = SimAdapter(scenario, seed=0)
    sim.setup()
    bb = bbk.writer("localization")
    try:
        bbk.set_(bb, bbk.TWIST, Twist(0.3, 0.4))
        for _ in range(60):  # 2 s of driving an arc
            sim.sense(bb)
            sim.act(bb)
            sim.advance(1.0 / 30.0)
        sim.sense(bb)
        believed = bbk.get(bb, bbk.ROBOT_STATE).pose
        truth = sim.ground_truth().robot
    finally:
        sim.close()
    assert believed == sim.believed_pose
    assert math.hypot(believed.x - truth.x, believed.y - truth.y) > 0.002
