"""Which detection is which target, and the "hybrid" policy between precise and coarse sources.

Precision rule (one rule, on the detection itself, so any plugin can opt in): a detection is *coarse*
when ``det.extra.get("precision") == "coarse"`` (the VLM stub marks its detections so); every other
detection is *precise* (fiducials: aruco, apriltag). Policy ``hybrid``: when a precise detection matches a
target in a frame, coarse detections of that same target are dropped — the VLM finds things far away,
the fiducial gives the pose up close. Policy ``all`` keeps everything.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from mission.core.config import TargetSpec
from mission.core.types import Detection


@dataclass(frozen=True)
class SourcedDetection:
    """A detection and the instance name of the source that produced it (TargetSpec.source matches either)."""

    source: str
    det: Detection


def is_coarse(det: Detection) -> bool:
    return det.extra.get("precision") == "coarse" if isinstance(det.extra, dict) else False


def detection_problem(det: object) -> str | None:
    """Why a source's output item cannot be used (None when it is a usable Detection)."""
    if not isinstance(det, Detection):
        return f"got {type(det).__name__}, expected Detection"
    pos = np.asarray(det.position, dtype=np.float64)
    quat = np.asarray(det.orientation, dtype=np.float64)
    if pos.shape != (3,) or not np.all(np.isfinite(pos)):
        return f"position {pos.tolist()} is not 3 finite numbers"
    if quat.shape != (4,) or not np.all(np.isfinite(quat)) or float(np.linalg.norm(quat)) < 1e-9:
        return f"orientation {quat.tolist()} is not a unit quaternion"
    if not math.isfinite(float(det.stamp)):
        return "stamp is not finite"
    return None


def matches(spec: TargetSpec, d: SourcedDetection) -> bool:
    """A spec's unset fields match anything; `source` matches the instance name or the plugin name."""
    det = d.det
    if spec.marker_id is not None and det.marker_id != spec.marker_id:
        return False
    if spec.label is not None and det.label != spec.label:
        return False
    return spec.source is None or spec.source in (d.source, det.source)


def _rank(d: SourcedDetection) -> tuple[bool, float, float]:
    # precise before coarse, then most confident, then nearest
    return (is_coarse(d.det), -float(d.det.confidence), d.det.distance)


@dataclass
class Assignment:
    """The outcome for one frame: best detection per target, what is kept, how many coarse were dropped."""

    best: dict[str, SourcedDetection]
    kept: list[SourcedDetection]
    coarse_dropped: int


def assign(detections: list[SourcedDetection], targets: dict[str, TargetSpec], policy: str = "hybrid") -> Assignment:
    """Match detections to named targets and apply the policy (see the module doc)."""
    dropped: set[int] = set()
    best: dict[str, SourcedDetection] = {}
    for name, spec in targets.items():
        cands = [(i, d) for i, d in enumerate(detections) if matches(spec, d)]
        if not cands:
            continue
        if policy == "hybrid" and any(not is_coarse(d.det) for _, d in cands):
            dropped.update(i for i, d in cands if is_coarse(d.det))
            cands = [(i, d) for i, d in cands if not is_coarse(d.det)]
        best[name] = min((d for _, d in cands), key=_rank)
    kept = [d for i, d in enumerate(detections) if i not in dropped]
    return Assignment(best=best, kept=kept, coarse_dropped=len(dropped))
