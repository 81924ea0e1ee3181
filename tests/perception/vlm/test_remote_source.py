"""The `vlm` source on a remote client (`gemini`, `openai`) against the loopback model servers: for each
thing the service does, what the source returned, what its persisted budget and circuit breaker did, and
what the tree saw (the perception stage's track of the target, which the tree reads).

Frames are the ray-cast RGB-D scenes of tests/helpers/vlm_scene.py; the fake model answers with the box's true
pixel. The budget's clock is a fake one moved by the test (time.time for the HTTP layer's own waits).
"""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

from mission.core import se3
from mission.core.config import TargetSpec
from mission.perception_plugins.pipeline import PerceptionStage, source_statuses
from mission.perception_plugins.vlm.source import VlmSource
from tests.helpers.vlm_scene import Box, Scene, box_front_face, camera_pose, render, yaw_towards
from tests.helpers.vlm_servers import FakeModelServer, Reply

KEY = "test-key-0c4d8e2f6a1b"
APIS = ("gemini", "openai")
BOX = Box((3.0, 0.3, 0.25), (0.3, 0.3, 0.5), (30, 30, 200), yaw=0.2)
CAM = camera_pose(0.0, 0.0, yaw_towards(0.0, 0.0, BOX.centre[0], BOX.centre[1]))
FRAME = render(Scene([BOX]), CAM)
T0 = 1_700_000_000.0


def true_point() -> tuple[float, float]:
    """Where the box's front face is in FRAME, as [y, x] in 0–1000: what a good model answers."""
    k = FRAME.intrinsics
    u, v = k.project(se3.apply(se3.invert(CAM), box_front_face(BOX)[:3, 3])[None, :])[0]
    return v / k.height * 1000.0, u / k.width * 1000.0


class Clock:
    def __init__(self) -> None:
        self.t = T0

    def __call__(self) -> float:
        return self.t


@pytest.fixture(params=APIS)
def api(request, monkeypatch) -> str:
    monkeypatch.setenv("GOOGLE_API_KEY", KEY)
    return request.param


@pytest.fixture
def server(api):
    y, x = true_point()
    with FakeModelServer(
        api,
        api_key=KEY if api == "gemini" else None,
        answerer=lambda image, prompt: json.dumps([{"point": [round(y), round(x)], "label": "red box"}]),
    ) as s:
        yield s
        assert s.problems == []


class World:
    """The source under test, the perception stage the runner would give it, and the clock."""

    def __init__(self, server: FakeModelServer, tmp_path, **params) -> None:
        remote = {
            "timeout_s": 1.0,
            "max_retries": 1,
            "backoff_s": 0.02,
            "max_backoff_s": 5.0,
            **params.pop("remote", {}),
        }
        raw = {
            "client": server.api,
            "state_file": str(tmp_path / "quota.json"),
            "publish_rate_limit_hz": 1.0,
            "requests_per_minute": 60,
            "daily_quota": 100,
            "remote": remote,
            **params,
        }
        if server.api == "gemini":
            raw["gemini"] = {"endpoint": server.url}
        else:
            raw["openai"] = {"base_url": server.url, "model": server.model}
        self.clock = Clock()
        self.source = VlmSource(raw, name="vlm", clock=self.clock)
        self.stage = PerceptionStage([self.source], {"target": TargetSpec(label="red box")})
        self.frames = 0

    def step(self, dt: float = 1.0) -> list:
        """One frame through the stage; the model call in flight is let finish; the clock moves on."""
        frame = dataclasses.replace(FRAME, stamp=float(self.frames))
        self.frames += 1
        perceived = self.stage.process(frame, self.frames, robot=None, extrinsics=None)
        assert self.source.wait_idle(timeout=30.0)
        self.clock.t += dt
        return perceived.detections

    @property
    def tree_sees_target(self) -> bool:
        return self.stage.tracks["target"].visible

    @property
    def status(self) -> dict:
        return self.source.status()

    def close(self) -> None:
        self.source.close()


@pytest.fixture
def world(server, tmp_path):
    w = World(server, tmp_path)
    yield w
    w.close()


def test_three_good_answers_latch_the_target_and_the_tree_sees_it(server, world):
    for _ in range(3):
        world.step()
    assert world.source.latch.latched and world.status["model_calls"] == 3
    dets = world.step()  # the latched pose, re-emitted
    assert world.tree_sees_target and len(dets) == 1 and dets[0].extra["client"] == server.api
    face = box_front_face(BOX)[:3, 3]
    assert np.linalg.norm(np.asarray(dets[0].extra["pose_anchor"][:3]) - face) < 0.05
    cost = world.status["cost"]
    assert cost["requests"] == len(server.received) == 3
    assert cost["input_tokens"] == server.totals.input_tokens and cost["output_tokens"] == server.totals.output_tokens
    assert world.status["calls_today"] == 3 and not world.status["breaker_open"]


def test_server_errors_after_every_retry_open_the_breaker_with_the_reason_and_stop_the_calls(server, world):
    server.script(*[Reply.error(503, "The model is overloaded. Please try again later.")] * 40)
    for _ in range(5):
        assert world.step() == []
    st = world.status
    assert st["breaker_open"] and st["state"] == "breaker_open"
    assert st["breaker_reason"].startswith("5 consecutive failed attempts, the last: model call failed: POST ")
    assert "HTTP 503" in st["breaker_reason"] and "(after 2 attempts)" in st["breaker_reason"]
    assert st["client_errors_server"] == 5 and len(server.received) == 10  # 5 calls × (1 + 1 retry)
    for _ in range(5):  # the breaker holds: no more requests, the tree sees nothing
        world.step()
    assert len(server.received) == 10 and not world.tree_sees_target
    assert st["cost"]["failures"] == {"server": 5} and st["calls_today"] == 10
    world.source.reset_latch()  # /mission/redetect: the model is asked again
    world.step()
    assert len(server.received) == 12 and world.status["failed_latch_attempts"] == 1


def test_a_rejected_request_opens_the_breaker_at_once(api, tmp_path, monkeypatch):
    monkeypatch.setenv("GOOGLE_API_KEY", "a-key-the-service-does-not-know")
    with FakeModelServer(api, api_key=KEY) as server:
        world = World(server, tmp_path)  # gemini sends a key the service does not know, openai none at all
        world.step()
        st = world.status
        assert st["breaker_open"] and len(server.received) == 1
        assert st["breaker_reason"].startswith("the service rejected the request: POST ")
        assert "HTTP 401" in st["breaker_reason"]
        world.step()
        assert len(server.received) == 1 and not world.tree_sees_target
        world.close()
        server.problems.clear()


def test_timeouts_count_towards_the_breaker(server, tmp_path):
    server.script(*[Reply.slow(3.0)] * 20)
    world = World(server, tmp_path, max_failed_latch_attempts=3, remote={"timeout_s": 0.2, "max_retries": 0})
    for _ in range(3):
        world.step()
    st = world.status
    assert st["breaker_open"] and "no answer within remote.timeout_s 0.2 s" in st["breaker_reason"]
    assert st["client_errors_timeout"] == 3 and not world.tree_sees_target
    world.close()


def test_a_dropped_connection_is_retried_and_the_call_still_answers(server, world):
    server.script(Reply.drop())
    world.step()
    assert world.status["answers"] == 1 and world.status["cost"]["retries"] == 1
    assert world.status["calls_today"] == 2 and world.status["failed_latch_attempts"] == 0


def test_answers_the_source_cannot_read_are_misses_not_failures(server, world):
    server.answerer = lambda image, prompt: "I am not able to point at things."
    for _ in range(6):
        world.step()
    st = world.status
    assert st["misses"] == 6 and not st["breaker_open"] and st.get("client_errors", 0) == 0
    assert st["cost"]["unread_answers"] == 6 and not world.tree_sees_target


def test_malformed_json_and_out_of_image_points_give_nothing_to_latch(server, world):
    server.script(Reply.answer('[{"point": [412, '), Reply.answer('[{"point": [-4000, 99999]}]'), Reply.answer("[]"))
    for _ in range(3):
        world.step()
    st = world.status
    assert st["misses"] == 3 and st.get("answers", 0) == 0 and not world.source.latch.latched
    assert not st["breaker_open"]


def test_a_long_retry_after_pauses_the_source_without_opening_the_breaker(server, world):
    server.script(Reply.error(429, "Resource has been exhausted (e.g. check quota).", retry_after="300"))
    world.step()
    for _ in range(10):  # 10 s of the source's clock: paused, no request sent
        world.step()
    st = world.status
    assert st["state"] == "rate_limited" and not st["breaker_open"] and len(server.received) == 1
    assert st["client_errors_rate_limited"] == 1 and "HTTP 429" in st["last_error"]
    world.clock.t += 300  # the pause is over
    world.step()
    assert len(server.received) == 2 and world.status["answers"] == 1


def test_the_per_minute_budget_holds_across_calls_and_retries(server, tmp_path):
    server.script(*[Reply.error(500)] * 20)
    world = World(server, tmp_path, requests_per_minute=3, remote={"max_retries": 4})
    for _ in range(20):  # 20 s of the source's clock
        world.step()
    assert len(server.received) == 3  # never more than 3 requests in 60 s, retries included
    assert world.status["requests_last_minute"] == 3 and world.status["state"] == "rate_limited"
    world.close()


def test_the_daily_quota_holds_across_restarts_and_retries(server, tmp_path):
    server.script(*[Reply.error(500)] * 20)
    first = World(server, tmp_path, daily_quota=4, remote={"max_retries": 2})
    first.step()  # 1 call: 3 requests
    first.close()
    second = World(server, tmp_path, daily_quota=4, remote={"max_retries": 2})  # a restart
    second.clock.t = first.clock.t + 60
    for _ in range(5):
        second.step()
    assert len(server.received) == 4 and second.status["state"] == "quota_exhausted"
    assert second.status["calls_today"] == 4
    second.close()


def test_the_status_the_heartbeat_and_report_carry_is_json_and_keyless(server, world):
    server.script(Reply.error(500, f"something echoed {KEY}"), Reply.error(500))
    world.step()
    statuses = source_statuses(world.stage.sources)
    text = json.dumps(statuses)
    assert set(statuses) == {"vlm"} and KEY not in text
    vlm = statuses["vlm"]
    assert {"state", "breaker_open", "breaker_reason", "last_error", "cost", "calls_today"} <= set(vlm)
