"""Mission metrics are computed from ground truth the way the design notes define them."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import py_trees
import pytest

from mission.app.metrics import MetricsRecorder, dock_errors
from mission.app.sim_run import evaluate
from mission.core import se3
from mission.core.docking import dock_offsets
from mission.core.types import NavGoal, Pose2D


@dataclass
class GT:
    stamp: float
    robot: Pose2D
    target: Pose2D | None = None
    target_moving: bool = True
    target_in_los: bool = True
    target_in_fov: bool = True
    T_map_dock: np.ndarray | None = None
    T_map_target_marker: np.ndarray | None = None
    collisions: int = 0

    @property
    def T_map_optical(self) -> np.ndarray:
        return se3.compose(
            se3.planar(self.robot.x, self.robot.y, self.robot.yaw, 0.3), se3.transform(se3.R_BODY_OPTICAL)
        )


def wall_tag(x: float, y: float, facing_yaw: float) -> np.ndarray:
    """A tag on a wall whose face (z) points along `facing_yaw` in the floor plane, at camera height."""
    # marker z = (cos, sin, 0); marker y = up; x = y × z
    z = np.array([math.cos(facing_yaw), math.sin(facing_yaw), 0.0])
    yv = np.array([0.0, 0.0, 1.0])
    return se3.transform(np.column_stack([np.cross(yv, z), yv, z]), (x, y, 0.3))


def test_dock_errors_of_a_perfect_dock_are_zero():
    tag = wall_tag(3.0, 0.0, math.pi)  # faces −x
    cam = se3.compose(se3.planar(2.70, 0.0, 0.0, 0.3), se3.transform(se3.R_BODY_OPTICAL))
    e = dock_errors(cam, tag, robot_yaw=0.0, standoff=0.30)
    assert e.lateral_m == pytest.approx(0.0, abs=1e-9)
    assert e.distance_m == pytest.approx(0.0, abs=1e-9)
    assert e.skew_deg == pytest.approx(0.0, abs=1e-9)
    assert e.within()


def test_dock_errors_measure_lateral_distance_and_skew():
    tag = wall_tag(3.0, 0.0, math.pi)
    cam = se3.compose(se3.planar(2.66, 0.05, math.radians(12), 0.3), se3.transform(se3.R_BODY_OPTICAL))
    e = dock_errors(cam, tag, robot_yaw=math.radians(12), standoff=0.30)
    assert e.lateral_m == pytest.approx(0.05)
    assert e.distance_m == pytest.approx(0.04)
    assert e.skew_deg == pytest.approx(12.0)
    assert not e.within()


def test_occlusion_latency_is_time_from_blocked_line_of_sight_to_lost():
    rec = MetricsRecorder()
    robot, target = Pose2D(0, 0, 0), Pose2D(2, 0, 0)
    script = [
        (0.0, True, "FOLLOW"),
        (1.0, False, "FOLLOW"),
        (1.2, False, "FOLLOW"),
        (1.4, False, "LOST"),
        (4.4, False, "SEARCH"),
        (6.0, True, "SEARCH"),
        (6.4, True, "FOLLOW"),
    ]
    for t, los, state in script:
        rec.record(GT(t, robot, target, target_in_los=los), state, None, None)
    s = rec.summary(6.4)
    assert s["occlusions"] == 1 and s["occlusions_detected"] == 1
    assert s["occlusion_detection_latency_s"]["max"] == pytest.approx(0.4)
    assert s["loss_events"] == 1 and s["loss_events_recovered"] == 1
    assert s["reacquisition_time_s"]["max"] == pytest.approx(5.0)
    assert [x["state"] for x in s["state_transitions"]] == ["FOLLOW", "LOST", "SEARCH", "FOLLOW"]


def test_unrecovered_loss_is_reported():
    rec = MetricsRecorder()
    for t, state in [(0.0, "FOLLOW"), (1.0, "SEARCH"), (5.0, "SEARCH")]:
        rec.record(GT(t, Pose2D(0, 0, 0), Pose2D(2, 0, 0)), state, None, None)
    s = rec.summary(5.0)
    assert s["loss_events"] == 1 and s["loss_events_recovered"] == 0
    assert s["loss_recovery_fraction"] == 0.0


def test_goal_jitter_counts_only_goals_while_the_target_stands_still():
    rng = np.random.default_rng(0)
    rec = MetricsRecorder()
    for i in range(40):
        still = i >= 10
        noise = rng.normal(scale=0.05, size=2)
        x, y = (1.5 + noise[0], noise[1]) if still else (0.1 * i, 0.0)  # moving goals are far apart
        rec.record(
            GT(i * 0.1, Pose2D(0, 0, 0), Pose2D(2, 0, 0), target_moving=not still),
            "FOLLOW",
            NavGoal(Pose2D(x, y, 0.0), stamp=i * 0.1, seq=i),
            None,
        )
    sd = rec.summary(4.0)["goal_jitter_sd_m"]
    assert 0.03 < sd < 0.1  # ≈ 0.05·√2, unaffected by the moving stretch


def test_an_occlusion_the_tree_calls_search_is_missed_not_detected():
    # line of sight breaks at 1.0 s and stays broken; the tree says SEARCH ("it left the view") at 1.4 s
    rec = MetricsRecorder()
    robot, target = Pose2D(0, 0, 0), Pose2D(2, 0, 0)
    for t, los, state in [
        (0.0, True, "FOLLOW"),
        (1.0, False, "FOLLOW"),
        (1.4, False, "SEARCH"),
        (3.0, False, "SEARCH"),
        (3.5, True, "FOLLOW"),
    ]:
        rec.record(GT(t, robot, target, target_in_los=los), state, None, None)
    s = rec.summary(3.5)
    assert s["occlusions"] == 1 and s["occlusions_over_0_5s"] == 1
    assert s["occlusions_detected"] == 0 and s["occlusions_missed"] == 1
    assert s["occlusion_detection_latency_s"] is None
    assert s["reacquisition_time_s"]["max"] == pytest.approx(2.1)  # SEARCH entry → FOLLOW


def test_each_occlusion_has_its_own_latency_and_a_short_one_need_not_be_detected():
    rec = MetricsRecorder()
    robot, target = Pose2D(0, 0, 0), Pose2D(2, 0, 0)
    script = [
        (0.0, True, "FOLLOW"),
        (1.0, False, "FOLLOW"),
        (1.3, True, "FOLLOW"),  # 0.3 s blink behind a thin pole: no LOST needed
        (2.0, False, "FOLLOW"),
        (2.3, False, "LOST"),
        (4.0, True, "LOST"),
        (4.1, True, "FOLLOW"),
        (6.0, False, "FOLLOW"),
        (6.45, False, "LOST"),
        (9.0, False, "SEARCH"),
        (12.0, True, "FOLLOW"),
    ]
    for t, los, state in script:
        rec.record(GT(t, robot, target, target_in_los=los), state, None, None)
    s = rec.summary(12.0)
    assert s["occlusions"] == 3 and s["occlusions_over_0_5s"] == 2
    assert s["occlusions_detected"] == 2 and s["occlusions_missed"] == 0
    lat = s["occlusion_detection_latency_s"]
    assert lat["n"] == 2 and lat["max"] == pytest.approx(0.45) and lat["median"] == pytest.approx(0.375)
    assert s["loss_events"] == 2 and s["loss_events_recovered"] == 2
    assert s["reacquisition_time_s"]["max"] == pytest.approx(5.55)  # LOST at 6.45 → FOLLOW at 12.0


def test_dock_errors_agree_with_the_docking_geometry_the_behaviours_steer_by():
    tag = wall_tag(1.0, 2.0, math.radians(30))
    robot = Pose2D(
        1.0 + 0.33 * math.cos(math.radians(30)) - 0.02 * math.sin(math.radians(30)),
        2.0 + 0.33 * math.sin(math.radians(30)) + 0.02 * math.cos(math.radians(30)),
        math.radians(30 + 180 - 7),
    )
    cam = se3.compose(se3.planar(robot.x, robot.y, robot.yaw, 0.3), se3.transform(se3.R_BODY_OPTICAL))
    off = dock_offsets(cam, tag, robot.yaw)
    e = dock_errors(cam, tag, robot_yaw=robot.yaw, standoff=0.30)
    assert off.standoff_m == pytest.approx(0.33) and off.lateral_m == pytest.approx(0.02)
    assert e.standoff_m == pytest.approx(off.standoff_m)
    assert e.distance_m == pytest.approx(0.03) and e.lateral_m == pytest.approx(0.02)
    assert e.skew_deg == pytest.approx(7.0)
    assert not e.within() and e.within(distance=0.035)


def test_a_run_is_judged_by_the_design_criteria_a_user_reads_in_the_report():
    def follow_summary(script: list[tuple[float, bool, str]], end: float) -> dict:
        rec = MetricsRecorder()
        for t, los, state in script:
            rec.record(GT(t, Pose2D(0, 0, 0), Pose2D(2, 0, 0), target_in_los=los), state, None, None)
        return rec.summary(end)

    running = py_trees.common.Status.RUNNING
    quick = follow_summary(
        [
            (0.0, True, "FOLLOW"),
            (1.0, False, "FOLLOW"),
            (1.4, False, "LOST"),
            (4.4, False, "SEARCH"),
            (6.0, True, "FOLLOW"),
            (30.0, True, "FOLLOW"),
        ],
        30.0,
    )
    assert evaluate("follow", running, "FOLLOW", "", quick, 30.0) == (
        True,
        "followed the target to the end, in view 83 % of the follow phase",
    )
    slow_find = follow_summary(
        [
            (0.0, True, "FOLLOW"),
            (1.0, False, "FOLLOW"),
            (1.4, False, "LOST"),
            (4.4, False, "SEARCH"),
            (13.0, True, "FOLLOW"),
            (30.0, True, "FOLLOW"),
        ],
        30.0,
    )
    assert evaluate("follow", running, "FOLLOW", "", slow_find, 30.0) == (
        False,
        "target re-acquired after 11.6 s (> 10 s)",
    )
    late_call = follow_summary(
        [
            (0.0, True, "FOLLOW"),
            (1.0, False, "FOLLOW"),
            (1.7, False, "LOST"),
            (3.0, True, "FOLLOW"),
            (30.0, True, "FOLLOW"),
        ],
        30.0,
    )
    assert evaluate("follow", running, "FOLLOW", "", late_call, 30.0) == (
        False,
        "occlusion detected after 0.70 s (> 0.5 s)",
    )
    wrong_call = follow_summary(
        [
            (0.0, True, "FOLLOW"),
            (1.0, False, "FOLLOW"),
            (1.3, False, "SEARCH"),
            (3.0, True, "FOLLOW"),
            (30.0, True, "FOLLOW"),
        ],
        30.0,
    )
    assert evaluate("follow", running, "FOLLOW", "", wrong_call, 30.0) == (
        False,
        "1 occlusion(s) of 0.5 s or more never called LOST",
    )
    docked = {"dock": {"lateral_m": 0.01, "distance_m": 0.03, "standoff_m": 0.33, "skew_deg": 2.0}, "collisions": 0}
    ok, why = evaluate("dock", py_trees.common.Status.SUCCESS, "DONE", "", docked, 20.0)
    assert not ok and why == "docked out of tolerance: lateral 1.0 cm, distance 3.0 cm, skew 2.0°"


def test_an_occlusion_the_tree_saw_coming_counts_with_latency_zero():
    # the target turned away behind a pillar: LOST at 1.0 s, the marker's centre hidden only at 1.3 s
    rec = MetricsRecorder()
    robot, target = Pose2D(0, 0, 0), Pose2D(2, 0, 0)
    for t, los, state in [
        (0.0, True, "FOLLOW"),
        (1.0, True, "LOST"),
        (1.3, False, "LOST"),
        (3.0, False, "SEARCH"),
        (4.0, True, "SEARCH"),
        (4.2, True, "FOLLOW"),
        (6.0, True, "SEARCH"),
        (6.5, False, "SEARCH"),
    ]:
        rec.record(GT(t, robot, target, target_in_los=los), state, None, None)
    s = rec.summary(7.0)
    assert s["occlusions"] == 1 and s["occlusions_detected"] == 1 and s["occlusions_missed"] == 0
    assert s["occlusion_detection_latency_s"]["max"] == 0.0  # the break during SEARCH at 6.5 s is not one


def test_the_tracking_fraction_is_time_in_follow_with_the_target_in_view_over_the_follow_phase():
    rec = MetricsRecorder()
    robot, target = Pose2D(0, 0, 0), Pose2D(2, 0, 0)
    script = [
        (0.0, True, True, "FOLLOW"),
        (4.0, True, False, "FOLLOW"),  # following, but it is out of view
        (5.0, False, False, "SEARCH"),
        (9.0, True, True, "FOLLOW"),
        (10.0, True, True, "FOLLOW"),
    ]
    for t, los, fov, state in script:
        rec.record(GT(t, robot, target, target_in_los=los, target_in_fov=fov), state, None, None)
    s = rec.summary(10.0)
    assert (s["tracking_s"], s["follow_phase_s"], s["tracking_fraction"]) == (5.0, 10.0, 0.5)


def test_a_follow_run_that_spent_most_of_its_time_searching_did_not_follow_the_target():
    # the VLM run of issue 15: every loss recovered in time, following at the end — 28 % of the time in FOLLOW
    summary = {
        "tracking_fraction": 0.28,
        "tracking_s": 25.2,
        "follow_phase_s": 90.0,
        "collisions": 0,
        "loss_events": 6,
        "loss_events_recovered": 6,
        "reacquisition_time_s": {"max": 9.0},
    }
    running = py_trees.common.Status.RUNNING
    assert evaluate("follow", running, "FOLLOW", "", summary, 90.0) == (
        False,
        "target tracked 28 % of the follow phase (< 70 %): in FOLLOW with it in view 25 s of 90 s",
    )
    assert evaluate("follow", running, "FOLLOW", "", summary, 90.0, min_tracking_fraction=0.25)[0]


def test_a_search_for_a_target_that_left_the_map_must_end_with_its_reason_within_the_limit():
    failed, running = py_trees.common.Status.FAILURE, py_trees.common.Status.RUNNING
    why = "SEARCH gave up: target not found 80 s after it was last seen at (7.00, 1.00): …"
    gave_up = {"target_gone_at_s": 30.0, "give_up_after_gone_s": 84.0, "collisions": 0, "duration_s": 114.0}
    assert evaluate("give_up", failed, "FAILED", why, gave_up, 114.0, give_up_within_s=110) == (
        True,
        f"gave up 84 s after the target left the map: {why}",
    )
    assert evaluate("give_up", failed, "FAILED", why, gave_up, 114.0, give_up_within_s=60) == (
        False,
        "gave up 84 s after the target left the map (> 60 s)",
    )
    searching = {"target_gone_at_s": 30.0, "give_up_after_gone_s": None, "collisions": 0, "duration_s": 150.0}
    assert evaluate("give_up", running, "SEARCH", "", searching, 150.0) == (
        False,
        "still searching 120 s after the target left the map",
    )


def test_an_occlusion_starts_when_the_camera_stops_seeing_the_target_not_when_a_grazing_line_breaks():
    # ground truth's line to the marker's centre grazes the door frame at 1.0 s; the camera reads the marker
    # until 1.2 s; LOST at 1.6 s is 0.4 s after the target was last seen — within the bound, not 0.6 s
    from mission.core.types import TargetTrack
    from tests.helpers.behaviour_world import detection_of, marker_facing

    rec = MetricsRecorder()
    robot, target = Pose2D(0, 0, 0), Pose2D(2, 0, 0)
    marker = marker_facing(2.0, 0.0, math.pi)
    script = [
        (0.0, True, True, "FOLLOW"),
        (1.0, False, True, "FOLLOW"),
        (1.1, False, True, "FOLLOW"),
        (1.2, False, True, "FOLLOW"),
        (1.4, False, False, "FOLLOW"),
        (1.6, False, False, "LOST"),
        (3.0, True, False, "LOST"),
    ]
    for t, los, seen, state in script:
        track = TargetTrack("target", last_seen=t if seen else 1.2)
        track.detection = detection_of(marker, robot, stamp=t if seen else 1.2)
        rec.record(GT(t, robot, target, target_in_los=los), state, None, {"target": track})
    latency = rec.summary(3.0)["occlusion_detection_latency_s"]
    assert latency["max"] == pytest.approx(0.4)


def test_the_report_pictures_say_what_every_colour_and_mark_means(tmp_path):
    """Issue 36: the target's end mark had no key (and SEARCH's red), the map's key covered obstacles, the
    timeline had no colour key. Each picture now returns what its key says."""
    from mission.viz.run_report import plot_timeline, plot_trajectories

    rec = MetricsRecorder()
    script = [(0.0, True, "FOLLOW"), (1.0, False, "LOST"), (4.0, False, "SEARCH"), (6.0, True, "FOLLOW")]
    for i, (t, los, state) in enumerate(script):
        rec.record(GT(t, Pose2D(0.1 * i, 0, 0), Pose2D(2, 0.2 * i, 0), target_in_los=los), state, None, None)
    key = plot_trajectories(rec, None, tmp_path / "trajectories.png", "t")
    assert {"target (truth)", "target end", "robot start", "robot end", "FOLLOW", "LOST", "SEARCH"} <= set(key)
    timeline = plot_timeline(rec, tmp_path / "timeline.png", "t")
    assert timeline == ["FOLLOW", "LOST", "SEARCH", "in sight / in view", "line of sight blocked", "not in view"]
    assert (tmp_path / "trajectories.png").stat().st_size > 0 and (tmp_path / "timeline.png").stat().st_size > 0
