"""`client: gemini` — Google's Gemini API (Gemini Robotics-ER, as the design notes run it) over its
``generateContent`` REST endpoint.

One call is one ``POST {endpoint}/models/{model}:generateContent`` with the image (inline JPEG) and the
prompt; the key goes in the ``x-goog-api-key`` header, read from the environment variable
``gemini.api_key_env`` (GOOGLE_API_KEY) when the client is built, and is never logged or reported. With
``gemini.response_schema`` the answer is constrained JSON (``responseMimeType: application/json``); it
is read robustly either way (pointing.py). Token counts come from the answer's ``usageMetadata``.

Why REST and not the google-genai SDK: the SDK retries on its own, out of sight of the persisted request
budget that the free tier (5 requests a minute, 20 a day) makes the centre of this design — every
request must be counted before it is sent (remote.py). The REST format is small and stable.
"""

from __future__ import annotations

import os
import re
from typing import TYPE_CHECKING, Any

import httpx
import numpy as np

from mission.core.errors import ConfigError
from mission.perception_plugins.vlm.client import RequestBudget, VlmPoint
from mission.perception_plugins.vlm.families import PROMPTS, AnswerReader, resolve_family
from mission.perception_plugins.vlm.pointing import ReadAnswer, prompt_for
from mission.perception_plugins.vlm.remote import ErrorDetails, ModelCallError, RemoteCaller, jpeg_base64, sent_size
from mission.perception_plugins.vlm.settings import GeminiSettings, RemoteSettings

if TYPE_CHECKING:
    from mission.perception_plugins.vlm.source import VlmParams


class GeminiClient:
    """A VlmClient on Gemini's generateContent: the image and the prompt in, normalised [y, x] points out."""

    def __init__(
        self,
        settings: GeminiSettings,
        remote: RemoteSettings,
        budget: RequestBudget | None,
        *,
        api_key: str,
        seed: int = 0,
    ) -> None:
        self.settings = settings
        self.remote = remote
        self._key = api_key
        self._caller = RemoteCaller(remote, budget, secrets=[api_key], error_details=gemini_error_details, seed=seed)
        self.url = f"{settings.endpoint.rstrip('/')}/models/{settings.model}:generateContent"
        self.family = resolve_family(settings.family, settings.model, key="gemini.family", fallback="gemini-er")
        self.last_note = ""  # what the last answer held (pointing.ReadAnswer.note), for status and logs
        self.last_read: ReadAnswer | None = None

    @property
    def usage(self) -> Any:
        return self._caller.usage

    def request_body(self, image: np.ndarray, label: str) -> dict[str, Any]:
        """The generateContent request for one question (the documented REST shape)."""
        s = self.settings
        config: dict[str, Any] = {"temperature": s.temperature}
        if s.response_schema is not None and self.family == "gemini-er":
            config["responseMimeType"] = "application/json"
            config["responseSchema"] = s.response_schema
        thinking: dict[str, Any] = {}
        if s.thinking_budget is not None:
            thinking["thinkingBudget"] = s.thinking_budget
        if s.thinking_level is not None:
            thinking["thinkingLevel"] = s.thinking_level
        if thinking:
            config["thinkingConfig"] = thinking
        data = jpeg_base64(image, max_side=self.remote.max_image_side_px, quality=self.remote.jpeg_quality)
        return {
            "contents": [
                {
                    "role": "user",
                    "parts": [
                        {"inline_data": {"mime_type": "image/jpeg", "data": data}},
                        {"text": prompt_for(s.prompt or PROMPTS[self.family], label)},
                    ],
                }
            ],
            "generationConfig": config,
        }

    def locate(self, image: np.ndarray, label: str) -> list[VlmPoint]:
        headers = {"x-goog-api-key": self._key, "content-type": "application/json"}
        answer = self._caller.post_json(self.url, self.request_body(image, label), headers)
        usage = answer.get("usageMetadata")
        if isinstance(usage, dict):
            self.usage.add_tokens(
                input_tokens=usage.get("promptTokenCount"),
                output_tokens=usage.get("candidatesTokenCount"),
                total_tokens=usage.get("totalTokenCount"),
                thinking_tokens=usage.get("thoughtsTokenCount"),
            )
        h, w = image.shape[:2]
        size = sent_size(w, h, self.remote.max_image_side_px)
        reader = AnswerReader(self.family, self.remote.default_confidence, size)
        read = self._caller.read_answer(lambda: self._answer_text(answer), reader)
        self.last_note = read.note
        self.last_read = read
        return read.points

    def _answer_text(self, answer: dict[str, Any]) -> str:
        """The model's text: the first candidate's non-thought parts. A blocked prompt or an empty
        candidate is an answer with nothing in it; a body of another shape is a bad response."""
        candidates = answer.get("candidates")
        if candidates is None:
            feedback = answer.get("promptFeedback")
            if isinstance(feedback, dict) and feedback.get("blockReason"):
                self.last_note = f"prompt blocked ({feedback['blockReason']})"
                return ""
            raise ModelCallError("bad_response", f"POST {self.url}: the answer has no candidates")
        if not isinstance(candidates, list):
            raise ModelCallError("bad_response", f"POST {self.url}: candidates is not a list")
        if not candidates:
            return ""
        first = candidates[0] if isinstance(candidates[0], dict) else {}
        parts = (first.get("content") or {}).get("parts") or []
        return "".join(p.get("text", "") for p in parts if isinstance(p, dict) and not p.get("thought"))

    def close(self) -> None:
        self._caller.close()


_DURATION = re.compile(r"^\s*(\d+(?:\.\d+)?)s\s*$")


def gemini_error_details(resp: httpx.Response) -> ErrorDetails:
    """A Google RPC error body: ``{"error": {"code", "message", "status", "details": [...]}}``, whose
    details may carry a ``RetryInfo`` (``retryDelay: "26s"``) and a ``QuotaFailure`` naming the quota
    that ran out (a per-day one means no more requests today)."""
    data = resp.json()
    err = data.get("error", {}) if isinstance(data, dict) else {}
    if not isinstance(err, dict):
        return ErrorDetails(str(err))
    out = ErrorDetails(str(err.get("message", "")))
    for detail in err.get("details") or []:
        if not isinstance(detail, dict):
            continue
        kind = str(detail.get("@type", ""))
        if kind.endswith("google.rpc.RetryInfo"):
            m = _DURATION.match(str(detail.get("retryDelay", "")))
            if m:
                out.retry_after_s = float(m.group(1))
        elif kind.endswith("google.rpc.QuotaFailure"):
            ids = [str(v.get("quotaId", "")) for v in detail.get("violations") or [] if isinstance(v, dict)]
            out.daily_quota_spent = any("PerDay" in q for q in ids)
    return out


def gemini_client(params: VlmParams, budget: RequestBudget) -> GeminiClient:
    """Gemini Robotics-ER over Google's generateContent REST API (API key from the environment).

    The ``client: gemini`` entry point. A missing key is a config error at start-up (naming the variable),
    not a failed call per frame."""
    s = params.gemini
    key = os.environ.get(s.api_key_env, "").strip()
    if not key:
        why = (
            f"the environment variable {s.api_key_env} is not set; export your Gemini API key in it "
            "(it is never read from config, so no report records it)"
        )
        raise ConfigError(why, key="gemini.api_key_env")
    return GeminiClient(s, params.remote, budget, api_key=key, seed=params.seed)
