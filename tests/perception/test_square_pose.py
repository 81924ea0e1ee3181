"""Square-fiducial pose: both IPPE solutions, the choice between them over time, and the confidence score."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mission.core import se3
from mission.perception_plugins import square_pose as sp
from tools.synthetic_views import default_intrinsics, pose_facing_camera


def _exact_corners(T: np.ndarray, side: float) -> np.ndarray:
    return default_intrinsics().project(se3.apply(T, sp.object_points(side)))


def test_object_points_are_tl_tr_br_bl_with_y_up():
    pts = sp.object_points(0.2)
    assert pts.tolist() == [[-0.1, 0.1, 0.0], [0.1, 0.1, 0.0], [0.1, -0.1, 0.0], [-0.1, -0.1, 0.0]]


def test_solve_square_returns_both_poses_best_first_and_the_best_is_the_truth():
    T = pose_facing_camera(np.array([0.1, -0.05, 1.5]), tilt_axis_angle=0.3, tilt=math.radians(30), roll=0.4)
    k = default_intrinsics()
    hyps = sp.solve_square(_exact_corners(T, 0.2), 0.2, k.matrix, k.dist_coeffs)
    assert len(hyps) == 2
    assert hyps[0].reprojection_error <= hyps[1].reprojection_error
    assert np.allclose(hyps[0].tvec, T[:3, 3], atol=1e-6)
    assert se3.rotation_angle(hyps[0].rotation, T[:3, :3]) < 1e-6
    # The alternative is the mirror pose: same place, tilted the other way.
    assert se3.rotation_angle(hyps[1].rotation, T[:3, :3]) > math.radians(20)


def test_solve_square_on_degenerate_corners_returns_nothing_instead_of_raising():
    k = default_intrinsics()
    assert sp.solve_square(np.zeros((4, 2)), 0.2, k.matrix, k.dist_coeffs) == []


def _pair(true_err: float, wrong_err: float, wobble: float = 0.0) -> tuple[sp.PoseHypothesis, sp.PoseHypothesis]:
    """A true pose and its flip, with given reprojection errors; `wobble` rotates both slightly (motion)."""
    r_true = se3.rot_y(math.radians(25) + wobble) @ np.diag([1.0, -1.0, -1.0])
    r_flip = se3.rot_y(math.radians(-25) + wobble) @ np.diag([1.0, -1.0, -1.0])
    t = np.array([0.0, 0.0, 3.0])
    return (
        sp.PoseHypothesis(se3.matrix_to_rvec(r_true), t, true_err),
        sp.PoseHypothesis(se3.matrix_to_rvec(r_flip), t, wrong_err),
    )


def _is_true(h: sp.PoseHypothesis) -> bool:
    return se3.rotation_angle(h.rotation, se3.rot_y(math.radians(25)) @ np.diag([1.0, -1.0, -1.0])) < math.radians(5)


def test_naive_choice_takes_the_lower_error_even_when_it_is_the_wrong_pose():
    true, wrong = _pair(0.30, 0.28)
    choice = sp.choose_naive(sorted([true, wrong], key=lambda h: h.reprojection_error))
    assert choice.chosen is wrong
    assert choice.ambiguity > 0.5  # and it knows it is unsure


def test_temporal_choice_recovers_from_a_wrong_first_pick_as_evidence_accumulates():
    rng = np.random.default_rng(0)
    d = sp.TemporalDisambiguator()
    picks = []
    for i in range(30):
        # On average the true pose fits better (0.25 vs 0.30 px), but single frames often say otherwise,
        # and the first frame does.
        e_true, e_wrong = (0.30, 0.25) if i == 0 else (0.25 + rng.normal(0, 0.04), 0.30 + rng.normal(0, 0.04))
        true, wrong = _pair(abs(e_true), abs(e_wrong), wobble=0.002 * i)
        hyps = [true, wrong] if rng.random() < 0.5 else [wrong, true]  # solver order means nothing
        picks.append(_is_true(d.choose(7, i / 30.0, hyps).chosen))
    assert not picks[0]
    assert all(picks[-15:])


def test_a_clearly_better_solution_is_taken_at_once():
    d = sp.TemporalDisambiguator()
    true, wrong = _pair(0.31, 0.30)
    assert not _is_true(d.choose(1, 0.0, [wrong, true]).chosen)  # weak evidence: naive start
    true, wrong = _pair(0.2, 2.0, wobble=0.001)
    choice = d.choose(1, 0.033, [wrong, true])
    assert _is_true(choice.chosen) and choice.switched


def test_track_restarts_after_the_marker_was_unseen_for_more_than_a_second():
    d = sp.TemporalDisambiguator(stale_after_s=1.0)
    true, wrong = _pair(0.2, 0.25)
    assert d.choose(3, 0.0, [true, wrong]).track_frames == 1
    assert d.choose(3, 0.5, [true, wrong]).track_frames == 2
    assert d.choose(3, 2.0, [true, wrong]).track_frames == 1
    assert d.choose(4, 2.0, [true, wrong]).track_frames == 1  # tracks are per marker id


def test_confidence_follows_fit_size_and_ambiguity():
    base = sp.confidence(0.2, 60.0, 0.0)
    assert 0.8 < base <= 1.0
    assert sp.confidence(2.0, 60.0, 0.0) < base  # poor fit
    assert sp.confidence(0.2, 12.0, 0.0) < base  # small in the image
    assert sp.confidence(0.2, 60.0, 1.0) == pytest.approx(base / 2)  # flip unresolved
    assert sp.confidence(float("nan"), 60.0, 0.0) == 0.0
    assert sp.confidence(float("inf"), 60.0, 0.0) == 0.0
