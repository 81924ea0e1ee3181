"""The VLM's consensus: how far apart answers may be and still be the same place, and where the latch goes."""

from __future__ import annotations

import numpy as np

from mission.core import se3
from mission.perception_plugins.vlm.latch import Candidate, OneShotLatch


def answer(x: float, sigma_m: float = 0.0, stamp: float = 0.0) -> Candidate:
    return Candidate(se3.transform(np.eye(3), (x, 4.0, 0.3)), 0.8, stamp, sigma_m)


def latch() -> OneShotLatch:
    return OneShotLatch(min_consecutive=3, tolerance_m=0.10, max_failed_attempts=5)


def test_exact_answers_twenty_centimetres_apart_are_two_places():
    consensus = latch()
    assert not any(consensus.add(answer(x)) for x in (6.70, 6.90, 6.70))
    assert not consensus.latched


def test_far_answers_on_noisy_depth_agree_within_their_standard_errors_and_latch():
    # Three answers from 5.8 m away on a stereo camera (σ ≈ 6 cm each after averaging the patch).
    consensus = latch()
    results = [consensus.add(answer(x, sigma_m=0.06)) for x in (6.70, 6.90, 6.78)]
    assert results == [False, False, True]
    assert abs(consensus.T_anchor_target[0, 3] - 6.793) < 1e-3  # type: ignore[index]


def test_a_noisy_answer_counts_less_in_the_latched_position():
    # Two near, exact answers and one far, noisy one that still agrees with them.
    consensus = latch()
    for c in (answer(6.75, 0.0), answer(6.77, 0.0), answer(6.95, 0.08)):
        consensus.add(c)
    assert consensus.latched
    x = consensus.T_anchor_target[0, 3]  # type: ignore[index]
    assert 6.76 < x < 6.79  # the plain mean would be 6.823


def test_far_answers_a_heading_error_apart_agree_and_near_ones_the_same_distance_apart_do_not():
    # AMCL's heading is off by ~0.02 rad between updates: 6 m away that moves an answer ~0.3 m sideways.
    consensus = OneShotLatch(min_consecutive=2, tolerance_m=0.10, max_failed_attempts=5, bearing_tolerance_rad=0.08)
    far = [Candidate(se3.transform(np.eye(3), (6.8, y, 0.3)), 0.8, 0.0, 0.0, 5.8) for y in (4.0, 4.3)]
    assert [consensus.add(c) for c in far] == [False, True]
    consensus = OneShotLatch(min_consecutive=2, tolerance_m=0.10, max_failed_attempts=5, bearing_tolerance_rad=0.08)
    near = [Candidate(se3.transform(np.eye(3), (2.0, y, 0.3)), 0.8, 0.0, 0.0, 1.0) for y in (4.0, 4.3)]
    assert [consensus.add(c) for c in near] == [False, False]
