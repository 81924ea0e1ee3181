"""The `aruco` perception source: OpenCV ArUco markers → Detections with a disambiguated 6-DoF pose.

Semantics of the ``aruco_pose_streamer`` design notes (seeds/000): configurable dictionary with a
warning and DICT_4X4_250 fallback, marker size (plus per-id sizes), intrinsics from the frame with the
fx = fy = 0.9·W fallback pinhole in degraded mode, zero distortion when none is given. Beyond them:
every OpenCV predefined dictionary and custom ones from an OpenCV dictionary file
(perception_plugins/marker_dictionaries.py), optional id filter, sub-pixel corners that stay on the
marker (perception_plugins/corner_refinement.py), and both IPPE poses kept and chosen between over time
(perception_plugins/square_pose.py), with a confidence computed from the fit.

OpenCV 4.x (≥ 4.8, ``ArucoDetector``) and 5.x are both supported; which of the detector's quads is the
marker is chosen in perception_plugins/aruco_detection.py.
"""

from __future__ import annotations

import difflib
import logging
import math
from collections.abc import Sequence
from typing import Any, ClassVar, Literal

import cv2
import numpy as np
from pydantic import Field, PositiveFloat, PositiveInt

from mission.core import se3
from mission.core.config import StrictModel, validate_model
from mission.core.errors import ConfigError
from mission.core.types import Detection, Frame
from mission.perception_plugins import marker_dictionaries, square_pose
from mission.perception_plugins.aruco_detection import WINDOW_SIDE_PX, QuadDetector
from mission.perception_plugins.corner_refinement import refine_corners, subpix_corners, warm_up
from mission.perception_plugins.frame_intrinsics import FrameIntrinsics
from mission.perception_plugins.marker_bits import PatternCheck, aruco_pattern, follow_quads
from mission.perception_plugins.marker_dictionaries import PREDEFINED, MarkerDictionary
from mission.perception_plugins.marker_quads import Box
from mission.perception_plugins.marker_tracking import (
    FULL_FRAME_EVERY,
    Found,
    RegionTracker,
    Shrink,
    as_arrays,
    as_found,
    detect_tracked,
)

log = logging.getLogger(__name__)

DEFAULT_DICTIONARY = "DICT_4X4_250"
SUPPORTED_DICTIONARIES = PREDEFINED  # and any OpenCV dictionary file

# What OpenCV's detector refines itself; "edges" and "subpix" are done here, on its unrefined corners.
_REFINEMENT = {
    "edges": "CORNER_REFINE_NONE",
    "subpix": "CORNER_REFINE_NONE",
    "none": "CORNER_REFINE_NONE",
    "contour": "CORNER_REFINE_CONTOUR",
    "apriltag": "CORNER_REFINE_APRILTAG",
}


class ArucoParams(StrictModel):
    """Params of the `aruco` source (config `perception.sources[i].params`, or `mission detect --set`)."""

    dictionary: str = DEFAULT_DICTIONARY  # a DICT_* name or a dictionary .yml; an unknown name is a config error
    marker_size_m: PositiveFloat = 0.049  # black square's side, metres
    marker_sizes: dict[int, PositiveFloat] = Field(default_factory=dict)  # per-id override
    allowed_ids: list[int] | None = None  # None = report every id of the dictionary
    corner_refinement: Literal["edges", "subpix", "none", "contour", "apriltag"] = "edges"  # see corner_refinement.py
    disambiguation: Literal["temporal", "naive"] = "temporal"  # naive = lowest error per frame (baseline)
    tracking: bool = False  # look where the markers were; the full frame only now and then (marker_tracking.py)
    full_frame_every: PositiveInt = FULL_FRAME_EVERY  # tracking: a full-frame pass at least this often


def _make_detector(dictionary: cv2.aruco.Dictionary, refinement: str) -> QuadDetector:
    """OpenCV's ArUco detector (``ArucoDetector``: OpenCV ≥ 4.8 and 5.x) refining with `refinement`'s OpenCV
    method, choosing the marker's own quad (perception_plugins/aruco_detection.py)."""

    def configure(params: Any) -> None:
        params.cornerRefinementMethod = getattr(cv2.aruco, _REFINEMENT[refinement])

    return QuadDetector(dictionary, configure)


def _dictionary(value: str, source: str) -> MarkerDictionary:
    """The dictionary `value` names. An unknown name is a config error listing the names there are, as an
    unknown AprilTag family is: a robot that silently read another dictionary would see no markers — or the
    wrong ones (issue 36; the design notes' fallback to DICT_4X4_250 hid exactly that). A dictionary file
    that cannot be read is a config error too."""
    found = marker_dictionaries.resolve(value, key="dictionary")
    if found is not None:
        return found
    hint = difflib.get_close_matches(str(value).upper(), SUPPORTED_DICTIONARIES, n=1)
    raise ConfigError(
        f"unsupported dictionary {value!r}{f' (did you mean {hint[0]}?)' if hint else ''}; supported: "
        f"{', '.join(SUPPORTED_DICTIONARIES)}, or an OpenCV dictionary file (.yml)",
        key="dictionary",
    )


def to_grey(image: Any) -> np.ndarray:
    """A uint8 grey image from a mono (H×W, H×W×1) or BGR (H×W×3) frame; anything else is a ValueError."""
    if not isinstance(image, np.ndarray):
        raise ValueError(f"expected a numpy image (H×W or H×W×3 uint8), got {type(image).__name__}")
    if image.dtype != np.uint8:
        raise ValueError(f"expected a uint8 image (H×W mono or H×W×3 BGR), got dtype {image.dtype}")
    if image.size == 0:  # before cvtColor, which fails on an empty array with a multi-line cv2.error
        raise ValueError(f"empty image of shape {tuple(image.shape)}; expected H×W mono or H×W×3 BGR")
    if image.ndim == 2:
        grey = image
    elif image.ndim == 3 and image.shape[2] == 1:
        grey = image[:, :, 0]
    elif image.ndim == 3 and image.shape[2] == 3:
        grey = cv2.cvtColor(image, cv2.COLOR_BGR2GRAY)
    else:
        raise ValueError(f"expected an H×W mono or H×W×3 BGR image, got shape {tuple(image.shape)}")
    if grey.shape[0] < 8 or grey.shape[1] < 8:
        raise ValueError(f"image {grey.shape[1]}×{grey.shape[0]} is too small to hold a marker")
    return np.ascontiguousarray(grey)


class ArucoSource:
    """OpenCV ArUco markers with IPPE pose, temporal flip disambiguation and a real confidence."""

    description: ClassVar[str] = (
        "OpenCV ArUco markers (every DICT_*, or a dictionary file): 6-DoF pose (IPPE, temporally disambiguated)"
    )

    def __init__(self, params: dict, name: str = "aruco") -> None:
        self.name = name
        self.params = validate_model(ArucoParams, params)
        self.requested_dictionary = self.params.dictionary
        self.marker_dictionary = _dictionary(self.params.dictionary, name)
        self.dictionary = self.marker_dictionary.name
        self._cells = self.marker_dictionary.marker_bits + 2  # data bits + the black border, in modules
        self._detect = _make_detector(self.marker_dictionary.dictionary, self.params.corner_refinement)
        self._allowed = None if self.params.allowed_ids is None else set(self.params.allowed_ids)
        self._disambiguator = square_pose.TemporalDisambiguator()
        self._intrinsics = FrameIntrinsics(self.name, log)
        self.tracker = RegionTracker(self.params.full_frame_every) if self.params.tracking else None
        follows = self.params.tracking and self.params.corner_refinement == "edges"
        pattern = aruco_pattern(self.marker_dictionary.dictionary)
        self._pattern_check = PatternCheck(self._cells, pattern) if follows else None
        if self.params.corner_refinement == "edges":
            warm_up()  # compiled refinement: paid now, not on the first frame of a running loop

    # ------------------------------------------------------------------------------------------------

    def _refine(self, grey: np.ndarray, corners: Any) -> np.ndarray:
        """The detector's corners (M×4×2 float64), refined here when the method is ours."""
        quads = np.asarray(corners, dtype=np.float64).reshape(-1, 4, 2)
        method = self.params.corner_refinement
        if method == "edges":
            return refine_corners(grey, quads, self._cells)
        if method == "subpix":
            return subpix_corners(grey, quads, self._cells)
        return quads

    def _found(self, grey: np.ndarray, min_perimeter_rate: float | None) -> list[Found]:
        """A frame's (rate None) or tracking windows' markers, as the full frame finds them."""
        return as_found(*self._detect(grey, min_perimeter_rate))

    def _found_shrunk(self, grey: np.ndarray, min_perimeter_rate: float | None) -> list[Found]:
        """Tracking windows scaled down for the edges refiner: one threshold window (QuadDetector.window)."""
        return as_found(*self._detect.window(grey, min_perimeter_rate or 0.0))

    def _recovered(self, grey: np.ndarray, min_perimeter_rate: float | None) -> list[Found]:
        """A tracking window where a tracked marker was missed, read as the rescue pass reads the frame."""
        return as_found(*self._detect.recover(grey, min_perimeter_rate))

    def _search(self, grey: np.ndarray, skip: Sequence[Box], finer: bool) -> list[Found]:
        return as_found(*self._detect.search(grey, skip, finer))

    def _follow(self, grey: np.ndarray, quads: np.ndarray, ids: np.ndarray) -> list[np.ndarray | None]:
        assert self._pattern_check is not None
        return follow_quads(grey, quads, ids, self._cells, self._pattern_check)

    def marker_size(self, marker_id: int) -> float:
        """The side length (m) configured for `marker_id`."""
        return float(self.params.marker_sizes.get(marker_id, self.params.marker_size_m))

    def process(self, frame: Frame) -> list[Detection]:
        corners, ids = self.markers(to_grey(frame.image))
        return self.detections(frame, corners, ids)

    def markers(self, grey: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The frame's markers before pose (N×4×2 corners, final; N ids): what OpenCV's ``detectMarkers`` gives,
        so a bench can time the detection against it alone (process = detections of markers)."""
        if self.tracker is not None:
            edges = self.params.corner_refinement == "edges"
            shrink = Shrink(WINDOW_SIDE_PX, self._found_shrunk) if edges else None
            follow = self._follow if self._pattern_check is not None else None
            found = detect_tracked(grey, self.tracker, self._found, self._search, shrink, self._recovered, follow)
            corners, ids = as_arrays(found)
            final = np.array([f.refined for f in found], dtype=bool)
        else:
            corners, ids = self._detect(grey, None)
            final = np.zeros(len(ids), dtype=bool)
        if len(ids) and not final.all():  # a followed marker's corners are final already (follow_quads)
            corners[~final] = self._refine(grey, corners[~final])
        return corners, ids

    def detections(self, frame: Frame, corners: np.ndarray, ids: np.ndarray) -> list[Detection]:
        """`markers`' result for `frame` as Detections: each marker's pose (IPPE, disambiguated), skipping ids not
        allowed and markers whose pose fails."""
        if len(ids) == 0:
            return []
        intrinsics, degraded = self._intrinsics(frame)
        K, D = intrinsics.matrix, intrinsics.dist_coeffs
        out: list[Detection] = []
        for c, mid in zip(corners, np.asarray(ids).reshape(-1), strict=True):
            marker_id = int(mid)
            if self._allowed is not None and marker_id not in self._allowed:
                continue
            size = self.marker_size(marker_id)
            hyps = square_pose.solve_square(c, size, K, D)
            if not hyps:
                continue
            if self.params.disambiguation == "temporal":
                choice = self._disambiguator.choose(marker_id, frame.stamp, hyps)
            else:
                choice = square_pose.choose_naive(hyps)
            out.append(self._detection(frame, marker_id, c, size, choice, degraded))
        return out

    def _detection(
        self,
        frame: Frame,
        marker_id: int,
        corners: np.ndarray,
        size: float,
        choice: square_pose.PoseChoice,
        degraded: bool,
    ) -> Detection:
        best = choice.chosen
        side_px = square_pose.pixel_side(corners)
        extra: dict[str, Any] = {
            "rvec": [round(v, 6) for v in best.rvec.tolist()],  # tolist: Python floats, not numpy scalars
            "tvec": [round(v, 6) for v in best.tvec.tolist()],
            "ambiguity": round(choice.ambiguity, 4),
            "error_ratio": round(choice.error_ratio, 4),
            "pixel_size": round(side_px, 2),
            "marker_size_m": size,
            "dictionary": self.dictionary,
            "intrinsics": "fallback" if degraded else "calibrated",
            "disambiguation": self.params.disambiguation,
            "track_frames": choice.track_frames,  # consecutive frames this marker's pose has been followed
        }
        if choice.alternative is not None:
            alt = choice.alternative
            extra["alternative"] = {
                "rvec": [round(v, 6) for v in alt.rvec.tolist()],
                "tvec": [round(v, 6) for v in alt.tvec.tolist()],
                "reprojection_error": round(alt.reprojection_error, 4),
            }
        err = best.reprojection_error if math.isfinite(best.reprojection_error) else float("inf")
        return Detection(
            source=self.name,
            marker_id=marker_id,
            label=None,
            corners=corners,
            position=np.asarray(best.tvec, dtype=np.float64).copy(),
            orientation=se3.matrix_to_quat(best.rotation),
            confidence=square_pose.confidence(err, side_px, choice.ambiguity),
            reprojection_error=err,
            stamp=frame.stamp,
            frame_id=frame.frame_id,
            extra=extra,
        )

    def close(self) -> None:
        self._disambiguator.reset()
        if self.tracker is not None:
            self.tracker.reset()
