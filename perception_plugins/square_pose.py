"""Pose of a square fiducial (ArUco, AprilTag) from its four corners, and the choice between its two poses.

A flat square seen by a pinhole camera has two poses that explain its corners almost equally well: the
true one and its mirror about the viewing ray (the plane "flips" towards or away from the camera). IPPE
(``SOLVEPNP_IPPE_SQUARE``) returns both. Close up their reprojection errors differ clearly; at 2–3 m and
oblique views they differ by < 0.1 px, so taking the lower error per frame picks the wrong pose in ~10 %
of views (FIELD_NOTES). :class:`TemporalDisambiguator` fixes that by following both hypotheses of each
marker over frames and choosing on the accumulated evidence.

Shared by every square-fiducial source (``mission.perception_plugins.aruco``, ``mission.perception_plugins.apriltag``):

* :func:`object_points` — corners in the marker frame in the order IPPE_SQUARE needs (TL TR BR BL);
* :func:`solve_square` — both IPPE poses with their RMS reprojection errors, best first;
* :class:`TemporalDisambiguator` (``choose(key, stamp, hypotheses)``) and :func:`choose_naive` — a
  :class:`PoseChoice` with the chosen pose, the alternative and an ambiguity in [0, 1];
* :func:`confidence` — a 0..1 score from reprojection error, the marker's pixel size and the ambiguity.

Frames: the pose is camera-optical ← marker (OpenCV marker frame: x right, y up, z out of the face).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field

import cv2
import numpy as np

from mission.core import se3


def object_points(side_m: float) -> np.ndarray:
    """The marker's corners in its own frame: (−L/2, L/2), (L/2, L/2), (L/2, −L/2), (−L/2, −L/2), z = 0.

    This is TL TR BR BL as ArUco and (reordered) AprilTag report corners, and the order
    ``SOLVEPNP_IPPE_SQUARE`` requires.
    """
    h = side_m / 2.0
    return np.array([[-h, h, 0.0], [h, h, 0.0], [h, -h, 0.0], [-h, -h, 0.0]], dtype=np.float64)


@functools.lru_cache(maxsize=64)
def _pnp_object_points(side_m: float) -> np.ndarray:
    """object_points(side_m) shaped 4×1×3 for solvePnP, built once per size (read-only: shared)."""
    pts = object_points(side_m).reshape(4, 1, 3)
    pts.flags.writeable = False
    return pts


def pixel_side(corners: np.ndarray) -> float:
    """Mean side length (px) of the marker's image quadrilateral: how big, hence how precise, it is."""
    c = np.asarray(corners, dtype=np.float64).reshape(4, 2).tolist()
    return sum(math.dist(c[i], c[(i + 1) % 4]) for i in range(4)) / 4.0


@dataclass(frozen=True)
class PoseHypothesis:
    """One pose of the marker: camera ← marker, with its RMS reprojection error (px) on the 4 corners."""

    rvec: np.ndarray  # (3,) axis-angle
    tvec: np.ndarray  # (3,) metres
    reprojection_error: float

    @functools.cached_property
    def rotation(self) -> np.ndarray:
        # Cached: the disambiguator, the pose and the detection's quaternion all read it (bench: perception).
        return se3.rvec_to_matrix(self.rvec)

    @property
    def T(self) -> np.ndarray:
        return se3.transform(self.rotation, self.tvec)


def solve_square(corners: np.ndarray, side_m: float, K: np.ndarray, dist: np.ndarray) -> list[PoseHypothesis]:
    """Both IPPE poses of a square of side `side_m` whose corners (TL TR BR BL, px) are `corners`.

    Returns one or two hypotheses sorted by reprojection error (lowest first); empty if OpenCV fails
    (degenerate corners). `K` is the 3×3 camera matrix and `dist` the distortion coefficients.
    """
    img = np.asarray(corners, dtype=np.float64).reshape(4, 1, 2)
    try:
        n, rvecs, tvecs, errs = cv2.solvePnPGeneric(
            _pnp_object_points(float(side_m)), img, K, dist, flags=cv2.SOLVEPNP_IPPE_SQUARE
        )
    except cv2.error:
        return []
    # Scalars through Python floats: this runs for every marker of every frame (bench: perception).
    errs_list = np.asarray(errs, dtype=np.float64).reshape(-1).tolist() if errs is not None else [0.0] * int(n)
    out = []
    for i in range(int(n)):
        rvec = np.asarray(rvecs[i], np.float64).reshape(3)
        tvec = np.asarray(tvecs[i], np.float64).reshape(3)
        values = rvec.tolist() + tvec.tolist()
        if all(map(math.isfinite, values)) and values[5] > 0:  # finite and in front of the camera
            out.append(PoseHypothesis(rvec, tvec, errs_list[i]))
    return sorted(out, key=lambda h: h.reprojection_error)


@dataclass(frozen=True)
class PoseChoice:
    """The pose a source reports for one marker in one frame, and how sure the choice is.

    `ambiguity` is the likelihood of the alternative relative to the chosen pose, in [0, 1]: ~1 when the
    evidence cannot tell them apart, → 0 when the alternative is clearly worse (or there is none).
    `error_ratio` is this frame's raw min/max ratio of the two reprojection errors (1 = indistinguishable).
    """

    chosen: PoseHypothesis
    alternative: PoseHypothesis | None
    ambiguity: float
    error_ratio: float
    switched: bool = False  # the choice flipped to the other hypothesis in this frame
    track_frames: int = 1  # frames the hypotheses have been followed for (1 = new track)


def _frame_evidence(e_a: float, e_b: float, floor_px: float) -> float:
    """Evidence (in [−1, 1]) that hypothesis a explains this frame better than b.

    Normalised squared-error difference: scale-free, so blur and noise level do not change its meaning,
    and bounded, so one noisy frame cannot outweigh a history. `floor_px` keeps near-perfect fits from
    turning rounding noise into evidence.
    """
    a2, b2 = e_a * e_a, e_b * e_b
    return (b2 - a2) / (a2 + b2 + floor_px * floor_px)


def choose_naive(hypotheses: list[PoseHypothesis], floor_px: float = 0.02) -> PoseChoice:
    """The single-frame choice: lowest reprojection error (what ROS nodes do; the benchmark's baseline)."""
    if not hypotheses:
        raise ValueError("no pose hypotheses to choose from")
    best = hypotheses[0]
    alt = hypotheses[1] if len(hypotheses) > 1 else None
    if alt is None:
        return PoseChoice(best, None, 0.0, 0.0)
    ratio = _ratio(best.reprojection_error, alt.reprojection_error)
    ev = _frame_evidence(best.reprojection_error, alt.reprojection_error, floor_px)
    return PoseChoice(best, alt, math.exp(-4.0 * max(0.0, ev)), ratio)


def _ratio(a: float, b: float) -> float:
    lo, hi = min(a, b), max(a, b)
    return 1.0 if hi <= 1e-12 else lo / hi


@dataclass
class _Track:
    rotations: list[np.ndarray]  # the two followed hypotheses' rotations
    evidence: float  # accumulated, decayed evidence that hypothesis 0 is right (negative: hypothesis 1)
    chosen: int
    last_stamp: float
    frames: int = 1


@dataclass
class TemporalDisambiguator:
    """Chooses between the two IPPE poses of each marker using the frames before this one.

    Per key (marker id), both hypotheses are followed over frames: the two new solutions are matched to
    the two followed ones by the smallest total rotation change. Each frame adds to a decayed sum the
    normalised evidence of which hypothesis reprojects better (:func:`_frame_evidence`); the pose
    reported is the one with the better accumulated evidence, changed only when the other leads by
    more than `hysteresis`. Over n frames the random part of the per-frame errors averages out while
    the wrong pose's systematic misfit adds up, so the choice converges where a single frame is a coin
    toss, and a wrong first pick is undone (continuity alone would keep it).

    A frame where one solution is clearly better (error ratio < `clear_ratio`, typical up close) decides
    at once. A track is restarted when the marker was unseen for more than `stale_after_s`, when time
    goes backwards, or when the new solutions cannot be matched within `max_jump_deg` (the marker moved
    too fast to follow, or a different marker took its id).
    """

    decay: float = 0.9  # evidence kept per frame (~10-frame memory)
    hysteresis: float = 0.3  # evidence lead needed to switch
    clear_ratio: float = 0.2  # min/max error ratio for a one-frame decision (0.5 measured: 10 % flips, 0.2: 4 %)
    stale_after_s: float = 1.0
    max_jump_deg: float = 40.0
    floor_px: float = 0.02
    _tracks: dict[object, _Track] = field(default_factory=dict, repr=False)

    def reset(self, key: object | None = None) -> None:
        """Forget one marker's history (or every marker's)."""
        if key is None:
            self._tracks.clear()
        else:
            self._tracks.pop(key, None)

    def choose(self, key: object, stamp: float, hypotheses: list[PoseHypothesis]) -> PoseChoice:
        """The pose to report for marker `key` at time `stamp` (s), given this frame's hypotheses."""
        if not hypotheses:
            raise ValueError("no pose hypotheses to choose from")
        if len(hypotheses) == 1:
            self._tracks.pop(key, None)
            return PoseChoice(hypotheses[0], None, 0.0, 0.0)
        h = list(hypotheses[:2])
        e = [h[0].reprojection_error, h[1].reprojection_error]
        ratio = _ratio(*e)
        rots = [h[0].rotation, h[1].rotation]
        tr = self._tracks.get(key)
        if tr is not None and not (0.0 <= stamp - tr.last_stamp <= self.stale_after_s):
            tr = None
        if tr is not None:
            a00, a11 = se3.rotation_angle(tr.rotations[0], rots[0]), se3.rotation_angle(tr.rotations[1], rots[1])
            a01, a10 = se3.rotation_angle(tr.rotations[0], rots[1]), se3.rotation_angle(tr.rotations[1], rots[0])
            jump = max(a00, a11)
            if a01 + a10 < a00 + a11:
                h, e, rots = h[::-1], e[::-1], rots[::-1]
                jump = max(a01, a10)
            if jump > math.radians(self.max_jump_deg):
                tr = None
        if tr is None:
            # New track: hypothesis 0 is the lower-error one (solve_square sorts), i.e. start naive.
            if e[1] < e[0]:
                h, e, rots = h[::-1], e[::-1], rots[::-1]
            tr = _Track(rotations=rots, evidence=0.0, chosen=0, last_stamp=stamp, frames=0)
            self._tracks[key] = tr
        ev = _frame_evidence(e[0], e[1], self.floor_px)
        tr.evidence = self.decay * tr.evidence + ev
        tr.rotations = rots
        tr.last_stamp = stamp
        tr.frames += 1
        previous = tr.chosen
        if ratio < self.clear_ratio:
            tr.chosen = 0 if e[0] < e[1] else 1
            # A decisive frame also resets the history in its favour, so noise after it cannot undo it.
            tr.evidence = abs(tr.evidence) if tr.chosen == 0 else -abs(tr.evidence)
        elif tr.chosen == 0 and tr.evidence < -self.hysteresis:
            tr.chosen = 1
        elif tr.chosen == 1 and tr.evidence > self.hysteresis:
            tr.chosen = 0
        lead = tr.evidence if tr.chosen == 0 else -tr.evidence
        return PoseChoice(
            chosen=h[tr.chosen],
            alternative=h[1 - tr.chosen],
            ambiguity=math.exp(-4.0 * max(0.0, lead)),
            error_ratio=ratio,
            switched=tr.frames > 1 and tr.chosen != previous,
            track_frames=tr.frames,
        )


def confidence(reprojection_error_px: float, pixel_side_px: float, ambiguity: float) -> float:
    """A 0..1 confidence from quantities that actually predict pose quality.

    * reprojection error (px): a clean fit has ~0.1–0.3 px; the factor ``1 / (1 + (e / 1 px)²)`` halves
      confidence at 1 px (a corner off, motion blur, a partly hidden marker) and drops fast beyond;
    * marker side in the image (px): pose noise scales as 1/side, so ``1 − exp(−side / 25 px)`` gives
      ~0.33 for a 10 px marker (barely decodable), 0.86 at 50 px, ~1 above 100 px;
    * ambiguity in [0, 1] (see :class:`PoseChoice`): position is good even when the flip is unresolved,
      orientation is not, so a fully ambiguous pose keeps half its confidence: ``1 − ambiguity / 2``.
    """
    e = max(0.0, float(reprojection_error_px)) if math.isfinite(reprojection_error_px) else math.inf
    c_fit = 1.0 / (1.0 + e * e) if math.isfinite(e) else 0.0
    c_size = 1.0 - math.exp(-max(0.0, float(pixel_side_px)) / 25.0)
    c_amb = 1.0 - 0.5 * min(1.0, max(0.0, float(ambiguity)))
    return float(min(1.0, max(0.0, c_fit * c_size * c_amb)))
