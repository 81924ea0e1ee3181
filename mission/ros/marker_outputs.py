"""What the node says about markers, as plain data: the edge-triggered flag, debug JSON, TF child names.

The ArUco subsystem's contract (design notes, "aruco_pose_streamer"), kept free of rclpy so it is
tested directly and reused by replay:

* ``/marker_detected`` is published only on visibility transitions (true on the first frame with a
  marker after none, false on the first frame without one after some); it starts as "not visible".
* ``/aruco/debug`` carries a 1 Hz heartbeat ``{"status": "running", "node": …}`` and, for every
  processed frame with markers, an observation ``{"frame_id", "stamp", "ids", "markers": [{"id",
  "tvec_m", "rvec_rad", …}]}``.
* TF child frames are ``aruco_marker_<id>``, plus the detection's label (a tag's attributed entity
  name, a VLM label) made into a valid frame name.
"""

from __future__ import annotations

import re
from typing import Any

import numpy as np

from mission.core import se3
from mission.core.types import Detection, TargetTrack


class VisibilityEdge:
    """Turns per-frame visibility into transitions: ``update`` returns the new value only when it changed."""

    def __init__(self) -> None:
        self.visible = False
        self.transitions = 0

    def update(self, visible: bool) -> bool | None:
        if visible == self.visible:
            return None
        self.visible = visible
        self.transitions += 1
        return visible


def marker_frame_name(marker_id: int) -> str:
    return f"aruco_marker_{int(marker_id)}"


def label_frame_name(label: str) -> str:
    """A label as a TF frame name: lower case, [a-z0-9_] only (``"red cube"`` → ``red_cube``)."""
    return re.sub(r"_+", "_", re.sub(r"[^a-z0-9_]", "_", label.strip().lower())).strip("_")


def tf_child_frames(det: Detection) -> list[str]:
    """Every TF child frame this detection is published as."""
    names = [marker_frame_name(det.marker_id)] if det.marker_id is not None else []
    if det.label:
        name = label_frame_name(det.label)
        if name and name not in names:
            names.append(name)
    return names


def detection_matrix(det: Detection) -> np.ndarray:
    """T_camera_marker of a detection."""
    return se3.from_pos_quat(det.position, det.orientation)


def observation_json(frame_id: str, stamp: float, detections: list[Detection]) -> dict[str, Any]:
    """One processed frame's markers as the debug topic carries them."""
    markers = []
    for det in detections:
        rvec = se3.matrix_to_rvec(se3.quat_to_matrix(det.orientation))
        markers.append(
            {
                "id": det.marker_id,
                "label": det.label,
                "source": det.source,
                "tvec_m": [round(float(v), 5) for v in det.position],
                "rvec_rad": [round(float(v), 5) for v in rvec],
                "distance_m": round(det.distance, 5),
                "confidence": round(float(det.confidence), 4),
                "reprojection_error_px": round(float(det.reprojection_error), 4),
            }
        )
    return {
        "frame_id": frame_id,
        "stamp": round(float(stamp), 6),
        "ids": [m["id"] for m in markers],
        "markers": markers,
    }


def heartbeat_json(node: str, counters: dict[str, Any]) -> dict[str, Any]:
    """The 1 Hz liveness message, with the counters an operator needs (frames, drops, errors)."""
    return {"status": "running", "node": node, **counters}


def current_detection(tracks: dict[str, TargetTrack] | None, name: str, stamp: float) -> Detection | None:
    """The named target's detection in the frame at `stamp` (None when it was not seen in that frame)."""
    tr = (tracks or {}).get(name)
    if tr is None or tr.detection is None or tr.misses != 0 or tr.last_seen is None:
        return None
    return tr.detection if abs(float(tr.last_seen) - float(stamp)) < 1e-9 else None
