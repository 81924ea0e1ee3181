"""Misread answers told apart from a moving target, on plain numbers (misreads.py); the source's own tests
(test_families.py) drive the same through a fake model server."""

from __future__ import annotations

import numpy as np

from mission.core import se3
from mission.core.types import CameraIntrinsics
from mission.perception_plugins.vlm.latch import Candidate
from mission.perception_plugins.vlm.misreads import SWAP_HINT, AnswerScreen, MisreadLedger

K = CameraIntrinsics(fx=500.0, fy=500.0, cx=320.0, cy=240.0, width=640, height=480)
CAMERA = np.eye(4)  # the anchor frame is the camera's optical frame: z ahead


def at(x: float, y: float, z: float, stamp: float) -> Candidate:
    return Candidate(se3.from_pos_quat(np.array([x, y, z]), np.array([0.0, 0.0, 0.0, 1.0])), 0.9, stamp)


def screen() -> AnswerScreen:
    return AnswerScreen(tolerance_m=0.10, bearing_tolerance_rad=0.0, depth_tolerance_m=0.25, target_speed_mps=0.3)


def test_two_misreads_name_no_cause_and_a_third_names_the_commonest() -> None:
    ledger = MisreadLedger()
    ledger.add(SWAP_HINT)
    ledger.add("")
    assert ledger.likely_cause(read_right=0, family="gemini") == ""
    ledger.add(SWAP_HINT)
    assert ledger.likely_cause(read_right=0, family="gemini") == SWAP_HINT


def test_a_few_unexplained_misreads_among_many_good_answers_name_nothing() -> None:
    ledger = MisreadLedger()
    for _ in range(3):
        ledger.add("")
    assert ledger.likely_cause(read_right=10, family="gemini") == ""  # a target on the move, not a convention
    assert "check the model's family (now gemini)" in ledger.likely_cause(read_right=2, family="gemini")
    ledger.withdraw("")  # one of them was the target moving after all
    assert ledger.total == 2 and ledger.likely_cause(read_right=0, family=None) == ""


def test_an_answer_on_the_wall_behind_is_held_and_a_second_there_confirms_the_target_moved() -> None:
    run = [at(0.0, 0.0, 2.0, 0.0), at(0.01, 0.0, 2.0, 1.0)]
    s = screen()
    wall = at(1.0, 0.0, 4.0, 2.0)  # 2 m farther, 1 m aside: farther than it walks in a second
    first = s.screen(wall, run, CAMERA, wall.T_anchor_target[:3, 3], (445.0, 240.0), (480, 640), K)
    assert first.verdict == "held"
    again = at(1.02, 0.0, 4.0, 3.0)
    second = s.screen(again, run, CAMERA, again.T_anchor_target[:3, 3], (447.0, 240.0), (480, 640), K)
    assert second.verdict == "confirms" and second.held is wall and second.cause == first.cause


def test_an_answer_as_far_as_the_target_walks_since_the_newest_is_the_target_walking_on() -> None:
    run = [at(0.0, 0.0, 2.0, 0.0), at(0.0, 0.0, 2.0, 1.0)]
    later = at(0.0, 0.0, 3.2, 5.0)  # 1.2 m farther, 4 s later at 0.3 m/s
    verdict = screen().screen(later, run, CAMERA, later.T_anchor_target[:3, 3], (320.0, 240.0), (480, 640), K)
    assert verdict.verdict == "walked"


def test_a_swapped_point_that_lands_on_the_run_names_the_swap() -> None:
    run = [at(0.4, 0.0, 2.0, 0.0), at(0.4, 0.0, 2.0, 1.0)]  # seen at pixel (420, 240)
    # the model meant (420, 240) but wrote it the other way round: read as (u, v) = (240·640/480, 420·480/640)
    misread = at(-0.3, 0.3, 3.5, 2.0)
    verdict = screen().screen(misread, run, CAMERA, misread.T_anchor_target[:3, 3], (320.0, 315.0), (480, 640), K)
    assert verdict.verdict == "held" and verdict.cause == SWAP_HINT
