"""Benchmark `real_images`: the fiducial sources on photographs, against the raw libraries on the same files.

Rendered frames say how accurate a detector is; photographs say whether it finds what is there. Each
set of photos names where it comes from (:data:`PHOTO_SETS`): the ArUco photos in ``../shared/data``
(beside the checkout, as CI has them), and public AprilTag test photos fetched onto the measuring
machine into ``out/real-images/<set>/`` (or ``$MISSION_REAL_IMAGES``; never committed). A set that is
not there is left out and listed as missing. Per set:

* **AprilTag recall.** The ``apriltag`` source at its defaults against pupil-apriltags at the library's
  own settings (decimate 2, the old default; decimate 1.5; decimate 1 with and without ``refine_edges``).
  The reference is every tag any of them found (same id, centres within a fifth of the tag's side), and,
  for AprilTag's own test photos, the corners its test lists. Target: recall at the defaults ≥ the best
  library setting's, at ≤ 1.3× the time of decimate 2: our whole ``process()`` against the library's
  ``detect(estimate_tag_pose=True)`` at decimate 2 (both give poses, as in the perception benchmark),
  interleaved image by image; each setting's bare ``detect()`` time is in the details.
* **ArUco corners.** The ``aruco`` source at its defaults against raw OpenCV (``detectMarkers`` with
  OpenCV's default parameters, unrefined and with ``CORNER_REFINE_SUBPIX``). The reference corner is the
  consensus of OpenCV's two line-fitting refiners (``CORNER_REFINE_CONTOUR`` and ``CORNER_REFINE_APRILTAG``),
  where they agree within 1 px; a corner more than 2 px from it is an outlier. Target: no more outliers
  than unrefined OpenCV, and the same ids.
* **Rendered small tags**, for comparison: 15 cm tag36h11 tags 4–7 m away in 640×480 frames (18–30 px),
  where the truth is known.

Run: ``mission bench --only real_images`` (``--quick``: one timing repeat, fewer rendered frames).
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from bench.common import Figure, progress
from bench.perception_bench import raw_aruco_poses
from mission.core.errors import MissionError
from mission.core.types import CameraIntrinsics, Frame
from mission.perception_plugins import marker_dictionaries
from mission.perception_plugins.apriltag import AprilTagSource
from mission.perception_plugins.apriltag_backends import SafeDetector
from mission.perception_plugins.aruco import ArucoSource
from tools import synthetic_views as sv

ROOT = Path(__file__).resolve().parents[1]
TIME_TARGET = 1.3  # ours / raw decimate 2
OUTLIER_PX = 2.0
CONSENSUS_PX = 1.0


def shared_data_dir() -> Path:
    """``../shared/data`` beside the checkout (what CI has), or beside its parent (a git worktree one level
    deeper), or ``$MISSION_SHARED_DATA``; a MissionError saying where it looked when there is none."""
    env = os.environ.get("MISSION_SHARED_DATA")
    candidates = [Path(env)] if env else [ROOT.parent / "shared" / "data", ROOT.parent.parent / "shared" / "data"]
    for c in candidates:
        if c.is_dir():
            return c.resolve()
    raise MissionError(f"no shared real-image data: looked in {', '.join(map(str, candidates))}")


def fetched_dir() -> Path:
    """Where public photo sets fetched onto this machine live (never committed)."""
    return Path(os.environ.get("MISSION_REAL_IMAGES", ROOT / "out" / "real-images"))


@dataclass(frozen=True)
class PhotoSet:
    """Photographs of one origin: what they show and where they come from."""

    name: str
    origin: str  # repository, path, commit and licence
    kind: str  # "aruco" | "apriltag"
    folder: str  # under the shared data (shared=True) or the fetched directory
    patterns: tuple[str, ...]
    dictionary: str = "DICT_APRILTAG_36h11"  # aruco: a DICT_* name or a dictionary file in the folder
    shared: bool = False
    expected_suffix: str | None = None  # apriltag: a text file per image listing the tags the origin expects

    def root(self) -> Path:
        return (shared_data_dir() if self.shared else fetched_dir()) / self.folder

    def files(self) -> list[Path]:
        try:
            root = self.root()
        except MissionError:
            return []
        return sorted({p for pat in self.patterns for p in root.glob(pat)})

    def dictionary_value(self) -> str:
        return str(self.root() / self.dictionary) if marker_dictionaries.is_path(self.dictionary) else self.dictionary


_OPENCV_TUTORIAL = "opencv/opencv_contrib modules/aruco/tutorials/**/images @ 834a98c0 (Apache-2.0), in ../shared/data"
_NASA = "AprilRobotics/apriltag test/data @ 1c21707a (NASA Swarmathon photos, CC BY-SA 2.0)"
_DUCKIE = "pupil-labs/apriltags test/ @ f5334c6e (Duckietown lib-dt-apriltags test photos)"
_JULIA = "JuliaRobotics/AprilTags.jl data/ @ e26240a2 (MIT)"

PHOTO_SETS: tuple[PhotoSet, ...] = (
    PhotoSet("opencv tutorial photos (DICT_6X6_250)", _OPENCV_TUTORIAL, "aruco", "real-aruco",
             ("contrib__singlemarkersoriginal.jpg", "contrib__ch*.jpg", "contrib__img_*.jpg"),
             "DICT_6X6_250", shared=True),
    PhotoSet("opencv tutorial photos (custom dictionary)", _OPENCV_TUTORIAL, "aruco", "real-aruco",
             ("contrib__gboriginal.png", "contrib__diamondmarkers.png"), "contrib__tutorial_dict.yml", shared=True),
    PhotoSet("apriltag test photos (as DICT_APRILTAG_36h11)", _NASA, "aruco", "apriltag-test-data", ("*.jpg",)),
    PhotoSet("duckietown photos (as DICT_APRILTAG_36h11)", _DUCKIE, "aruco", "pupil-apriltags-test", ("*.png",)),
    PhotoSet("AprilTags.jl photos (as DICT_APRILTAG_36h11)", _JULIA, "aruco", "juliarobotics-apriltags", ("*.jpg",)),
    PhotoSet("apriltag test photos", _NASA, "apriltag", "apriltag-test-data", ("*.jpg",), expected_suffix=".txt"),
    PhotoSet("duckietown photos", _DUCKIE, "apriltag", "pupil-apriltags-test", ("*.png",)),
    PhotoSet("AprilTags.jl photos", _JULIA, "apriltag", "juliarobotics-apriltags", ("*.jpg",)),
)  # fmt: skip


def read_grey(path: Path) -> np.ndarray:
    img = cv2.imread(str(path), cv2.IMREAD_GRAYSCALE)
    if img is None:
        raise MissionError(f"{path}: not a readable image")
    return img


def _median_ms(fn: Callable[[], Any], repeats: int) -> float:
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return float(np.median(times)) * 1000.0


def interleaved_ms(fns: dict[str, Callable[[], Any]], repeats: int) -> dict[str, float]:
    """Median ms of each function, called in turn `repeats` times (so all see the same machine load)."""
    samples: dict[str, list[float]] = {k: [] for k in fns}
    for _ in range(repeats):
        for k, fn in fns.items():
            samples[k].append(_median_ms(fn, 1))
    return {k: float(np.median(v)) for k, v in samples.items()}


# --------------------------------------------------------------------------------------------------
# ArUco: ids and corners against OpenCV's refiners
# --------------------------------------------------------------------------------------------------

_OPENCV_METHODS = {
    "unrefined": cv2.aruco.CORNER_REFINE_NONE,
    "subpix": cv2.aruco.CORNER_REFINE_SUBPIX,
    "contour": cv2.aruco.CORNER_REFINE_CONTOUR,
    "apriltag": cv2.aruco.CORNER_REFINE_APRILTAG,
}


def opencv_markers(grey: np.ndarray, dictionary: cv2.aruco.Dictionary, method: int) -> list[tuple[int, np.ndarray]]:
    """Raw OpenCV: ``detectMarkers`` with its default parameters and one corner refinement method."""
    params = cv2.aruco.DetectorParameters()
    params.cornerRefinementMethod = method
    corners, ids, _ = cv2.aruco.ArucoDetector(dictionary, params).detectMarkers(grey)
    if ids is None:
        return []
    return [(int(i), np.asarray(c, np.float64).reshape(4, 2)) for c, i in zip(corners, ids.reshape(-1), strict=True)]


def _match(markers: list[tuple[int, np.ndarray]], marker_id: int, centre: np.ndarray) -> np.ndarray | None:
    best = None
    for i, c in markers:
        if i == marker_id:
            d = float(np.linalg.norm(c.mean(axis=0) - centre))
            side = float(np.linalg.norm(c[1] - c[0]))
            if d <= max(4.0, 0.25 * side) and (best is None or d < best[0]):
                best = (d, c)
    return None if best is None else best[1]


@dataclass
class CornerStudy:
    """Corners of one photo set against the contour/AprilTag-refiner consensus."""

    images: int = 0
    markers_ours: int = 0
    markers_raw: int = 0  # unrefined OpenCV, default parameters
    same_ids: int = 0  # images whose ids (as a multiset) equal raw OpenCV's
    consensus_corners: int = 0
    outliers: dict[str, int] = field(default_factory=dict)  # ours / unrefined / subpix → corners > 2 px off
    compared: dict[str, int] = field(default_factory=dict)  # corners with a consensus each of them has
    worst_px: dict[str, float] = field(default_factory=dict)

    def to_json(self) -> dict[str, Any]:
        return {
            "images": self.images,
            "markers_ours": self.markers_ours,
            "markers_raw_opencv": self.markers_raw,
            "images_with_the_same_ids": self.same_ids,
            "consensus_corners": self.consensus_corners,
            **{f"outliers_{k}": v for k, v in self.outliers.items()},
            **{f"worst_px_{k}": round(v, 2) for k, v in self.worst_px.items()},
        }


def aruco_corner_study(files: Iterable[Path], dictionary: str, params: dict | None = None) -> CornerStudy:
    """Our `aruco` source (`params` over its defaults) and raw OpenCV on `files`, corners against the consensus."""
    study = CornerStudy()
    md = marker_dictionaries.resolve(dictionary)
    if md is None:
        raise MissionError(f"unknown dictionary {dictionary!r}")
    for path in files:
        grey = read_grey(path)
        source = ArucoSource({"dictionary": dictionary, **(params or {})})
        ours = [(int(d.marker_id), np.asarray(d.corners)) for d in source.process(Frame(grey, 0.0))]
        source.close()
        raw = {name: opencv_markers(grey, md.dictionary, m) for name, m in _OPENCV_METHODS.items()}
        study.images += 1
        study.markers_ours += len(ours)
        study.markers_raw += len(raw["unrefined"])
        study.same_ids += sorted(i for i, _ in ours) == sorted(i for i, _ in raw["unrefined"])
        candidates = {"ours": ours, "unrefined": raw["unrefined"], "subpix": raw["subpix"]}
        for marker_id, corners in raw["unrefined"]:
            centre = corners.mean(axis=0)
            a, b = _match(raw["contour"], marker_id, centre), _match(raw["apriltag"], marker_id, centre)
            if a is None or b is None:
                continue
            agree = np.linalg.norm(a - b, axis=1) <= CONSENSUS_PX
            reference = (a + b) / 2.0
            study.consensus_corners += int(agree.sum())
            for name, found in candidates.items():
                c = _match(found, marker_id, centre)
                if c is None:
                    continue
                err = np.linalg.norm(c - reference, axis=1)[agree]
                study.compared[name] = study.compared.get(name, 0) + len(err)
                study.outliers[name] = study.outliers.get(name, 0) + int((err > OUTLIER_PX).sum())
                if len(err):
                    study.worst_px[name] = max(study.worst_px.get(name, 0.0), float(err.max()))
    for name in ("ours", "unrefined", "subpix"):
        study.outliers.setdefault(name, 0)
        study.worst_px.setdefault(name, 0.0)
    return study


def aruco_times(files: list[Path], dictionary: str, repeats: int) -> dict[str, float]:
    """Total ms over `files`: our source's process() and raw OpenCV detectMarkers + solvePnP, interleaved."""
    md = marker_dictionaries.resolve(dictionary)
    assert md is not None
    total = {"ours": 0.0, "raw": 0.0}
    source = ArucoSource({"dictionary": dictionary})
    raw = raw_aruco_poses(md.dictionary, 0.1)
    for path in files:
        img = cv2.imread(str(path))
        h, w = img.shape[:2]
        k = _pinhole(w, h)
        frame = Frame(img, 0.0, intrinsics=k)
        ms = interleaved_ms(
            {"ours": lambda f=frame: source.process(f), "raw": lambda i=img, kk=k: raw(i, kk.matrix, kk.dist_coeffs)},
            repeats,
        )
        for key in total:
            total[key] += ms[key]
    source.close()
    return total


def _pinhole(w: int, h: int) -> CameraIntrinsics:
    return CameraIntrinsics.fallback(w, h)


# --------------------------------------------------------------------------------------------------
# AprilTag: recall against the library's settings
# --------------------------------------------------------------------------------------------------

LIBRARY_SETTINGS = {
    "decimate 2": {"quad_decimate": 2.0, "refine_edges": 1},
    "decimate 1.5": {"quad_decimate": 1.5, "refine_edges": 1},
    "decimate 1": {"quad_decimate": 1.0, "refine_edges": 1},
    "decimate 1, no refine_edges": {"quad_decimate": 1.0, "refine_edges": 0},
}
BASELINE_SETTING = "decimate 2"
WITH_POSE = "decimate 2, estimate_tag_pose"


def _camera(grey: np.ndarray) -> tuple[float, float, float, float]:
    """(fx, fy, cx, cy) of the fallback pinhole our source uses for a frame without intrinsics."""
    k = CameraIntrinsics.fallback(grey.shape[1], grey.shape[0])
    return (k.fx, k.fy, k.cx, k.cy)


@dataclass(frozen=True)
class Tag:
    tag_id: int
    centre: tuple[float, float]
    side: float


def _tags_of(found: Iterable[Any]) -> list[Tag]:
    out = []
    for d in found:
        c = np.asarray(d.corners, np.float64).reshape(4, 2)
        side = float(np.mean(np.linalg.norm(np.roll(c, -1, axis=0) - c, axis=1)))
        out.append(Tag(int(d.tag_id if hasattr(d, "tag_id") else d.marker_id), tuple(c.mean(axis=0)), side))
    return out


def _same(a: Tag, b: Tag) -> bool:
    return a.tag_id == b.tag_id and float(np.hypot(a.centre[0] - b.centre[0], a.centre[1] - b.centre[1])) <= max(
        4.0, 0.2 * max(a.side, b.side)
    )


def union(found: Iterable[list[Tag]]) -> list[Tag]:
    """Every tag found by any of them, once."""
    out: list[Tag] = []
    for tags in found:
        for t in tags:
            if not any(_same(t, u) for u in out):
                out.append(t)
    return out


def recalled(tags: list[Tag], reference: list[Tag]) -> int:
    return sum(any(_same(r, t) for t in tags) for r in reference)


def expected_tags(path: Path) -> list[Tag]:
    """AprilTag's test lists (``id, (x y), (x y), (x y), (x y)`` per line) as Tags."""
    out = []
    for line in path.read_text().splitlines():
        parts = line.replace("(", " ").replace(")", " ").replace(",", " ").split()
        if len(parts) >= 9:
            xy = np.array([float(v) for v in parts[1:9]]).reshape(4, 2)
            side = float(np.mean(np.linalg.norm(np.roll(xy, -1, axis=0) - xy, axis=1)))
            out.append(Tag(int(parts[0]), tuple(xy.mean(axis=0)), side))
    return out


@dataclass
class RecallStudy:
    images: int = 0
    reference: int = 0
    found: dict[str, int] = field(default_factory=dict)  # setting (or "ours") → reference tags found
    ms: dict[str, float] = field(default_factory=dict)  # setting → total ms
    expected: int = 0  # tags the origin's own lists name (0: no lists)
    expected_found: dict[str, int] = field(default_factory=dict)
    sizes_px: list[float] = field(default_factory=list)

    def best_library_setting(self) -> str:
        return max(LIBRARY_SETTINGS, key=lambda k: (self.found.get(k, 0), -self.ms.get(k, 0.0)))

    def to_json(self) -> dict[str, Any]:
        rows = []
        for k in [*LIBRARY_SETTINGS, "ours (defaults)"]:
            key = "ours" if k.startswith("ours") else k
            rows.append(
                {
                    "setting": k,
                    "found": self.found.get(key, 0),
                    "reference": self.reference,
                    "recall": round(self.found.get(key, 0) / max(1, self.reference), 3),
                    **(
                        {"expected_found": f"{self.expected_found.get(key, 0)}/{self.expected}"}
                        if self.expected
                        else {}
                    ),
                    "ms_total": round(self.ms.get(key, 0.0), 1),
                    "time_vs_decimate_2": round(
                        self.ms.get(key, 0.0) / max(1e-9, self.ms.get(BASELINE_SETTING, 0.0)), 2
                    ),
                }
            )
        rows.append(
            {
                "setting": WITH_POSE,
                "ms_total": round(self.ms.get(WITH_POSE, 0.0), 1),
                "time_vs_decimate_2": round(
                    self.ms.get(WITH_POSE, 0.0) / max(1e-9, self.ms.get(BASELINE_SETTING, 0.0)), 2
                ),
            }
        )
        sizes = np.asarray(self.sizes_px) if self.sizes_px else np.zeros(1)
        return {
            "images": self.images,
            "reference_tags": self.reference,
            "tag_side_px": f"{sizes.min():.0f}–{sizes.max():.0f} (median {np.median(sizes):.0f})",
            "rows": rows,
        }


def apriltag_recall_study(images: Iterable[tuple[np.ndarray, list[Tag] | None]], repeats: int) -> RecallStudy:
    """The library at each of LIBRARY_SETTINGS and our source at its defaults on `images` (grey, the
    origin's expected tags or None)."""
    study = RecallStudy()
    detectors = {k: SafeDetector(families="tag36h11", nthreads=1, **v) for k, v in LIBRARY_SETTINGS.items()}
    source = AprilTagSource({})
    for grey, expected in images:
        frame = Frame(grey, 0.0)
        found = {k: _tags_of(d.detect(grey)) for k, d in detectors.items()}
        found["ours"] = _tags_of(source.process(frame))
        reference = union(found.values())
        study.images += 1
        study.reference += len(reference)
        study.sizes_px += [t.side for t in reference]
        for k, tags in found.items():
            study.found[k] = study.found.get(k, 0) + recalled(tags, reference)
        if expected is not None:
            study.expected += len(expected)
            for k, tags in found.items():
                study.expected_found[k] = study.expected_found.get(k, 0) + recalled(tags, expected)
        fns: dict[str, Callable[[], Any]] = {k: (lambda d=d, g=grey: d.detect(g)) for k, d in detectors.items()}
        fns["ours"] = lambda f=frame: source.process(f)
        cam = _camera(grey)
        fns[WITH_POSE] = lambda g=grey, k=cam: detectors[BASELINE_SETTING].detect(
            g, estimate_tag_pose=True, camera_params=k, tag_size=0.15
        )
        for k, v in interleaved_ms(fns, repeats).items():
            study.ms[k] = study.ms.get(k, 0.0) + v
    source.close()
    return study


def rendered_small_tags(n: int, seed: int = 0) -> list[tuple[np.ndarray, list[Tag] | None]]:
    """15 cm tag36h11 tags 4–7 m away in 640×480 frames (18–30 px), up to 50° off axis, blur and noise."""
    rng = np.random.default_rng(seed)
    k = sv.default_intrinsics(640, 480)
    out: list[tuple[np.ndarray, list[Tag] | None]] = []
    for i in range(n):
        d = 4.0 + 3.0 * (i % 4) / 3.0
        v = sv.render_marker_view(
            sv.random_pose(d, 50.0, rng, k, 0.15),
            marker_id=7,
            marker_size_m=0.15,
            dictionary=cv2.aruco.DICT_APRILTAG_36h11,
            intrinsics=k,
            rng=rng,
        )
        side = float(np.mean(np.linalg.norm(np.roll(v.corners, -1, axis=0) - v.corners, axis=1)))
        out.append((cv2.cvtColor(v.image, cv2.COLOR_BGR2GRAY), [Tag(7, tuple(v.corners.mean(axis=0)), side)]))
    return out


# --------------------------------------------------------------------------------------------------
# the benchmark
# --------------------------------------------------------------------------------------------------


def run(quick: bool, out: Path) -> dict[str, Any]:
    repeats = 1 if quick else 5
    figures: list[Figure] = []
    details: dict[str, Any] = {"apriltag": {}, "aruco": {}, "missing_sets": [], "origins": {}}
    for ps in PHOTO_SETS:
        files = ps.files()
        if not files:
            where = "../shared/data" if ps.shared else str(fetched_dir())
            details["missing_sets"].append(f"{ps.name} ({ps.folder} not found under {where})")
            continue
        details["origins"][ps.name] = ps.origin
        if ps.kind == "apriltag":
            images = [
                (
                    read_grey(p),
                    expected_tags(p.with_suffix(ps.expected_suffix))
                    if ps.expected_suffix and p.with_suffix(ps.expected_suffix).is_file()
                    else None,
                )
                for p in files
            ]
            study = apriltag_recall_study(images, repeats)
            _recall_figures(ps.name, ps.origin, study, figures)
            details["apriltag"][ps.name] = {"origin": ps.origin, **study.to_json()}
        else:
            dictionary = ps.dictionary_value()
            cs = aruco_corner_study(files, dictionary)
            times = aruco_times(files, dictionary, repeats)
            _corner_figures(ps.name, ps.origin, cs, times, figures)
            details["aruco"][ps.name] = {
                "origin": ps.origin,
                "dictionary": ps.dictionary,
                **cs.to_json(),
                "ms_ours": round(times["ours"], 1),
                "ms_raw_opencv": round(times["raw"], 1),
            }
        progress(f"real_images: {ps.name} ({len(files)} images)")
    rendered = "rendered small tags (15 cm at 4–7 m, 640×480)"
    study = apriltag_recall_study(rendered_small_tags(12 if quick else 48), repeats)
    _recall_figures(rendered, "tools/synthetic_views.py", study, figures)
    details["apriltag"][rendered] = {"origin": "rendered here (synthetic_views)", **study.to_json()}
    progress("real_images: rendered small tags")
    return {
        "title": "Real images: recall and corners of our sources at their defaults vs the raw libraries on photographs",
        "figures": [f.to_json() for f in figures],
        "details": details,
        "plots": [],
    }


def _recall_figures(name: str, origin: str, study: RecallStudy, figures: list[Figure]) -> None:
    best = study.best_library_setting()
    ours = study.found.get("ours", 0)
    figures.append(
        Figure(
            f"{name}: tags found at the defaults (of {study.reference}; images: {origin})",
            ours,
            "tags",
            baseline=f"pupil-apriltags at its best setting here ({best})",
            baseline_value=study.found.get(best, 0),
            target="≥ the best library setting",
            meets_target=ours >= study.found.get(best, 0),
        )
    )
    base = study.ms.get(WITH_POSE, 0.0)
    r = round(study.ms.get("ours", 0.0) / base, 3) if base else None
    figures.append(
        Figure(
            f"{name}: time of process() at the defaults, all images",
            round(study.ms.get("ours", 0.0), 1),
            "ms",
            baseline="pupil-apriltags detect(estimate_tag_pose=True) at decimate 2 (its usual setting), interleaved",
            baseline_value=round(base, 1),
            ratio=r,
            target=f"ratio ≤ {TIME_TARGET}",
            meets_target=None if r is None else r <= TIME_TARGET,
        )
    )


def _corner_figures(name: str, origin: str, cs: CornerStudy, times: dict[str, float], figures: list[Figure]) -> None:
    figures.append(
        Figure(
            f"{name}: corners > {OUTLIER_PX:g} px off the refiners' consensus (of {cs.compared.get('ours', 0)}; "
            f"images: {origin})",
            cs.outliers["ours"],
            "corners",
            baseline="raw OpenCV detectMarkers, unrefined (SUBPIX: " + str(cs.outliers["subpix"]) + ")",
            baseline_value=cs.outliers["unrefined"],
            target="≤ unrefined OpenCV",
            meets_target=cs.outliers["ours"] <= cs.outliers["unrefined"],
        )
    )
    figures.append(
        Figure(
            f"{name}: markers found",
            cs.markers_ours,
            "markers",
            baseline="raw OpenCV detectMarkers (default parameters)",
            baseline_value=cs.markers_raw,
            target="the same ids in every image",
            meets_target=cs.same_ids == cs.images,
        )
    )
    figures.append(
        Figure(
            f"{name}: time of process(), all images",
            round(times["ours"], 1),
            "ms",
            baseline="raw OpenCV detectMarkers (SUBPIX) + solvePnP per marker, interleaved",
            baseline_value=round(times["raw"], 1),
            ratio=round(times["ours"] / times["raw"], 3) if times["raw"] else None,
        )
    )
