"""The two remote clients — `gemini` (generateContent) and `openai` (chat completions with an image) —
against a real HTTP server on 127.0.0.1 that speaks each API's documented format (tests/helpers/vlm_servers.py).

For each thing a remote service does — answer, answer badly, say 429 with Retry-After, fail with 5xx,
answer too slowly, drop the connection, reject the key — what the client returned, what it cost, what
the persisted budget recorded (before each request was sent), and what the breaker did.
"""

from __future__ import annotations

import itertools
import json
import logging
import time
from pathlib import Path

import numpy as np
import pytest

from mission.core.config import validate_model
from mission.core.errors import ConfigError
from mission.perception_plugins.vlm.gemini import gemini_client
from mission.perception_plugins.vlm.openai_chat import openai_client
from mission.perception_plugins.vlm.quota import QuotaBudget, QuotaStore
from mission.perception_plugins.vlm.remote import ModelCallError
from mission.perception_plugins.vlm.source import VlmParams
from tests.helpers.vlm_scene import Box, Scene, camera_pose, render, yaw_towards
from tests.helpers.vlm_servers import FakeModelServer, Received, Reply

KEY = "test-key-5f1c9e0a7b3d"  # made up; every test that sends it checks it stays in the request header
APIS = ("gemini", "openai")
RED = (30, 30, 200)
BOX = Box((3.0, 0.3, 0.25), (0.3, 0.3, 0.5), RED, yaw=0.2)
CAM = camera_pose(0.0, 0.0, yaw_towards(0.0, 0.0, BOX.centre[0], BOX.centre[1]))
FRAME = render(Scene([BOX]), CAM)
IMAGE = FRAME.image


@pytest.fixture(params=APIS)
def api(request, monkeypatch) -> str:
    monkeypatch.setenv("GOOGLE_API_KEY", KEY)
    monkeypatch.setenv("VLM_SERVER_KEY", KEY)
    return request.param


@pytest.fixture
def server(api):
    with FakeModelServer(api, api_key=KEY) as s:
        yield s
        assert s.problems == [], "the client sent a request the real API would refuse"


def params_for(server: FakeModelServer, tmp_path: Path, **remote) -> VlmParams:
    raw: dict = {
        "client": server.api,
        "state_file": str(tmp_path / "quota.json"),
        "requests_per_minute": 60,
        "daily_quota": 100,
        "remote": {"timeout_s": 2.0, "max_retries": 3, "backoff_s": 0.05, "max_backoff_s": 5.0, **remote},
    }
    if server.api == "gemini":
        raw["gemini"] = {"endpoint": server.url}
    else:
        raw["openai"] = {"base_url": server.url, "model": server.model, "api_key_env": "VLM_SERVER_KEY"}
    return validate_model(VlmParams, raw)


class Budget:
    """The source's budget as a client sees it, with the call's first request recorded as the source does."""

    def __init__(self, tmp_path: Path, *, daily: int = 100, per_minute: int = 60) -> None:
        self.path = tmp_path / "quota.json"
        self.store = QuotaStore(self.path, daily_quota=daily, min_interval_s=0.0, requests_per_minute=per_minute)
        self.budget = QuotaBudget(self.store, time.time)

    def on_disk(self) -> dict:
        return json.loads(self.path.read_text()) if self.path.exists() else {}


def client_for(server: FakeModelServer, tmp_path: Path, budget: Budget | None = None, **remote):
    params = params_for(server, tmp_path, **remote)
    budget = budget or Budget(tmp_path)
    factory = gemini_client if server.api == "gemini" else openai_client
    return factory(params, budget.budget), budget


def call(client, budget: Budget, label: str = "red box"):
    """One model call as the source makes it: the first request recorded, then the client's call."""
    budget.store.record_call(time.time())
    return client.locate(IMAGE, label)


def gaps(server: FakeModelServer) -> list[float]:
    t = [r.t for r in server.received]
    return [b - a for a, b in itertools.pairwise(t)]


# -- a normal answer ---------------------------------------------------------------------------------


def test_a_normal_answer_is_the_models_points_sent_in_the_apis_documented_format(server, tmp_path):
    server.script(Reply.points((480, 530), (120, 900)))
    client, budget = client_for(server, tmp_path)
    points = call(client, budget)
    assert [(p.y, p.x) for p in points] == [(480, 530), (120, 900)]
    assert all(p.confidence == 0.8 for p in points)  # the model stated none: remote.default_confidence
    (req,) = server.received
    assert req.image.shape == IMAGE.shape  # a real JPEG of the frame (smaller than max_image_side_px)
    assert np.mean(np.abs(req.image.astype(float) - IMAGE)) < 3.0
    assert "red box" in req.prompt and "[y, x]" in req.prompt and "0-1000" in req.prompt
    assert KEY not in req.path  # the key travels in a header only
    if server.api == "gemini":
        assert req.path == "/v1beta/models/gemini-robotics-er-2-preview:generateContent"
        assert req.headers["x-goog-api-key"] == KEY
        assert req.body["generationConfig"]["responseMimeType"] == "application/json"
        assert req.body["generationConfig"]["responseSchema"]["type"] == "ARRAY"
    else:
        assert req.body["model"] == server.model and req.headers["authorization"] == f"Bearer {KEY}"
    cost = client.usage.to_json()
    assert cost["requests"] == 1 and cost["retries"] == 0 and cost["answers"] == 1
    assert cost["input_tokens"] == server.totals.input_tokens and cost["output_tokens"] == server.totals.output_tokens
    assert cost["total_tokens"] == server.totals.input_tokens + server.totals.output_tokens
    client.close()


def test_a_large_image_is_sent_scaled_to_max_image_side_px(server, tmp_path):
    client, budget = client_for(server, tmp_path, max_image_side_px=160)
    budget.store.record_call(time.time())
    client.locate(np.ascontiguousarray(np.tile(IMAGE, (2, 2, 1))), "red box")  # 640×480
    assert server.received[0].image.shape == (120, 160, 3)
    client.close()


@pytest.mark.parametrize(
    ("text", "expected", "unread"),
    [
        (
            'Sure! The red box:\n```json\n[{"point": [412, 618], "label": "red box"}]\n```\nAnything else?',
            [(412, 618)],
            0,
        ),
        (
            '[{"point": [1030, -12], "label": "red box"}, {"point": [5000, 300], "label": "red box"}]',
            [(1000, 0)],
            0,
        ),  # a little past the edge: on the edge; far outside: not in the image
        ("[]", [], 0),
        ("I could not find a red box in this image.", [], 1),
        ('[{"point": [300, 400], "label": "red box"}, {"point": [310', [(300, 400)], 0),  # cut off at max tokens
        ('{"points": [{"point": ["250", "750"], "confidence": 0.9}]}', [(250, 750)], 0),
        ("[{'point': [600, 200], 'label': 'red box'}]", [(600, 200)], 0),  # Python's quotes
    ],
    ids=["fenced-with-prose", "out-of-range", "empty", "prose-only", "truncated", "wrapped-strings", "single-quotes"],
)
def test_answers_are_read_robustly(server, tmp_path, text, expected, unread):
    server.script(Reply.answer(text))
    client, budget = client_for(server, tmp_path)
    points = call(client, budget)
    assert [(p.y, p.x) for p in points] == expected
    assert client.usage.unread_answers == unread and client.usage.failures == {}
    client.close()


# -- manners: 429, 5xx, timeouts, dropped connections -------------------------------------------------


def test_429_with_retry_after_is_waited_out_and_each_request_is_recorded_before_it_is_sent(api, tmp_path):
    budget = Budget(tmp_path)
    on_disk_at_arrival: list[int] = []

    def snapshot(_req: Received) -> None:
        on_disk_at_arrival.append(budget.on_disk().get("calls_today", 0))

    with FakeModelServer(api, api_key=KEY, on_request=snapshot) as server:
        server.script(Reply.error(429, "Resource has been exhausted", retry_after="1"), Reply.points((500, 500)))
        client, _ = client_for(server, tmp_path, budget)
        points = call(client, budget)
        assert [(p.y, p.x) for p in points] == [(500, 500)]
        assert server.replies() == ["429", "answer"]
        assert gaps(server)[0] >= 1.0  # Retry-After: 1 (the backoff alone would be 0.05 s)
        assert on_disk_at_arrival == [1, 2]  # each request was on disk before it reached the server
        assert client.usage.retries == 1 and client.usage.requests == 2
        client.close()


def test_gemini_retry_info_in_the_error_body_is_honoured_without_a_header(monkeypatch, tmp_path):
    monkeypatch.setenv("GOOGLE_API_KEY", KEY)
    with FakeModelServer("gemini", api_key=KEY) as server:
        server.script(Reply.error(429, retry_delay_s=0.6), Reply.points((500, 500)))
        client, budget = client_for(server, tmp_path)
        assert call(client, budget)
        assert gaps(server)[0] >= 0.6
        client.close()


def test_5xx_is_retried_with_exponential_backoff(server, tmp_path):
    server.script(Reply.error(500), Reply.error(503), Reply.points((500, 500)))
    client, budget = client_for(server, tmp_path, backoff_s=0.2)
    assert call(client, budget)
    first, second = gaps(server)
    assert first >= 0.2 and second >= 0.4  # doubled (plus up to 25 % jitter)
    assert client.usage.retries == 2 and budget.on_disk()["calls_today"] == 3
    client.close()


def test_an_answer_slower_than_the_timeout_is_abandoned_and_retried(server, tmp_path):
    server.script(Reply.slow(5.0, "[]"), Reply.points((300, 300)))
    client, budget = client_for(server, tmp_path, timeout_s=0.3)
    t0 = time.monotonic()
    assert [(p.y, p.x) for p in call(client, budget)] == [(300, 300)]
    assert time.monotonic() - t0 < 4.0  # did not wait for the slow answer
    assert server.replies() == ["slow", "answer"] and client.usage.retries == 1
    client.close()


def test_a_dropped_connection_is_retried(server, tmp_path):
    server.script(Reply.drop(), Reply.points((300, 300)))
    client, budget = client_for(server, tmp_path)
    assert call(client, budget)
    assert server.replies() == ["drop", "answer"]
    client.close()


def test_retries_end_after_max_retries_with_an_error_naming_the_request(server, tmp_path):
    server.script(*[Reply.error(503, "The model is overloaded")] * 5)
    client, budget = client_for(server, tmp_path, max_retries=2)
    with pytest.raises(ModelCallError) as err:
        call(client, budget)
    assert err.value.kind == "server" and not err.value.permanent
    assert "HTTP 503" in str(err.value) and "The model is overloaded" in str(err.value)
    assert "(after 3 attempts)" in str(err.value) and f"POST {server.url}" in str(err.value)
    assert len(server.received) == 3 and client.usage.failures == {"server": 1}
    client.close()


def test_a_wrong_key_is_rejected_at_once_without_retrying(api, tmp_path):
    with FakeModelServer(api, api_key="another-key-entirely") as server:
        client, budget = client_for(server, tmp_path)
        with pytest.raises(ModelCallError) as err:
            call(client, budget)
        assert err.value.kind == "rejected" and err.value.permanent and err.value.status == 401
        assert len(server.received) == 1
        assert KEY not in str(err.value)
        server.problems.clear()  # the wrong key was the point
        client.close()


def test_an_answer_that_is_not_the_apis_json_is_a_bad_response_and_not_retried(server, tmp_path):
    server.script(Reply.raw(b"<html><body>502 Bad Gateway</body></html>"))
    client, budget = client_for(server, tmp_path)
    with pytest.raises(ModelCallError) as err:
        call(client, budget)
    assert err.value.kind == "bad_response" and len(server.received) == 1
    client.close()


def test_a_retry_after_longer_than_max_backoff_ends_the_call_and_pauses_the_persisted_budget(server, tmp_path):
    server.script(Reply.error(429, retry_after="120"))
    client, budget = client_for(server, tmp_path, max_backoff_s=5.0)
    t0 = time.time()
    with pytest.raises(ModelCallError) as err:
        call(client, budget)
    assert err.value.kind == "rate_limited" and err.value.throttled
    assert len(server.received) == 1
    assert budget.on_disk()["not_before"] >= t0 + 119
    restarted = QuotaStore(budget.path, daily_quota=100, min_interval_s=0.0)  # a restart keeps the pause
    assert restarted.refusal(time.time()) == "rate_limited"
    assert restarted.refusal(t0 + 121) is None
    client.close()


def test_no_retry_is_sent_beyond_the_daily_quota(server, tmp_path):
    server.script(*[Reply.error(500)] * 10)
    budget = Budget(tmp_path, daily=3)
    client, _ = client_for(server, tmp_path, budget, max_retries=8)
    with pytest.raises(ModelCallError) as err:
        call(client, budget)
    assert err.value.kind == "budget" and "daily quota is spent" in str(err.value)
    assert len(server.received) == 3 and budget.on_disk()["calls_today"] == 3
    client.close()


def test_a_retry_waits_for_the_per_minute_budget_or_ends_the_call(server, tmp_path):
    server.script(*[Reply.error(500)] * 10)
    budget = Budget(tmp_path, per_minute=2)
    client, _ = client_for(server, tmp_path, budget, max_retries=5, max_backoff_s=5.0)
    with pytest.raises(ModelCallError) as err:
        call(client, budget)
    assert err.value.kind == "budget" and "s away" in str(err.value)  # the window frees in ~60 s > 5 s
    assert len(server.received) == 2
    client.close()


def test_gemini_saying_the_days_quota_is_spent_spends_ours_too(monkeypatch, tmp_path):
    monkeypatch.setenv("GOOGLE_API_KEY", KEY)
    with FakeModelServer("gemini", api_key=KEY) as server:
        server.script(Reply.error(429, "Quota exceeded for quota metric", per_day=True, retry_delay_s=30))
        budget = Budget(tmp_path, daily=20)
        client, _ = client_for(server, tmp_path, budget)
        with pytest.raises(ModelCallError) as err:
            call(client, budget)
        assert err.value.kind == "quota" and len(server.received) == 1
        assert budget.store.refusal(time.time()) == "quota_exhausted"
        assert budget.on_disk()["calls_today"] == 20
        client.close()


# -- configuration -----------------------------------------------------------------------------------


def test_gemini_without_its_key_in_the_environment_is_a_config_error_naming_the_variable(monkeypatch, tmp_path):
    from mission.perception_plugins.vlm.source import VlmSource

    monkeypatch.delenv("GOOGLE_API_KEY", raising=False)
    with pytest.raises(ConfigError) as err:
        VlmSource({"client": "gemini", "state_file": str(tmp_path / "q.json")})
    assert err.value.key == "gemini.api_key_env" and "GOOGLE_API_KEY is not set" in str(err.value)


def test_openai_needs_the_served_model_named(tmp_path):
    from mission.perception_plugins.vlm.source import VlmSource

    with pytest.raises(ConfigError) as err:
        VlmSource({"client": "openai", "state_file": str(tmp_path / "q.json")})
    assert err.value.key == "openai.model"


@pytest.mark.parametrize("section", ["gemini", "openai"])
def test_a_key_written_into_the_config_is_refused_and_not_echoed(tmp_path, section):
    from mission.perception_plugins.vlm.source import VlmSource

    with pytest.raises(ConfigError) as err:
        VlmSource({"client": section, "state_file": str(tmp_path / "q.json"), section: {"api_key": KEY}})
    assert "never read from config" in str(err.value) and KEY not in str(err.value)
    assert err.value.key == section


def test_the_key_appears_in_no_log_record_or_error_even_at_debug_level(server, tmp_path, caplog):
    server.script(Reply.error(500, f"echoing {KEY} back"), Reply.drop(), Reply.error(401, f"bad key {KEY}"))
    client, budget = client_for(server, tmp_path)
    with caplog.at_level(logging.DEBUG), pytest.raises(ModelCallError) as err:
        call(client, budget)
    text = "\n".join(r.getMessage() for r in caplog.records) + str(err.value) + json.dumps(client.usage.to_json())
    assert KEY not in text and "***" in str(err.value)  # the server's echo of it is redacted
    assert any(r.name.startswith("httpx") for r in caplog.records)  # the HTTP library did log the requests
    client.close()
