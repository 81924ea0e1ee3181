"""The `apriltag` perception source: AprilTags → attributed, disambiguated 6-DoF detections.

* Two detectors behind one param (perception_plugins/apriltag_backends.py): ``apriltag3``
  (pupil-apriltags, the default: ~4× more accurate corners and faster, see BENCHMARKS.md) and ``opencv``
  (cv2.aruco with the matching ``DICT_APRILTAG_*``). Both report corners in OpenCV's convention, so the
  same tag gives the same corners and, through the shared square-fiducial code
  (perception_plugins/square_pose.py: both IPPE poses + temporal flip disambiguation per id), the same pose.
* Tag attribution, as the localisation listener of the design notes (seeds/003): a ``tags`` table maps an
  id to the entity carrying it (``402: autobot03``, ``53: {name: traffic_sign, static: true}``), with a
  per-tag size and the static transform tag → entity base. The detection's ``label`` is that name.
* Static transforms and the reported frame. With the TF convention of mission.core.se3 (``T_a_b`` maps
  points in b into a), a tag seen by our camera gives ``T_camera_tag``; the tag is mounted on its entity
  (``T_tag_entity``, a right multiplication) and our camera on our robot (``T_base_camera``, a left
  multiplication)::

      T_base_entity = T_base_camera @ T_camera_tag @ T_tag_entity

  ``report_frame: camera`` (default, what the mission tree expects) reports T_camera_tag in the camera
  optical frame, marker z out of the face, plus ``extra["T_camera_entity"]`` when the tag has a
  T_tag_entity. ``report_frame: base`` reports T_base_entity in ``base_frame``.
* Stamps: every detection carries its frame's stamp (moving entities need it); entities marked
  ``static`` in the table are flagged ``extra["static"] = True`` so a consumer may fuse them over time.
* Decode quality: ``extra["hamming"]`` and ``extra["decision_margin"]``; tags above ``max_hamming`` or
  below ``min_decision_margin`` are dropped, and the confidence is the pose confidence of square_pose
  times ``0.5 ** hamming`` times ``1 − exp(−decision_margin / 25)``.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Sequence
from dataclasses import replace
from typing import Any, ClassVar, Literal

import cv2
import numpy as np
from pydantic import Field, PositiveFloat, PositiveInt, field_validator, model_validator

from mission.core import se3
from mission.core.config import Renamed, StrictModel, validate_model
from mission.core.errors import ConfigError
from mission.core.types import Detection, Frame
from mission.perception_plugins import square_pose
from mission.perception_plugins.apriltag_backends import (
    APRILTAG3_MAX_HAMMING,
    OPENCV_DICTIONARIES,
    SUPPORTED_FAMILIES,
    Apriltag3Backend,
    OpenCvBackend,
    RawTag,
)
from mission.perception_plugins.aruco import to_grey
from mission.perception_plugins.aruco_detection import WINDOW_SIDE_PX, QuadDetector
from mission.perception_plugins.corner_refinement import refine_corners, warm_up
from mission.perception_plugins.frame_intrinsics import FrameIntrinsics
from mission.perception_plugins.marker_bits import PatternCheck, aruco_pattern, follow_quads
from mission.perception_plugins.marker_quads import Box
from mission.perception_plugins.marker_tracking import (
    FULL_FRAME_EVERY,
    Found,
    RegionTracker,
    Shrink,
    as_found,
    detect_tracked,
)

log = logging.getLogger(__name__)


class TransformSpec(StrictModel):
    """A rigid transform in config: ``xyz`` (m) and either ``quat`` (x, y, z, w) or ``rpy`` (rad).

    ``rpy`` is URDF's: roll about x, pitch about y, yaw about z, fixed axes (R = Rz(yaw)·Ry(pitch)·Rx(roll)).
    """

    xyz: tuple[float, float, float] = (0.0, 0.0, 0.0)  # translation, metres
    quat: tuple[float, float, float, float] | None = None  # rotation as (x, y, z, w); or give rpy
    rpy: tuple[float, float, float] | None = None  # rotation as URDF roll, pitch, yaw (rad)

    @model_validator(mode="after")
    def _one_rotation(self) -> TransformSpec:
        if self.quat is not None and self.rpy is not None:
            raise ValueError("give either quat or rpy, not both")
        if self.quat is not None and not 1e-6 < math.sqrt(sum(q * q for q in self.quat)) < 1e6:
            raise ValueError(f"quat {list(self.quat)} cannot be normalised")
        return self

    def matrix(self) -> np.ndarray:
        if self.quat is not None:
            rot = se3.quat_to_matrix(self.quat)
        elif self.rpy is not None:
            r, p, y = self.rpy
            rot = se3.rot_z(y) @ se3.rot_y(p) @ se3.rot_x(r)
        else:
            rot = np.eye(3)
        return se3.transform(rot, self.xyz)


class TagSpec(StrictModel):
    """One row of the attribution table: who carries tag <id>, how big it is, how it is mounted."""

    renamed_keys: ClassVar[dict[str, Renamed]] = {"size_m": "marker_size_m"}

    name: str = Field(min_length=1)
    marker_size_m: PositiveFloat | None = None  # black-border side (m); None = the source's marker_size_m
    static: bool = False  # the entity never moves (a sign, a dock): its stamp does not matter
    T_tag_entity: TransformSpec | None = None  # tag frame → entity base frame (None = the tag is the entity)


class AprilTagParams(StrictModel):
    """Params of the `apriltag` source (config ``perception.sources[i].params``)."""

    family: str = "tag36h11"  # tag36h11, tag25h9, tag16h5, tagStandard41h12 (where the backend has it)
    backend: Literal["apriltag3", "opencv"] = "apriltag3"  # pupil-apriltags or OpenCV aruco (BENCHMARKS.md)
    renamed_keys: ClassVar[dict[str, Renamed]] = {  # spellings before the one word for each idea (issue 31)
        "tag_size_m": "marker_size_m",
        "refine_edges": ("corner_refinement", lambda v: "edges" if v else "none"),
    }

    marker_size_m: PositiveFloat = 0.15  # black-border side (m) of tags the table does not size
    tags: dict[int, TagSpec] = Field(default_factory=dict)  # id → entity; "402: autobot03" is short for {name: …}
    ignore_unknown: bool = False  # drop tags that are not in the table
    camera_mount: TransformSpec | None = None  # T_base_camera: robot base → camera optical frame
    report_frame: Literal["camera", "base"] = "camera"  # base: robot base → entity base (camera_mount)
    base_frame: str = Field("base_link", min_length=1)  # frame_id of detections when report_frame is base
    decimate: float = Field(1.0, ge=1.0, le=8.0)  # apriltag3 quad_decimate; 1 = full resolution (opencv: not used)
    threads: int = Field(1, ge=1, le=64)  # apriltag3 nthreads (>1: known data races, troubleshooting); opencv: own pool
    corner_refinement: Literal["edges", "none"] = "edges"  # edges: on their fitted edges (corner_refinement.py)
    min_contrast: Literal["auto"] | int = "auto"  # apriltag3 min_white_black_diff, 0–255; auto: 0.4 × frame spread
    max_hamming: int = Field(2, ge=0, le=5)  # corrected bits accepted (apriltag3 decodes at most 2)
    min_decision_margin: float = Field(0.0, ge=0.0)  # drop weaker decodes (grey levels)
    disambiguation: Literal["temporal", "naive"] = "temporal"  # flip choice, as the aruco source
    tracking: bool = False  # look where the tags were; the full frame only now and then (marker_tracking.py)
    full_frame_every: PositiveInt = FULL_FRAME_EVERY  # tracking: a full-frame pass at least this often

    @field_validator("min_contrast")
    @classmethod
    def _grey_levels(cls, v: Any) -> Any:
        if isinstance(v, int) and not 0 <= v <= 255:
            raise ValueError("expected 'auto' or grey levels 0–255")
        return v

    @field_validator("tags", mode="before")
    @classmethod
    def _short_rows(cls, v: Any) -> Any:
        if isinstance(v, dict):
            return {k: ({"name": row} if isinstance(row, str) else row) for k, row in v.items()}
        return v

    @model_validator(mode="after")
    def _needs_mount(self) -> AprilTagParams:
        if self.report_frame == "base" and self.camera_mount is None:
            raise ValueError("report_frame 'base' needs camera_mount (the robot base → camera optical transform)")
        return self


def _check_backend(p: AprilTagParams) -> None:
    supported = SUPPORTED_FAMILIES[p.backend]
    if p.family not in supported:
        raise ConfigError(
            f"family {p.family!r} is not supported by backend {p.backend!r}; supported: {', '.join(supported)}",
            key="family",
        )
    if p.backend == "apriltag3" and p.max_hamming > APRILTAG3_MAX_HAMMING:
        raise ConfigError(
            f"backend 'apriltag3' corrects at most {APRILTAG3_MAX_HAMMING} bits, got {p.max_hamming}",
            key="max_hamming",
        )


def _params(params: dict) -> AprilTagParams:
    try:
        return validate_model(AprilTagParams, params)
    except ConfigError as err:
        if all(key != "(top level)" for key, _ in err.problems):
            raise
        problems = [  # a model-level check: name the key it is about
            (("camera_mount" if "camera_mount" in msg else None), msg.removeprefix("value error, "))
            if key == "(top level)"
            else (key, msg)
            for key, msg in err.problems
        ]
        raise ConfigError.several(problems, file=err.file) from None


def _searcher(family: str) -> QuadDetector | None:
    """OpenCV's detector for `family`, for tracking's search pass; None for a family OpenCV does not have (its
    new tags then wait for the next full-frame pass)."""
    if family not in OPENCV_DICTIONARIES:
        return None
    dictionary = cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, OPENCV_DICTIONARIES[family]))
    return QuadDetector(dictionary, lambda params: None)


def _pattern_check(family: str, cells: int) -> PatternCheck | None:
    """The check that a followed tag's quad holds its tag (marker_bits), from OpenCV's dictionary of `family`,
    whose corners' order both backends return; None for a family OpenCV does not have (its tags are then
    detected in windows on every frame)."""
    if family not in OPENCV_DICTIONARIES:
        return None
    dictionary = cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, OPENCV_DICTIONARIES[family]))
    return PatternCheck(cells, aruco_pattern(dictionary))


def decode_confidence(hamming: int, decision_margin: float) -> float:
    """0..1 from AprilTag's decode quality: halves per corrected bit; a weak margin (< ~25 grey levels) costs."""
    return float(0.5 ** max(0, hamming) * (1.0 - math.exp(-max(0.0, decision_margin) / 25.0)))


def _pose7(t: np.ndarray) -> list[float]:
    pos, quat = se3.to_pos_quat(t)
    return [round(float(x), 6) for x in (*pos, *quat)]


class AprilTagSource:
    """AprilTags (AprilTag 3 or OpenCV), attributed to named entities, with static-transform composition."""

    description: ClassVar[str] = (
        "AprilTags (tag36h11/25h9/16h5/Standard41h12; AprilTag 3 or OpenCV): attributed entity names, "
        "static transforms, disambiguated 6-DoF pose"
    )

    def __init__(self, params: dict, name: str = "apriltag") -> None:
        self.name = name
        self.params = p = _params(params)
        _check_backend(p)
        self.T_base_camera = p.camera_mount.matrix() if p.camera_mount is not None else None
        self._T_tag_entity = {i: row.T_tag_entity.matrix() for i, row in p.tags.items() if row.T_tag_entity is not None}
        if p.backend == "apriltag3":
            self._backend: Apriltag3Backend | OpenCvBackend = Apriltag3Backend(
                p.family,
                decimate=p.decimate,
                threads=p.threads,
                refine_edges=p.corner_refinement == "edges",
                min_contrast=None if p.min_contrast == "auto" else int(p.min_contrast),
            )
        else:
            edges = p.corner_refinement == "edges"
            self._backend = OpenCvBackend(p.family, max_hamming=p.max_hamming, refine_edges=edges)
        self._disambiguator = square_pose.TemporalDisambiguator()
        self._intrinsics = FrameIntrinsics(self.name, log)
        self.counters: dict[str, int] = {}
        self.tracker = RegionTracker(p.full_frame_every) if p.tracking else None
        self._searcher = _searcher(p.family) if p.tracking else None
        edges = p.corner_refinement == "edges"
        self._pattern_check = _pattern_check(p.family, self._backend.cells) if p.tracking and edges else None
        if edges:
            warm_up()  # compiled refinement: paid now, not on the first frame of a running loop

    # -- lookups -----------------------------------------------------------------------------------
    def marker_size(self, tag_id: int) -> float:
        """The black-border side (m) of tag `tag_id`: its table row's, else the source's."""
        row = self.params.tags.get(tag_id)
        sized = row is not None and row.marker_size_m is not None
        return float(row.marker_size_m if sized else self.params.marker_size_m)

    def entity(self, tag_id: int) -> str | None:
        """The attributed entity name of a tag id (None when the table does not know it)."""
        row = self.params.tags.get(tag_id)
        return row.name if row is not None else None

    def _count(self, key: str) -> None:
        self.counters[key] = self.counters.get(key, 0) + 1

    def _tracked(self, grey: np.ndarray) -> list[RawTag]:
        """This frame's tags through the tracker. With edges refinement its windows are searched scaled down
        (as the aruco source's) and every tag's corners are refined here, in the frame, at full resolution."""
        edges = self.params.corner_refinement == "edges"
        shrink = Shrink(WINDOW_SIDE_PX) if edges else None
        follow = self._follow if self._pattern_check is not None else None
        found = detect_tracked(grey, self.tracker, self._found, self._search, shrink, follow=follow)
        tags = [replace(f.extra, corners=f.quad) for f in found]
        todo = [k for k, f in enumerate(found) if not f.refined]  # a followed tag's corners are final (follow_quads)
        if edges and todo:
            quads = refine_corners(grey, np.stack([tags[k].corners for k in todo]), self._backend.cells)
            for k, q in zip(todo, quads, strict=True):
                tags[k] = replace(tags[k], corners=q)
        return tags

    def _found(self, grey: np.ndarray, min_perimeter_rate: float | None) -> list[Found]:
        """The backend's tags in `grey` (a frame, or tracking's mosaic of windows), corners unrefined."""
        tags = self._backend.detect(grey, min_perimeter_rate, refine=False)
        return [Found(t.corners, t.tag_id, t) for t in tags]

    def _follow(self, grey: np.ndarray, quads: np.ndarray, ids: np.ndarray) -> list[np.ndarray | None]:
        """follow_quads with the family's pattern; a followed tag keeps its last decode's hamming distance and
        decision margin."""
        assert self._pattern_check is not None
        return follow_quads(grey, quads, ids, self._backend.cells, self._pattern_check)

    def _search(self, grey: np.ndarray, skip: Sequence[Box], finer: bool) -> list[Found]:
        """Tracking's search pass: OpenCV's detector for the family on the frame sampled down (QuadDetector.search;
        AprilTag 3 costs most of a full frame even there). It only says where to look: each tag it finds is
        detected again by the backend, at full resolution, in a window of its own."""
        if self._searcher is None:
            return []
        return as_found(*self._searcher.search(grey, skip, finer))

    # -- the tick ----------------------------------------------------------------------------------
    def process(self, frame: Frame) -> list[Detection]:
        grey = to_grey(frame.image)
        raw = self._tracked(grey) if self.tracker is not None else self._backend.detect(grey)
        if not raw:
            return []
        intr, degraded = self._intrinsics(frame)
        camera = (intr.matrix, intr.dist_coeffs, degraded)  # built once per frame, not per tag
        out = []
        for tag in raw:
            det = self._detection(frame, tag, camera)
            if det is not None:
                out.append(det)
        return out

    def _detection(self, frame: Frame, tag: RawTag, camera: tuple[np.ndarray, np.ndarray, bool]) -> Detection | None:
        """`camera`: (K, distortion, degraded) of this frame's intrinsics."""
        p = self.params
        K, dist, degraded = camera
        if tag.hamming > p.max_hamming:
            self._count("rejected_hamming")
            return None
        if tag.decision_margin < p.min_decision_margin:
            self._count("rejected_margin")
            return None
        row = p.tags.get(tag.tag_id)
        if row is None and p.ignore_unknown:
            self._count("ignored_unknown")
            return None
        size = self.marker_size(tag.tag_id)
        hyps = square_pose.solve_square(tag.corners, size, K, dist)
        if not hyps:
            self._count("pose_failed")
            return None
        if p.disambiguation == "temporal":
            choice = self._disambiguator.choose(tag.tag_id, frame.stamp, hyps)
        else:
            choice = square_pose.choose_naive(hyps)
        best = choice.chosen
        side_px = square_pose.pixel_side(tag.corners)
        err = best.reprojection_error if math.isfinite(best.reprojection_error) else math.inf
        confidence = square_pose.confidence(err, side_px, choice.ambiguity) * decode_confidence(
            tag.hamming, tag.decision_margin
        )
        T_tag_entity = self._T_tag_entity.get(tag.tag_id)
        extra: dict[str, Any] = {
            "precision": "precise",
            "hamming": tag.hamming,
            "decision_margin": round(tag.decision_margin, 2),
            "static": bool(row.static) if row is not None else False,
            "family": p.family,
            "backend": p.backend,
            "marker_size_m": size,
            "ambiguity": round(choice.ambiguity, 4),
            "error_ratio": round(choice.error_ratio, 4),
            "track_frames": choice.track_frames,
            "pixel_size": round(side_px, 2),
            "intrinsics": "fallback" if degraded else "calibrated",
        }
        if p.report_frame == "base":
            assert self.T_base_camera is not None
            # robot base → camera (left), camera → tag (measured), tag → entity base (right)
            T_camera_tag = best.T
            reported = se3.compose(self.T_base_camera, T_camera_tag)
            if T_tag_entity is not None:
                reported = se3.compose(reported, T_tag_entity)
            frame_id = p.base_frame
            extra["T_camera_tag"] = _pose7(T_camera_tag)
            pos, quat = se3.to_pos_quat(reported)
        else:
            # T_camera_tag itself: its parts as solved, without building the 4×4 (every tag, every frame)
            pos, quat = best.tvec.copy(), se3.matrix_to_quat(best.rotation)
            frame_id = frame.frame_id
            if T_tag_entity is not None:
                extra["T_camera_entity"] = _pose7(se3.compose(best.T, T_tag_entity))
        return Detection(
            source=self.name,
            marker_id=tag.tag_id,
            label=row.name if row is not None else None,
            corners=tag.corners,
            position=pos,
            orientation=quat,
            confidence=float(min(1.0, max(0.0, confidence))),
            reprojection_error=err,
            stamp=frame.stamp,
            frame_id=frame_id,
            extra=extra,
        )

    def close(self) -> None:
        self._backend.close()
        self._disambiguator.reset()
        if self.tracker is not None:
            self.tracker.reset()
