"""The perception stage: frames → detections → per-target tracks before every tick, and bad input that
never stops the mission (perception_plugins/pipeline.py)."""

from __future__ import annotations

import logging
import math

import numpy as np

from mission.behaviours.line_of_sight import fitted_velocity
from mission.core import blackboard as bbk
from mission.core import se3
from mission.core.config import TargetSpec
from mission.core.perception import Perceived
from mission.core.types import Frame, Pose2D
from mission.perception_plugins.pipeline import PerceptionStage
from tests.helpers.behaviour_world import EXTRINSICS, Scene, ScriptedSource, board, detection_of, marker_facing, read

TARGETS = {"target": TargetSpec(marker_id=7), "dock": TargetSpec(marker_id=0)}


def make(sources: list, policy: str = "hybrid") -> PerceptionStage:
    return PerceptionStage(sources, dict(TARGETS), policy)


def step(scene: Scene, stage: PerceptionStage) -> Perceived | None:
    """One runner step without a tree: the world senses, the stage perceives the new frame, time passes."""
    scene.sense()
    perceived = stage.update(board())
    scene.act()
    return perceived


def test_a_seen_target_is_placed_in_the_map_through_robot_pose_and_extrinsics():
    marker = marker_facing(3.0, 2.0, math.radians(-150))
    scene = Scene(robot=Pose2D(1.0, 0.5, math.radians(40)), marker=marker)
    stage = make([scene.source()])

    perceived = step(scene, stage)
    assert perceived is not None and perceived.processed and not perceived.errors
    tr = read(bbk.TRACKS)["target"]
    assert tr.visible and tr.misses == 0 and tr.last_seen == scene.clock - scene.dt
    np.testing.assert_allclose(tr.pose_map, marker, atol=1e-9)
    assert tr.robot_at_last_seen == scene.robot
    assert [d.marker_id for d in read(bbk.DETECTIONS)] == [7]
    assert read(bbk.PERCEPTION_STATS)["frames_processed"] == 1
    assert "target seen" in perceived.summary and "(3.00, 2.00)" in perceived.summary
    dock = read(bbk.TRACKS)["dock"]
    assert not dock.visible and dock.last_seen is None and dock.misses == 1


def test_a_late_frame_is_placed_where_the_camera_was_when_it_was_taken():
    marker = marker_facing(3.0, 2.0, math.radians(-150))
    then = Pose2D(1.0, 0.5, math.radians(40))
    scene = Scene(robot=then, marker=marker)
    frame = Frame(
        image=np.zeros((48, 64, 3), np.uint8),
        stamp=1.0,
        T_anchor_camera=se3.planar(then.x, then.y, then.yaw) @ EXTRINSICS,
    )
    seen_then = detection_of(marker, then, stamp=1.0)
    stage = make([ScriptedSource("aruco", lambda f: [seen_then])])
    scene.robot = Pose2D(1.6, 0.9, math.radians(70))  # the robot moved on before the frame was perceived
    scene.sense()
    w = bbk.writer("adapter")
    bbk.set_(w, bbk.FRAME, frame)
    stage.update(board())
    np.testing.assert_allclose(read(bbk.TRACKS)["target"].pose_map, marker, atol=1e-9)


def test_visible_is_edge_triggered_and_misses_count_consecutive_frames():
    scene = Scene(marker=marker_facing(2.0, 0.0, math.pi))
    stage = make([scene.source()])
    seen_pattern = [True, True, False, False, False, True, True]
    flags, misses = [], []
    for seen in seen_pattern:
        scene.hidden = not seen
        step(scene, stage)
        tr = read(bbk.TRACKS)["target"]
        flags.append(tr.visible)
        misses.append(tr.misses)
    assert flags == seen_pattern
    assert misses == [0, 0, 1, 2, 3, 0, 0]
    assert tr.transitions == 3  # on, off, on
    assert tr.last_seen == scene.clock - scene.dt


def test_a_frame_is_perceived_once_however_often_the_stage_is_asked():
    scene = Scene(marker=marker_facing(2.0, 0.0, math.pi), hidden=True)
    src = scene.source()
    stage = make([src])
    step(scene, stage)
    again = [stage.update(board()) for _ in range(3)]  # faster ticks, or the image callback and the tick
    assert again == [None, None, None]
    assert src.calls == 1 and read(bbk.TRACKS)["target"].misses == 1


def test_a_raising_source_is_isolated_counted_logged_once_and_the_next_frame_works(caplog):
    scene = Scene(marker=marker_facing(2.0, 0.0, math.pi))
    raise_on = {2, 3}

    def flaky(frame: Frame) -> list:
        if scene.seq in raise_on:
            raise RuntimeError("model server went away")
        return []

    stage = make([ScriptedSource("vlm", flaky), scene.source("aruco")])
    results = []
    with caplog.at_level(logging.WARNING):
        for _ in range(4):
            results.append(step(scene, stage))
    assert [bool(r.errors) for r in results] == [False, True, True, False]
    assert "source 'vlm' raised RuntimeError: model server went away" in results[1].summary
    # the other source's detection still landed on the failing frames
    tr = read(bbk.TRACKS)["target"]
    assert tr.misses == 0 and tr.transitions == 1
    assert read(bbk.PERCEPTION_STATS)["source_errors:vlm"] == 2
    assert sum("model server went away" in r.getMessage() for r in caplog.records) == 1


def test_hybrid_policy_drops_coarse_detections_of_a_target_a_precise_source_sees():
    scene = Scene(marker=marker_facing(2.0, 0.0, math.pi))
    coarse = {"precision": "coarse"}

    def vlm(frame: Frame) -> list:
        far = marker_facing(2.2, 0.1, math.pi)
        return [detection_of(far, scene.robot, stamp=frame.stamp, source="vlm", extra=coarse)]

    stage = make([ScriptedSource("vlm", vlm), scene.source("aruco")])
    step(scene, stage)
    kept = read(bbk.DETECTIONS)
    assert [d.source for d in kept] == ["aruco"]
    assert read(bbk.TRACKS)["target"].detection.source == "aruco"
    assert read(bbk.PERCEPTION_STATS)["coarse_dropped"] == 1

    scene.hidden = True  # the fiducial is out of reach: the coarse source alone still finds the target
    step(scene, stage)
    tr = read(bbk.TRACKS)["target"]
    assert tr.misses == 0 and tr.detection.source == "vlm"
    assert abs(tr.pose_map[0, 3] - 2.2) < 1e-9


def test_policy_all_keeps_every_detection():
    scene = Scene(marker=marker_facing(2.0, 0.0, math.pi))

    def vlm(frame: Frame) -> list:
        return [detection_of(scene.marker, scene.robot, stamp=frame.stamp, extra={"precision": "coarse"})]

    stage = make([ScriptedSource("vlm", vlm), scene.source("aruco")], policy="all")
    step(scene, stage)
    assert len(read(bbk.DETECTIONS)) == 2
    assert read(bbk.TRACKS)["target"].detection.extra == {}  # precise ranks first


def test_a_stale_frame_is_dropped_and_counted():
    scene = Scene(marker=marker_facing(2.0, 0.0, math.pi))
    src = scene.source()
    stage = make([src])
    scene.clock = 5.0
    step(scene, stage)
    scene.clock = 4.0  # a late frame from the past
    perceived = step(scene, stage)
    assert perceived is not None
    assert perceived.dropped == "frames_stale" and "stale" in perceived.summary
    assert read(bbk.PERCEPTION_STATS)["frames_stale"] == 1
    assert src.calls == 1 and read(bbk.TRACKS)["target"].last_seen == 5.0


def test_garbage_images_are_dropped_and_counted_not_a_crash():
    scene = Scene(marker=marker_facing(2.0, 0.0, math.pi))
    src = scene.source()
    stage = make([src])
    w = bbk.writer("adapter")
    said = []
    for seq, image in enumerate(["not an image", None, np.zeros((0, 5, 3), np.uint8), np.zeros((4, 4, 7))], 1):
        bbk.set_(w, bbk.FRAME, Frame(image=image, stamp=float(seq)))  # type: ignore[arg-type]
        bbk.set_(w, bbk.FRAME_SEQ, seq)
        perceived = stage.update(board())
        assert perceived.dropped == "frames_dropped"
        said.append(perceived.summary)
    assert said[0] == "dropped frame 1: image is str, expected an H×W or H×W×3 ndarray"
    assert said[2] == "dropped frame 3: image has shape (0, 5, 3), expected H×W or H×W×3"
    assert read(bbk.PERCEPTION_STATS)["frames_dropped"] == 4 and src.calls == 0
    scene.seq = 10
    scene.clock = 10.0
    assert step(scene, stage).processed and read(bbk.TRACKS)["target"].visible


def test_unusable_detections_from_a_source_are_counted_and_skipped():
    scene = Scene(marker=marker_facing(2.0, 0.0, math.pi))

    def bad(frame: Frame) -> list:
        det = detection_of(scene.marker, scene.robot, stamp=frame.stamp)
        det.orientation = np.zeros(4)
        return [det, "junk"]

    stage = make([ScriptedSource("bad", bad)])
    assert step(scene, stage).processed
    assert read(bbk.PERCEPTION_STATS)["detections_invalid"] == 2
    assert read(bbk.TRACKS)["target"].misses == 1


def test_history_keeps_recent_map_positions_only():
    scene = Scene(marker=marker_facing(2.0, 0.0, math.pi))
    stage = make([scene.source()])
    for _ in range(45):  # 3 s at 15 Hz
        step(scene, stage)
    hist = read(bbk.TRACKS)["target"].history
    assert 28 <= len(hist) <= 31 and hist[-1][0] - hist[0][0] <= 2.0
    assert all(abs(x - 2.0) < 1e-9 for _, x, _ in hist)


def test_a_target_turning_on_the_spot_does_not_seem_to_walk():
    # a 0.4 m box standing at (2, 0) turns on the spot at 0.6 rad/s in front of the robot; its tag, on its face,
    # swings 0.2 m round its centre. Told how deep the body is, the stage keeps the centre, which stands still.
    def speed(body_depth_m: float) -> float:
        scene = Scene(robot=Pose2D(0.0, 0.0, 0.0))
        targets = {"target": TargetSpec(marker_id=7, body_depth_m=body_depth_m)}
        stage = PerceptionStage([scene.source()], targets, "hybrid")
        for i in range(16):  # 1 s at 15 Hz, the face from 25° one side of the robot to 25° the other
            facing = math.pi - 0.3 + 0.6 * i / 15
            scene.marker = marker_facing(2.0 + 0.2 * math.cos(facing), 0.2 * math.sin(facing), facing)
            step(scene, stage)
        track = read(bbk.TRACKS)["target"]
        if body_depth_m:
            assert all(math.hypot(x - 2.0, y) < 1e-6 for _, x, y in track.centres)
        v = fitted_velocity(track)
        assert v is not None
        return math.hypot(*v)

    assert speed(0.0) > 0.1  # the marker's swing, fitted as a walk
    assert speed(0.2) < 0.01


def test_without_extrinsics_the_camera_is_assumed_at_the_base_and_the_summary_says_so():
    scene = Scene(marker=marker_facing(2.0, 0.0, math.pi))
    stage = make([ScriptedSource("s", lambda f: [detection_of(scene.marker, scene.robot, stamp=f.stamp)])])
    w = bbk.writer("adapter")
    scene.sense()
    bbk.set_(w, bbk.CAMERA_EXTRINSICS, None)
    perceived = stage.update(board())
    assert "no camera extrinsics" in perceived.summary
    # the detection was made with the camera 15 cm ahead: placed 15 cm short without extrinsics
    assert abs(read(bbk.TRACKS)["target"].pose_map[0, 3] - (2.0 - EXTRINSICS[0, 3])) < 1e-9
