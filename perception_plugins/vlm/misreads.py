"""Misread answers: a VLM answer read in another convention than the model's, told apart from a target that moved.

A model family answers in its own convention (Gemini [y, x] on 0–1000, Qwen pixels as [x, y], Molmo's
percentages); read in the wrong one, the point lands elsewhere in the image: on a wall or the floor, at a depth
the answers that agree so far contradict. Such an answer must not enter the consensus, and after a few the
source's status should say what the user can do about it ("set family"). But a target carried away between two
answers lands elsewhere too, at a plausible depth or along its walk, and that is no misread.

* :class:`AnswerScreen` decides, for each answer, whether it joins the run of agreeing answers, shows the target
  walked on, confirms an answer held back before (two answers agreeing elsewhere are the target there), or is
  held back as misread, with its likely cause.
* :class:`MisreadLedger` counts the misread answers by cause and names the likely one once there are
  :data:`MISREADS_BEFORE_CAUSE`.

Pure logic, no threads and no clock: source.py drives both.
"""

from __future__ import annotations

import math
from collections import Counter
from dataclasses import dataclass
from typing import Literal

import numpy as np

from mission.core import se3
from mission.core.types import CameraIntrinsics
from mission.perception_plugins.vlm.latch import AGREE_SIGMAS, Candidate, agree_within_m

#: Misread answers (points outside the image, on a depth the other answers contradict, or in another
#: family's form) before the source's status names the likely cause.
MISREADS_BEFORE_CAUSE = 3

SWAP_HINT = "answers look like [x, y], read as [y, x]; set family (qwen2.5-vl, qwen3-vl, molmo, molmo2)"


class MisreadLedger:
    """The misread answers, by likely cause ("" when none is known)."""

    def __init__(self) -> None:
        self._by_cause: Counter[str] = Counter()

    @property
    def total(self) -> int:
        return sum(self._by_cause.values())

    def add(self, cause: str) -> None:
        self._by_cause[cause] += 1

    def withdraw(self, cause: str) -> None:
        """An answer counted as misread under `cause` was read right after all (the target had moved)."""
        self._by_cause[cause] -= 1
        if self._by_cause[cause] <= 0:
            del self._by_cause[cause]

    def clear(self) -> None:
        self._by_cause.clear()

    def likely_cause(self, read_right: int, family: str | None) -> str:
        """The likely cause once :data:`MISREADS_BEFORE_CAUSE` answers were misread ("" before): the most
        frequent known cause, or, when most answers are misread (`read_right` is how many were not), that
        points keep missing the target. A few misreads among many good answers are a target on the move, or an
        edge's depth, not a convention."""
        total = self.total
        if total < MISREADS_BEFORE_CAUSE:
            return ""
        known = Counter({k: v for k, v in self._by_cause.items() if k})
        if known:
            return known.most_common(1)[0][0]
        if 2 * total < read_right:
            return ""
        return (
            f"{total} answers misread (points outside the image or off the other answers' depth); "
            f"check the model's family{f' (now {family})' if family else ''}"
        )


def swap_cause(
    pixel: tuple[float, float] | None,
    image_size: tuple[int, int],
    intrinsics: CameraIntrinsics,
    run_in_camera: np.ndarray,
) -> str:
    """:data:`SWAP_HINT` when the answer's point with x and y swapped (`image_size` is (height, width)) lands near
    where the run's place appears in the image; "" when it does not."""
    if pixel is None or run_in_camera[2] <= 1e-3:
        return ""
    h, w = image_size
    u, v = pixel
    su, sv = v / h * w, u / w * h  # the same two numbers, read the other way round
    eu, ev = intrinsics.project(run_in_camera[None, :])[0]
    if abs(su - eu) <= 0.08 * w and abs(sv - ev) <= 0.08 * h:
        return SWAP_HINT
    return ""


@dataclass(frozen=True)
class Screened:
    """What :meth:`AnswerScreen.screen` made of an answer.

    * ``joins``: it agrees with the run, or lies at the depth the run does (the target moved sideways); it
      joins the consensus, which restarts if it is elsewhere.
    * ``walked``: it is no farther from the newest agreeing answer than the target walks in the time between
      them: the target walked on (the consensus restarts with it).
    * ``confirms``: it agrees with the answer held back before: the target is there. `held` is that answer (to
      count again) and `cause` the cause it was counted under (to withdraw).
    * ``held``: off the run and at a depth the run contradicts: misread, likely for `cause`; dropped.
    """

    verdict: Literal["joins", "walked", "confirms", "held"]
    held: Candidate | None = None
    cause: str = ""


class AnswerScreen:
    """Holds back an answer that lies off the agreeing answers so far *and* at a depth they contradict.

    Seen from the answer's image, the run's place is nearer or farther by more than `depth_tolerance_m`: a point
    read in the wrong convention lands on the wall or the floor. Two such answers agreeing with each other are the
    target somewhere else: the consensus restarts with both. So does one no farther from the newest agreeing
    answer than the target walks (`target_speed_mps`) in the time between them: a person carrying the object away
    at 0.3 m/s was three misreads a run before (the sim's vlm_discovery, every seed), and now and then a swap that
    happened to fit named a false cause. Whether swapping x and y would have hit the run is the likely cause."""

    def __init__(
        self, tolerance_m: float, bearing_tolerance_rad: float, depth_tolerance_m: float, target_speed_mps: float
    ) -> None:
        self.tolerance_m = tolerance_m
        self.bearing_tolerance_rad = bearing_tolerance_rad
        self.depth_tolerance_m = depth_tolerance_m
        self.target_speed_mps = target_speed_mps
        self._held: Candidate | None = None  # the last answer held back as misread
        self._held_cause = ""  # the cause it was counted under

    def reset(self) -> None:
        self._held = None
        self._held_cause = ""

    def screen(
        self,
        candidate: Candidate,
        run: list[Candidate],
        T_anchor_camera: np.ndarray,
        seen_in_camera: np.ndarray,
        pixel: tuple[float, float] | None,
        image_size: tuple[int, int],
        intrinsics: CameraIntrinsics,
    ) -> Screened:
        """Screen one answer: `candidate` is it in the anchor frame, `seen_in_camera` its position in the camera
        of the image it was answered on (taken at `T_anchor_camera`), `pixel` the point the model gave."""
        if not run:
            return Screened("joins")
        expected = np.mean([c.T_anchor_target[:3, 3] for c in run], axis=0)
        here = candidate.T_anchor_target[:3, 3]
        noisiest = max(run, key=lambda c: c.sigma_m)
        within = agree_within_m(candidate, noisiest, self.tolerance_m, self.bearing_tolerance_rad)
        if float(np.linalg.norm(here - expected)) <= within:
            return self._release("joins")
        in_cam = se3.apply(se3.invert(T_anchor_camera), expected[None, :])[0]
        depth_tolerance = self.depth_tolerance_m + AGREE_SIGMAS * math.hypot(candidate.sigma_m, noisiest.sigma_m)
        if abs(float(np.linalg.norm(seen_in_camera)) - float(np.linalg.norm(in_cam))) <= depth_tolerance:
            return self._release("joins")  # the same depth elsewhere: the target moved (the consensus restarts)
        newest = max(run, key=lambda c: c.stamp)
        walked = self.target_speed_mps * max(0.0, candidate.stamp - newest.stamp)
        if float(np.linalg.norm(here - newest.T_anchor_target[:3, 3])) <= within + walked:
            return self._release("walked")
        last = self._held
        if last is not None and np.linalg.norm(last.T_anchor_target[:3, 3] - here) <= agree_within_m(
            last, candidate, self.tolerance_m, self.bearing_tolerance_rad
        ):
            cause = self._held_cause
            self.reset()
            return Screened("confirms", held=last, cause=cause)  # twice there: the target is there
        self._held = candidate
        self._held_cause = swap_cause(pixel, image_size, intrinsics, in_cam)
        return Screened("held", cause=self._held_cause)

    def _release(self, verdict: Literal["joins", "walked"]) -> Screened:
        self._held = None
        return Screened(verdict)
