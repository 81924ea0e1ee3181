"""Rendered mission runs as marker sequences for the tracking benchmark (issue 34): the frames a simulated
robot's camera delivered over a run, each with the exact corners of every marker it could see.

The panning sequences (bench/marker_sequences.py) are a clean test of the tracker: markers on an arc, one
smooth turn. A mission is not that: the robot drives, stops and turns, the target walks and turns its faces,
the occluders hide it, the dock comes close enough to fill the picture. So the benchmark also runs the
tracker over the camera frames of real scenario runs, rendered at the benchmark's resolutions (the
scenario's ``camera.width`` / ``camera.height``).

The truth comes from the simulation: each marker's pose (the target's faces and the dock, from the run's
ground truth at the frame) and the camera's, through the camera's intrinsics, for the black square of the
size the marker was printed at. A marker the camera sees only partly, or from behind, has no truth.
"""

from __future__ import annotations

from typing import Any

import cv2
import numpy as np

from bench.marker_sequences import SequenceFrame
from mission.app.overrides import run_overrides
from mission.app.sim_run import run_scenario
from mission.core.observers import Run, RunObserver
from mission.core.perception import Perceived
from mission.core.types import CameraIntrinsics

SCENARIOS = (("follow_occlusion", 0), ("explore_dock", 0))  # a walking, hidden target; a dock come close


class _Frames(RunObserver):
    """Keeps every processed camera frame of a run, with its markers' true corners."""

    def __init__(self) -> None:
        self.frames: list[SequenceFrame] = []
        self.intrinsics: CameraIntrinsics | None = None

    def on_perception(self, run: Run, perceived: Perceived) -> None:
        frame = perceived.frame
        if frame is None or not perceived.processed or frame.intrinsics is None:
            return
        self.intrinsics = frame.intrinsics
        self.frames.append(SequenceFrame(frame.image.copy(), true_corners(run.world, frame.intrinsics)))


def _markers(world: Any) -> list[tuple[int, float, np.ndarray]]:
    """(id, printed side in m, T_map_marker) of every marker in the world now."""
    truth = world.ground_truth()
    scene, scenario = world.world, world.scenario
    out = [
        (mount.marker_id, mount.size_m, T) for mount, T in zip(scene.markers, truth.T_map_target_markers, strict=False)
    ]
    if truth.T_map_dock is not None and scenario.dock is not None:
        out.append((scenario.dock.id, scenario.dock.printed_size_m, truth.T_map_dock))
    return out


def true_corners(world: Any, k: CameraIntrinsics) -> dict[int, np.ndarray]:
    """id → the black squares' corners (N×4×2 px, in no particular order: N copies of the id, as the target
    wears its id on every face) of every marker wholly in the picture and facing the camera. The ground
    truth's camera is the true one (the detector may be told another)."""
    T_map_opt = world.ground_truth().T_map_optical
    T_opt_map = np.linalg.inv(T_map_opt)
    K = np.array([[k.fx, 0.0, k.cx], [0.0, k.fy, k.cy], [0.0, 0.0, 1.0]])
    D = np.asarray(k.distortion or (0.0,) * 5, dtype=np.float64)
    out: dict[int, np.ndarray] = {}
    for marker_id, side, T_map_marker in _markers(world):
        h = side / 2.0
        local = np.array([[-h, -h, 0.0], [h, -h, 0.0], [h, h, 0.0], [-h, h, 0.0]])
        T = T_opt_map @ T_map_marker
        cam = local @ T[:3, :3].T + T[:3, 3]
        if (cam[:, 2] <= 0.05).any() or float(T[:3, 2] @ -T[:3, 3]) <= 0.0:
            continue  # behind the camera, or its back turned to it
        px, _ = cv2.projectPoints(cam, np.zeros(3), np.zeros(3), K, D)
        px = px.reshape(4, 2)
        inside = (px >= 0).all() and (px[:, 0] <= k.width - 1).all() and (px[:, 1] <= k.height - 1).all()
        if inside:
            seen = out.get(int(marker_id), np.zeros((0, 4, 2)))
            out[int(marker_id)] = np.concatenate([seen, px[None]])
    return out


def mission_sequence(
    scenario: str, seed: int, width: int, height: int, seconds: float
) -> tuple[CameraIntrinsics, list[SequenceFrame]]:
    """The camera frames (BGR) of `seconds` of `scenario` run with `seed`, rendered at `width`×`height`, each
    with its markers' true corners."""
    grab = _Frames()
    overrides = run_overrides([f"camera.width={width}", f"camera.height={height}"])
    run_scenario(scenario, seed=seed, max_duration=seconds, observers=[grab], overrides=overrides)
    if grab.intrinsics is None:
        raise RuntimeError(f"{scenario} seed {seed}: the run delivered no camera frame")
    return grab.intrinsics, grab.frames
