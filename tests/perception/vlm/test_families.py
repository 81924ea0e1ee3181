"""Model families: each asked in its own trained form and read in its own convention, through the real
`gemini` / `openai` clients against the loopback servers replaying hand-written golden answers
(golden/*.txt, from each family's published format). Every golden answer must put the red box at its
true pixel; Qwen2.5-VL's answers, in pixels of the image its processor resized, must map back for
several image sizes.
"""

from __future__ import annotations

import json
import logging
import time
from pathlib import Path

import numpy as np
import pytest

from mission.core import se3
from mission.core.config import validate_model
from mission.core.errors import ConfigError
from mission.perception_plugins.vlm.families import detect_family, smart_resize
from mission.perception_plugins.vlm.gemini import gemini_client
from mission.perception_plugins.vlm.openai_chat import openai_client
from mission.perception_plugins.vlm.quota import QuotaBudget, QuotaStore
from mission.perception_plugins.vlm.source import VlmParams
from tests.helpers.vlm_scene import INTR, Box, Scene, box_front_face, camera_pose, render, yaw_towards
from tests.helpers.vlm_servers import FakeModelServer, Reply

GOLDEN = Path(__file__).parent / "golden"
KEY = "test-key-7a2e4c9b1d3f"
BOX = Box((3.0, 0.3, 0.25), (0.3, 0.3, 0.5), (30, 30, 200), yaw=0.2)
CAM = camera_pose(0.0, 0.0, yaw_towards(0.0, 0.0, BOX.centre[0], BOX.centre[1]))
FRAME = render(Scene([BOX]), CAM)
MODELS = {  # a served name of each family, as its publisher names it
    "gemini-er": "gemini-robotics-er-2-preview",
    "qwen2.5-vl": "Qwen/Qwen2.5-VL-7B-Instruct",
    "qwen3-vl": "Qwen/Qwen3-VL-8B-Instruct",
    "molmo": "allenai/Molmo-7B-D-0924",
    "molmo2": "allenai/Molmo2-8B",
}


def true_pixel(frame=FRAME) -> tuple[float, float]:
    k = frame.intrinsics
    u, v = k.project(se3.apply(se3.invert(CAM), box_front_face(BOX)[:3, 3])[None, :])[0]
    return float(u), float(v)


def golden(family: str) -> list[str]:
    return [a.strip("\n") for a in (GOLDEN / f"{family}.txt").read_text().split("\n---\n")]


def client_of(server: FakeModelServer, tmp_path: Path, monkeypatch, **section):
    raw: dict = {"client": server.api, "state_file": str(tmp_path / "q.json"), "remote": {"max_retries": 0}}
    if server.api == "gemini":
        monkeypatch.setenv("GOOGLE_API_KEY", KEY)
        raw["gemini"] = {"endpoint": server.url, **section}
    else:
        raw["openai"] = {"base_url": server.url, "model": server.model, **section}
    params = validate_model(VlmParams, raw)
    store = QuotaStore(tmp_path / "q.json", daily_quota=100, min_interval_s=0.0, requests_per_minute=60)
    factory = gemini_client if server.api == "gemini" else openai_client
    return factory(params, QuotaBudget(store, time.time))


@pytest.mark.parametrize(
    ("name", "family"),
    [
        ("gemini-robotics-er-2-preview", "gemini-er"),
        ("gemini-2.5-flash", "gemini-er"),  # Gemini's own models point the same way
        ("Qwen/Qwen2.5-VL-7B-Instruct", "qwen2.5-vl"),
        ("qwen2.5vl:7b", "qwen2.5-vl"),  # Ollama's tag
        ("Qwen/Qwen2_5_VL-3B", "qwen2.5-vl"),
        ("Qwen/Qwen3-VL-8B-Instruct", "qwen3-vl"),
        ("qwen3-vl:8b", "qwen3-vl"),
        ("allenai/Molmo-7B-D-0924", "molmo"),
        ("allenai/MolmoE-1B-0924", "molmo"),
        ("allenai/Molmo2-8B", "molmo2"),
        ("llava-1.6", None),
        (None, None),
    ],
)
def test_the_family_is_taken_from_the_model_name_when_the_name_says_it(name, family):
    assert detect_family(name) == family


@pytest.mark.parametrize(
    ("hw", "resized"),  # worked by hand from the rule: round each side to 28s, then into the pixel budget
    [((240, 320), (252, 308)), ((480, 640), (476, 644)), ((576, 1024), (588, 1036)), ((28, 28), (56, 56))],
)
def test_smart_resize_follows_the_qwen2_5_vl_processor(hw, resized):
    assert smart_resize(*hw) == resized


def test_smart_resize_scales_into_the_pixel_budget():
    h, w = smart_resize(2000, 3000, max_pixels=1280 * 28 * 28)
    assert h % 28 == 0 and w % 28 == 0 and h * w <= 1280 * 28 * 28 and abs(w / h - 1.5) < 0.05


@pytest.mark.parametrize("family", list(MODELS))
def test_each_familys_golden_answers_put_the_box_at_its_true_pixel(family, tmp_path, monkeypatch, caplog):
    api = "gemini" if family == "gemini-er" else "openai"
    answers = golden(family)
    caplog.set_level(logging.INFO, logger="mission.perception_plugins.vlm.families")
    with FakeModelServer(api, api_key=KEY if api == "gemini" else None, model=MODELS[family]) as server:
        server.script(*[Reply.answer(a) for a in answers])
        client = client_of(server, tmp_path, monkeypatch)
        assert client.family == family
        assert f"family {family}, from its name" in caplog.text
        u0, v0 = true_pixel()
        for answer in answers:
            points = client.locate(FRAME.image, "red box")
            assert points, answer
            u, v = points[0].to_pixel(INTR.width, INTR.height)
            assert abs(u - u0) < 3.0 and abs(v - v0) < 3.0, (answer, (u, v), (u0, v0))
        prompts = {r.prompt for r in server.received}
        client.close()
        assert server.problems == []
    (prompt,) = prompts
    assert "red box" in prompt
    if family.startswith("qwen"):
        assert "bbox_2d" in prompt
    elif family.startswith("molmo"):
        assert prompt == "Point to the red box."
    else:
        assert "[y, x]" in prompt and "0-1000" in prompt


@pytest.mark.parametrize(
    ("family", "text", "yx"),
    [
        ("molmo2", '<points coords="1 1 100 200 2 300 400">cups</points>', [(200, 100), (400, 300)]),
        ("molmo2", '<points coords="1: 1 100 200; 2: 1 300 400"/>', [(200, 100), (400, 300)]),
        ("molmo", '<points x1="10.0" y1="20.5" x2="30" y2="40" alt="cups">cups</points>', [(205, 100), (400, 300)]),
        ("qwen3-vl", '[{"point_2d": [100, 200]}, {"point_2d": [300, 400], "label": "b"}]', [(200, 100), (400, 300)]),
        ("qwen3-vl", '```json\n[{"bbox_2d": [100, 200, 300, 400], "label": "a"}, {"bbox_2d": [5', [(300, 200)]),
        ("gemini-er", '{"box_2d": [200, 100, 400, 300], "label": "a"}', [(300, 200)]),
    ],
)
def test_each_reader_takes_every_point_in_order_from_its_own_form(family, text, yx):
    from mission.perception_plugins.vlm.families import AnswerReader

    read = AnswerReader(family, 0.8)(text)
    assert [(p.y, p.x) for p in read.points] == yx and read.found_json


def test_a_box_answer_keeps_its_box_for_the_depth_patch(tmp_path, monkeypatch):
    with FakeModelServer("openai", model=MODELS["qwen3-vl"]) as server:
        server.script(Reply.answer('[{"bbox_2d": [466, 429, 544, 608], "label": "red box"}]'))
        client = client_of(server, tmp_path, monkeypatch)
        (p,) = client.locate(FRAME.image, "red box")
        client.close()
    assert p.box == (429.0, 466.0, 608.0, 544.0)  # ymin, xmin, ymax, xmax in 0–1000
    assert (p.y, p.x) == (518.5, 505.0)


@pytest.mark.parametrize(
    ("size", "resized", "sent"),  # frame (w, h), the processor's (w, h) worked by hand, what is sent (w, h)
    [
        ((320, 240), (308, 252), (320, 240)),
        ((640, 480), (644, 476), (640, 480)),
        ((1280, 720), (1036, 588), (1024, 576)),
    ],
)
def test_a_qwen2_5_vl_answer_in_resized_pixels_maps_back_for_each_image_size(
    size, resized, sent, tmp_path, monkeypatch
):
    w, h = size
    scale = w / 320
    intr = INTR.__class__(fx=250.0 * scale, fy=250.0 * scale, cx=w / 2, cy=h / 2, width=w, height=h)
    frame = render(Scene([BOX]), CAM, intr=intr)
    k = frame.intrinsics
    u0, v0 = k.project(se3.apply(se3.invert(CAM), box_front_face(BOX)[:3, 3])[None, :])[0]
    rw, rh = resized
    x, y = round(u0 / w * rw), round(v0 / h * rh)  # what the model, seeing the resized image, answers
    text = "```json\n" + json.dumps([{"point_2d": [x, y], "label": "red box"}]) + "\n```"
    with FakeModelServer("openai", model=MODELS["qwen2.5-vl"]) as server:
        server.script(Reply.answer(text))
        client = client_of(server, tmp_path, monkeypatch)
        (p,) = client.locate(frame.image, "red box")
        client.close()
        assert server.received[0].image.shape[:2] == (sent[1], sent[0])
    u, v = p.to_pixel(w, h)
    assert abs(u - u0) <= 0.6 * w / rw + 0.01 and abs(v - v0) <= 0.6 * h / rh + 0.01


def test_the_configured_family_wins_over_the_name(tmp_path, monkeypatch):
    with FakeModelServer("openai", model="my-finetune") as server:
        server.script(Reply.answer('<points coords="1 1 504 518">red box</points>'))
        client = client_of(server, tmp_path, monkeypatch, family="molmo2")
        (p,) = client.locate(FRAME.image, "red box")
        client.close()
    assert client.family == "molmo2" and (p.y, p.x) == (518.0, 504.0)


def test_a_model_whose_name_says_nothing_is_read_as_generic_and_the_log_says_to_set_family(
    tmp_path, monkeypatch, caplog
):
    with FakeModelServer("openai", model="my-finetune") as server:
        client = client_of(server, tmp_path, monkeypatch)
        client.close()
    assert client.family == "generic" and "set openai.family" in caplog.text


def test_gemini_robotics_er_2_is_the_default_and_thinking_settings_are_passed_through(tmp_path, monkeypatch):
    assert VlmParams().gemini.model == "gemini-robotics-er-2-preview"
    with FakeModelServer("gemini", api_key=KEY) as server:
        client = client_of(server, tmp_path, monkeypatch, thinking_budget=0, thinking_level="low")
        client.locate(FRAME.image, "red box")
        client.close()
        (req,) = server.received
    assert req.path == "/v1beta/models/gemini-robotics-er-2-preview:generateContent"
    assert req.body["generationConfig"]["thinkingConfig"] == {"thinkingBudget": 0, "thinkingLevel": "low"}


@pytest.mark.parametrize(
    ("model", "words"),
    [
        (
            "gemini-robotics-er-1.6-preview",
            "was shut down on 2026-08-31; use its successor gemini-robotics-er-2-preview",
        ),
        ("gemini-robotics-er-2-streaming-preview", "Live API"),
    ],
)
def test_a_model_generate_content_cannot_serve_is_one_config_line_naming_what_to_use(model, words):
    with pytest.raises(ConfigError) as err:
        validate_model(VlmParams, {"client": "gemini", "gemini": {"model": model}})
    text = str(err.value)
    assert len(text.splitlines()) == 1 and "gemini.model" in text and words in text


def test_an_unknown_family_is_a_config_error_listing_the_families():
    with pytest.raises(ConfigError) as err:
        validate_model(VlmParams, {"openai": {"family": "llava"}})
    assert "openai.family" in str(err.value) and "qwen2.5-vl" in str(err.value)


# -- the wrong-convention guard ------------------------------------------------------------------------


class Clock:
    def __init__(self) -> None:
        self.t = 1_700_000_000.0

    def __call__(self) -> float:
        return self.t


def source_on(server: FakeModelServer, tmp_path: Path, **params):
    from mission.perception_plugins.vlm.source import VlmSource

    raw = {
        "client": "openai",
        "state_file": str(tmp_path / "q.json"),
        "publish_rate_limit_hz": 1.0,
        "requests_per_minute": 60,
        "daily_quota": 100,
        "remote": {"max_retries": 0},
        "openai": {"base_url": server.url, "model": server.model},
        **params,
    }
    clock = Clock()
    return VlmSource(raw, clock=clock), clock


def ask(src, clock, frame, n: int) -> None:
    for _ in range(n):
        src.process(frame)
        assert src.wait_idle(timeout=30.0)
        clock.t += 1.0


@pytest.mark.parametrize(
    ("model", "answer", "cause"),
    [
        ("my-finetune", '[{"point_2d": [504, 518], "label": "red box"}]', "Qwen's bbox_2d / point_2d [x, y]"),
        ("my-finetune", '<points coords="1 1 504 518">red box</points>', "Molmo2's <points coords"),
        (MODELS["qwen3-vl"], '[{"point_2d": [1290, 1243], "label": "red box"}]', "pixels, not 0-1000"),
        (MODELS["qwen2.5-vl"], '[{"point_2d": [504, 518], "label": "red box"}]', "not pixels of the resized"),
        (MODELS["molmo"], '<points coords="1 1 504 518">red box</points>', "set family molmo2"),
        (MODELS["molmo"], '<point x="504" y="518" alt="red box">red box</point>', "not percent"),
    ],
)
def test_answers_in_another_convention_are_counted_and_the_status_names_the_likely_cause(
    model, answer, cause, tmp_path
):
    with FakeModelServer("openai", model=model, answerer=lambda image, prompt: answer) as server:
        src, clock = source_on(server, tmp_path)
        ask(src, clock, FRAME, 2)
        assert src.status()["misread_cause"] == ""  # not yet: one misread is not a pattern
        ask(src, clock, FRAME, 1)
        st = src.status()
        src.close()
    assert cause in st["misread_cause"] and "set family" in st["misread_cause"], st["misread_cause"]
    assert st["answers_misread"] == 3 and not src.latch.latched


def test_a_point_read_in_the_wrong_order_lands_off_the_others_depth_is_dropped_and_named(tmp_path):
    cam = camera_pose(0.0, 0.0, yaw_towards(0.0, 0.0, BOX.centre[0], BOX.centre[1]) + 0.35)  # box off to a side
    frame = render(Scene([BOX]), cam)
    k = frame.intrinsics
    u, v = k.project(se3.apply(se3.invert(cam), box_front_face(BOX)[:3, 3])[None, :])[0]
    y, x = round(v / k.height * 1000), round(u / k.width * 1000)
    assert abs(x - y) > 150  # swapped, the point is elsewhere
    right = json.dumps([{"point": [y, x], "label": "red box"}])
    swapped = json.dumps([{"point": [x, y], "label": "red box"}])  # a model writing [x, y] now and then
    replies = [right, swapped, right, swapped, right, swapped, right]
    with FakeModelServer("openai") as server:
        server.script(*[Reply.answer(r) for r in replies])
        src, clock = source_on(server, tmp_path, min_consecutive_detections=4)
        ask(src, clock, frame, len(replies))
        st = src.status()
        src.close()
    assert st["answers_off_depth"] == 3 and st["answers_misread"] == 3
    assert st["misread_cause"].startswith("answers look like [x, y], read as [y, x]; set family")
    assert src.latch.latched and st["model_calls"] == 7  # the four right answers latched: the others dropped
    face = box_front_face(BOX)[:3, 3]
    assert np.linalg.norm(src.latch.T_anchor_target[:3, 3] - face) < 0.05


def right_answer(frame, box) -> str:
    """A 0-1000 [y, x] answer that points at the box's front face in `frame` (taken from CAM)."""
    k = frame.intrinsics
    u, v = k.project(se3.apply(se3.invert(CAM), box_front_face(box)[:3, 3])[None, :])[0]
    return json.dumps([{"point": [round(v / k.height * 1000), round(u / k.width * 1000)], "label": "red box"}])


def test_a_target_walking_away_between_answers_has_moved_and_is_not_called_misread(tmp_path):
    """A person carrying the box walks away at 0.3 m/s; a model that reads it right answers once a second. Each
    answer is off the last one's depth by 0.3 m, farther than the depth tolerance: as far as the box can walk
    in the time between them, so the box moved — no answer is held back as misread, none names a cause."""
    boxes = [Box((3.0 + 0.3 * i, 0.3, 0.25), BOX.size, BOX.bgr, yaw=0.2) for i in range(6)]
    frames = [render(Scene([b]), CAM, stamp=float(i)) for i, b in enumerate(boxes)]

    with FakeModelServer("openai") as server:
        server.script(*[Reply.answer(right_answer(f, b)) for f, b in zip(frames, boxes, strict=True)])
        src, clock = source_on(server, tmp_path, depth_tolerance_m=0.1)
        for f in frames:
            ask(src, clock, f, 1)
        st = src.status()
        src.close()
    assert st["model_calls"] == 6
    assert st.get("answers_misread", 0) == 0 and st.get("answers_off_depth", 0) == 0
    assert st["target_moved"] >= 1 and st["misread_cause"] == ""


def test_a_target_seen_twice_at_a_new_depth_has_moved_and_the_consensus_restarts(tmp_path):
    near = Box((2.0, 0.2, 0.25), BOX.size, BOX.bgr, yaw=0.2)
    frames = [render(Scene([b]), CAM) for b in (BOX, near)]

    with FakeModelServer("openai") as server:
        there, here = Reply.answer(right_answer(frames[0], BOX)), Reply.answer(right_answer(frames[1], near))
        server.script(*[there] * 2, *[here] * 3)
        src, clock = source_on(server, tmp_path)
        ask(src, clock, frames[0], 2)
        ask(src, clock, frames[1], 3)
        st = src.status()
        src.close()
    assert st["answers_off_depth"] == 1  # the first answer at the new depth was held back…
    assert src.latch.latched and st["model_calls"] == 5  # …the second confirmed it: a new consensus of three
    assert st["target_moved"] == 1 and st.get("answers_misread", 0) == 0  # and it was not a misread
    assert st["misread_cause"] == ""
    face = box_front_face(near)[:3, 3]
    assert np.linalg.norm(src.latch.T_anchor_target[:3, 3] - face) < 0.05
