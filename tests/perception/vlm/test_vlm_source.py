"""The `vlm` source, with its default client (the stub): off-tick model calls, consensus and latch in the
map frame, republishing as the robot moves, the circuit breaker, a rate limit and quota that survive
restarts, and how the client is chosen.

Scenes are ray-cast RGB-D frames (tests/helpers/vlm_scene.py) with exact ground truth; the rate-limit clock is
a fake one advanced by the test, so nothing sleeps.
"""

from __future__ import annotations

import dataclasses
import json
import math

import numpy as np
import pytest

from mission.core import se3
from mission.core.config import SourceConfig
from mission.core.errors import ConfigError
from mission.core.types import Frame
from mission.perception_plugins import registry
from mission.perception_plugins.vlm.source import VlmSource
from tests.helpers.vlm_scene import Box, Scene, box_front_face, camera_pose, render, yaw_towards

RED = (30, 30, 200)
BOX = Box((3.0, 0.3, 0.25), (0.3, 0.3, 0.5), RED, yaw=0.2)
SCENE = Scene([BOX])
T0 = 1_700_000_000.0


class FakeClock:
    """The wall clock of the rate limit and quota, moved by the test."""

    def __init__(self, t: float = T0) -> None:
        self.t = t

    def __call__(self) -> float:
        return self.t


def make(tmp_path, clock: FakeClock, **params) -> VlmSource:
    base = {
        "state_file": str(tmp_path / "quota.json"),
        "latency_s": 0.0,
        "miss_rate": 0.0,
        "pixel_noise": 1.0,
        "publish_rate_limit_hz": 1.0,
        "daily_quota": 100,
    }
    return VlmSource({**base, **params}, name="vlm", clock=clock)


def step(src: VlmSource, frame: Frame, clock: FakeClock, dt: float = 1.0) -> list:
    """One tick: process the frame, let the model call in flight finish, move the clock on."""
    out = src.process(frame)
    assert src.wait_idle(timeout=10.0)
    clock.t += dt
    return out


_RENDERS: dict[tuple, Frame] = {}


def view(
    x: float, y: float = 0.0, stamp: float = 0.0, scene: Scene = SCENE, anchor: bool = True
) -> tuple[Frame, np.ndarray]:
    """The robot at (x, y) looking at the box; renders are cached per viewpoint (a new Frame each call)."""
    cam = camera_pose(x, y, yaw_towards(x, y, BOX.centre[0], BOX.centre[1]))
    key = (x, y, repr(scene), anchor)
    if key not in _RENDERS:
        _RENDERS[key] = render(scene, cam, anchor=anchor)
    return dataclasses.replace(_RENDERS[key], stamp=stamp), cam


def latch(src: VlmSource, clock: FakeClock, max_frames: int = 10) -> list:
    """Feed views from the start pose until the source latches; the detections of the latching frame."""
    for i in range(max_frames):
        frame, _ = view(0.0, stamp=i * 0.1)
        out = step(src, frame, clock)
        if src.latch.latched:
            return out or src.process(view(0.0, stamp=i * 0.1 + 0.05)[0])
    raise AssertionError(f"no latch after {max_frames} frames: {src.status()}")


@pytest.fixture
def clock() -> FakeClock:
    return FakeClock()


# -- the latch ---------------------------------------------------------------------------------------


def test_three_agreeing_answers_latch_the_target_in_the_map_frame(tmp_path, clock):
    src = make(tmp_path, clock)
    dets = latch(src, clock)
    assert src.model_calls == 3
    assert len(dets) == 1
    d = dets[0]
    face = box_front_face(BOX)
    pose_map = np.asarray(d.extra["pose_anchor"])
    assert np.linalg.norm(pose_map[:3] - face[:3, 3]) < 0.06  # coarse: the blob centre, not the face centre
    assert d.label == "red box" and d.marker_id is None and d.corners is None
    assert d.extra["precision"] == "coarse" and d.extra["latched"] is True and d.extra["model_calls"] == 3
    assert d.extra["anchor_frame"] == "map"
    json.dumps(d.to_json())  # serialisable for `mission detect --json` and logs
    src.close()


def test_the_latched_target_is_republished_as_the_robot_moves_with_no_more_model_calls(tmp_path, clock):
    src = make(tmp_path, clock)
    latched = np.asarray(latch(src, clock)[0].extra["pose_anchor"])
    face = box_front_face(BOX)
    emitted = 0
    for k in range(1, 9):  # drive towards and to the side of the box
        frame, cam = view(0.2 * k, 0.05 * k, stamp=10.0 + k / 30)
        dets = step(src, frame, clock)
        assert len(dets) == 1
        d = dets[0]
        t_map = cam @ se3.from_pos_quat(d.position, d.orientation)
        assert np.allclose(t_map[:3, 3], latched[:3], atol=1e-4)  # the same map pose from every viewpoint
        truth_cam = se3.apply(se3.invert(cam), face[:3, 3])
        assert np.linalg.norm(d.position - truth_cam) < 0.06  # and where the face really is, in this camera
        assert d.stamp == frame.stamp and d.extra["pixel"] is not None
        emitted += 1
    assert emitted == 8
    assert src.model_calls == 3
    src.close()


def test_republishing_is_paced_by_republish_rate_hz(tmp_path, clock):
    src = make(tmp_path, clock, republish_rate_hz=30.0)
    latch(src, clock)
    counts = [len(src.process(view(0.0, stamp=20.0 + i / 120)[0])) for i in range(24)]  # 120 Hz frames, 0.2 s
    assert sum(counts) == 6  # 30 Hz
    src.close()


def test_answers_that_disagree_restart_the_consensus(tmp_path, clock):
    src = make(tmp_path, clock)
    moved = Scene([Box((3.0, -0.5, 0.25), BOX.size, RED, yaw=0.2)])
    step(src, view(0.0, scene=SCENE)[0], clock)  # one answer at the first place…
    for i in range(3):  # …then the box is elsewhere: three new answers agree there
        step(src, view(0.0, stamp=1 + i, scene=moved)[0], clock)
    assert src.latch.latched and src.model_calls == 4
    assert src.latch.T_anchor_target[1, 3] < -0.3
    src.close()


def test_a_tighter_tolerance_and_more_answers_are_honoured(tmp_path, clock):
    src = make(tmp_path, clock, min_consecutive_detections=5, latch_position_tolerance_m=0.05)
    latch(src, clock)
    assert src.model_calls == 5 and src.latch.spread_m() <= 0.05
    src.close()


def test_a_redetect_request_resets_the_latch_and_the_model_is_asked_again(tmp_path, clock):
    src = make(tmp_path, clock)
    latch(src, clock)
    src.reset_latch()
    assert not src.latch.latched
    assert src.process(view(0.0, stamp=30.0)[0]) == []  # nothing until a new consensus
    assert src.model_calls == 4
    src.close()


# -- the circuit breaker ----------------------------------------------------------------------------


def test_no_map_pose_for_five_attempts_trips_the_breaker_before_any_model_call(tmp_path, clock):
    src = make(tmp_path, clock)
    for i in range(5):
        step(src, view(0.0, stamp=i, anchor=False)[0], clock)
    st = src.status()
    assert st["breaker_open"] and st["state"] == "breaker_open"
    assert src.model_calls == 0  # the quota is protected
    for i in range(5):  # even once the map pose is back, no calls until a redetect
        step(src, view(0.0, stamp=10 + i)[0], clock)
    assert src.model_calls == 0
    src.reset_latch()
    step(src, view(0.0, stamp=20)[0], clock)
    assert src.model_calls == 1
    src.close()


def test_failed_attempts_are_paced_by_the_rate_limit_and_must_be_consecutive(tmp_path, clock):
    src = make(tmp_path, clock, max_failed_latch_attempts=3)
    frame = view(0.0, anchor=False)[0]
    for _ in range(10):  # many frames inside one rate-limit interval are one attempt
        step(src, frame, clock, dt=0.05)
    assert src.latch.failed_attempts == 1
    clock.t += 1.0
    step(src, frame, clock)  # attempt 2
    step(src, view(0.0)[0], clock)  # the map pose is back: a call, and the count starts over
    assert src.latch.failed_attempts == 0 and src.model_calls == 1
    step(src, frame, clock)
    step(src, frame, clock)
    assert not src.latch.breaker_open
    step(src, frame, clock)
    assert src.latch.breaker_open
    src.close()


def test_a_camera_pose_in_another_anchor_frame_counts_as_unreachable(tmp_path, clock):
    src = make(tmp_path, clock, map_frame="odom", max_failed_latch_attempts=2)
    step(src, view(0.0)[0], clock)  # frames carry a "map" pose, the source wants "odom"
    step(src, view(0.0)[0], clock)
    assert src.latch.breaker_open and src.model_calls == 0
    src.close()


# -- the budget: rate limit and daily quota, across restarts ---------------------------------------


def test_model_calls_respect_publish_rate_limit_hz(tmp_path, clock):
    src = make(tmp_path, clock, publish_rate_limit_hz=0.025)  # one call per 40 s
    frame = view(0.0)[0]
    step(src, frame, clock, dt=39.0)
    step(src, frame, clock, dt=1.0)
    assert src.model_calls == 1 and src.status()["state"] == "rate_limited"
    step(src, frame, clock)
    assert src.model_calls == 2
    src.close()


def test_the_daily_quota_stops_model_calls(tmp_path, clock):
    src = make(tmp_path, clock, daily_quota=2, min_consecutive_detections=3)
    for i in range(6):
        step(src, view(0.0, stamp=i)[0], clock)
    assert src.model_calls == 2 and not src.latch.latched
    assert src.status()["state"] == "quota_exhausted"
    src.close()


def test_a_restarted_source_keeps_the_quota_and_rate_limit(tmp_path, clock):
    first = make(tmp_path, clock, daily_quota=3, publish_rate_limit_hz=0.1)
    step(first, view(0.0)[0], clock, dt=2.0)
    assert first.model_calls == 1
    first.close()  # a crash loop restarts the node two seconds later…
    second = make(tmp_path, clock, daily_quota=3, publish_rate_limit_hz=0.1)
    step(second, view(0.0)[0], clock, dt=8.0)
    assert second.model_calls == 0 and second.status()["state"] == "rate_limited"
    step(second, view(0.0)[0], clock, dt=10.0)
    step(second, view(0.0)[0], clock, dt=10.0)
    assert second.model_calls == 2
    second.close()
    third = make(tmp_path, clock, daily_quota=3, publish_rate_limit_hz=0.1)
    for _ in range(3):
        step(third, view(0.0)[0], clock, dt=10.0)
    assert third.model_calls == 0 and third.status()["state"] == "quota_exhausted"
    assert third.status()["calls_today"] == 3
    clock.t += 86400.0  # the next UTC day
    step(third, view(0.0)[0], clock)
    assert third.model_calls == 1
    third.close()


def test_with_the_frame_clock_budget_and_latency_run_on_frame_stamps_and_nothing_is_persisted(tmp_path):
    src = VlmSource(
        {
            "state_file": str(tmp_path / "q.json"),
            "clock": "frame",
            "latency_s": 0.5,
            "publish_rate_limit_hz": 1.0,
            "miss_rate": 0.0,
            "pixel_noise": 0.0,
        },
        name="vlm",
    )
    frame = view(0.0)[0]
    calls, answers = [], []
    for i in range(31):  # 3 s of 10 Hz frames
        src.process(dataclasses.replace(frame, stamp=i / 10))
        assert src.wait_idle(timeout=10.0)  # the worker is done, but the answer is due at stamp + 0.5 s
        calls.append(src.model_calls)
        answers.append(src.status().get("answers", 0))
    assert calls[0] == 1 and calls[9] == 1 and calls[10] == 2 and calls[20] == 3  # one call per second of stamps
    assert answers[4] == 0 and answers[5] == 1  # answered 0.5 s (of stamps) after the call
    assert src.latch.latched
    assert not (tmp_path / "q.json").exists()
    src.close()


# -- the model call is off the tick ----------------------------------------------------------------


def test_process_returns_at_once_while_the_model_is_thinking(tmp_path, clock):
    src = make(tmp_path, clock, latency_s=60.0)
    assert src.process(view(0.0)[0]) == []
    st = src.status()
    assert st["in_flight"] and st["state"] == "waiting_for_model" and st["model_calls"] == 1
    assert src.process(view(0.0, stamp=0.1)[0]) == []  # still thinking: no second call
    assert src.model_calls == 1
    src.close()  # interrupts the simulated latency
    assert src.wait_idle(timeout=10.0)


def test_missed_answers_cost_calls_but_do_not_latch(tmp_path, clock):
    src = make(tmp_path, clock, miss_rate=1.0)
    for i in range(4):
        step(src, view(0.0, stamp=i)[0], clock)
    assert src.model_calls == 4 and src.status()["misses"] == 4 and not src.latch.latched
    src.close()


def test_answers_below_confidence_threshold_are_ignored(tmp_path, clock):
    src = make(tmp_path, clock, confidence_threshold=0.99)
    for i in range(3):
        step(src, view(0.0, stamp=i)[0], clock)
    assert src.status()["misses"] == 3 and not src.latch.latched
    src.close()


def test_frames_without_depth_do_not_spend_model_calls(tmp_path, clock):
    src = make(tmp_path, clock)
    frame = view(0.0)[0]
    frame.depth = None
    step(src, frame, clock)
    assert src.model_calls == 0 and src.status()["state"] == "no_depth"
    src.close()


# -- keeping a latched pose honest -----------------------------------------------------------------


def test_a_latched_target_behind_the_camera_is_not_reported(tmp_path, clock):
    src = make(tmp_path, clock)
    latch(src, clock)
    away = render(SCENE, camera_pose(0.0, 0.0, math.pi), stamp=40.0)
    assert step(src, away, clock) == [] and src.latch.latched
    assert src.status()["latched_out_of_view"] == 1
    src.close()


def test_an_occluded_latched_target_is_not_reported_but_stays_latched(tmp_path, clock):
    src = make(tmp_path, clock)
    latch(src, clock)
    occluded = Scene([BOX, Box((1.5, 0.15, 0.4), (0.1, 0.8, 0.8), (120, 120, 120))])
    for i in range(20):
        assert step(src, view(0.0, stamp=50 + i, scene=occluded)[0], clock) == []
    assert src.latch.latched and src.model_calls == 3
    assert step(src, view(0.0, stamp=80)[0], clock)  # back in sight
    src.close()


def test_a_latch_whose_target_has_gone_is_dropped_and_the_model_asked_again(tmp_path, clock):
    src = make(tmp_path, clock, stale_after_frames=5, miss_rate=0.0)
    latch(src, clock)
    empty = Scene([])
    for i in range(4):
        assert step(src, view(0.0, stamp=60 + i, scene=empty)[0], clock) == []
    assert src.latch.latched  # four frames of "nothing there" are not yet enough
    step(src, view(0.0, stamp=65, scene=empty)[0], clock)
    assert not src.latch.latched and src.status()["unlatches"] == 1
    assert src.model_calls == 4 and src.status()["misses"] == 1  # asked again at once: nothing there
    src.close()


def test_max_latch_age_expires_a_latch(tmp_path, clock):
    src = make(tmp_path, clock, max_latch_age_s=5.0)
    latch(src, clock)
    assert src.process(view(0.0, stamp=100.0)[0]) == [] and not src.latch.latched
    src.close()


def test_without_latching_each_answer_is_emitted_once_for_a_moving_target(tmp_path, clock):
    src = make(tmp_path, clock, latch_in_map=False)
    out = [step(src, view(0.0, stamp=i, anchor=False)[0], clock) for i in range(4)]
    # the answer to frame i is ready at frame i + 1 and emitted once, in that frame's camera
    assert [len(o) for o in out] == [0, 1, 1, 1]
    d = out[1][0]
    assert d.extra["latched"] is False and d.extra["precision"] == "coarse"
    assert src.model_calls == 4 and not src.latch.breaker_open
    src.close()


# -- params ------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("params", "key"),
    [
        ({"publish_rate_limit_hz": 0}, "publish_rate_limit_hz"),
        ({"daily_quota": -1}, "daily_quota"),
        ({"miss_rate": 1.5}, "miss_rate"),
        ({"min_consecutive_detections": 0}, "min_consecutive_detections"),
        ({"latch_position_tolerance_m": "near"}, "latch_position_tolerance_m"),
        ({"max_failed_latch_attempts": 0}, "max_failed_latch_attempts"),
        ({"republish_rate_hz": -30}, "republish_rate_hz"),
        ({"target_lable": "red box"}, "target_lable"),
        ({"label": "trash bag"}, "label"),
        ({"client": "chatgpt"}, "client"),
        ({"client": "no_such_module:Client"}, "client"),
    ],
)
def test_a_bad_param_is_a_config_error_naming_the_key(tmp_path, params, key):
    with pytest.raises(ConfigError) as err:
        VlmSource({"state_file": str(tmp_path / "q.json"), **params})
    assert err.value.key == key


def test_the_registry_builds_the_source_and_names_the_config_key(tmp_path):
    src = registry.create(SourceConfig(plugin="vlm", params={"state_file": str(tmp_path / "q.json")}))
    assert isinstance(src, VlmSource) and src.name == "vlm" and src.params.client == "stub"
    assert src.params.publish_rate_limit_hz == 0.025 and src.params.daily_quota == 20
    assert src.params.min_consecutive_detections == 3 and src.params.latch_position_tolerance_m == 0.10
    assert src.params.republish_rate_hz == 30.0 and src.params.max_failed_latch_attempts == 5
    src.close()
    with pytest.raises(ConfigError, match=r"perception\.sources\.params\.daily_quota"):
        registry.create(SourceConfig(plugin="vlm", params={"daily_quota": "lots"}))


def test_configs_that_name_the_old_plugin_vlm_stub_get_the_same_source_with_the_stub_client(tmp_path):
    assert registry.load_class("vlm_stub") is registry.load_class("vlm") is VlmSource
    src = registry.create(SourceConfig(plugin="vlm_stub", params={"state_file": str(tmp_path / "q.json")}))
    assert src.name == "vlm_stub" and src.params.client == "stub"
    src.close()


def test_every_shipped_client_name_resolves_to_a_factory():
    from mission.core import plugins

    shipped = plugins.installed(plugins.VLM_CLIENTS)
    assert {"stub", "gemini", "openai"} <= set(shipped)
    for name in ("stub", "gemini", "openai"):
        assert callable(plugins.load(plugins.VLM_CLIENTS, name)), name


def test_a_custom_client_class_can_replace_the_stub(tmp_path, clock):
    src = make(
        tmp_path,
        clock,
        client="mission.perception_plugins.vlm.stub:ColourShapeClient",
        client_params={"pixel_noise": 0.0},
    )
    latch(src, clock)
    assert src.model_calls == 3
    src.close()
