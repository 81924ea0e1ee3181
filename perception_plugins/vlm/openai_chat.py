"""`client: openai` — an OpenAI-compatible chat-completions server with an image: the way local servers
(vLLM, Ollama, llama.cpp's server, LM Studio) serve point-capable models such as Qwen2.5-VL or Molmo.

One call is one ``POST {base_url}/chat/completions`` with a user message holding the prompt and the image
as a ``data:image/jpeg;base64,…`` URL. Open models answer in the form they were trained on, so the model's
family (``openai.family``, or its name: families.py) chooses the prompt and the reader; every reader ends
in normalised ``[y, x]`` points, so the rest of the pipeline cannot tell the clients apart. A key is sent
as a bearer token only when ``openai.api_key_env`` names a variable (local servers usually want none; a
user's OPENAI_API_KEY is never sent to a server it was not meant for). Token counts come from the
answer's ``usage``.
"""

from __future__ import annotations

import os
from typing import TYPE_CHECKING, Any

import numpy as np

from mission.core.errors import ConfigError
from mission.perception_plugins.vlm.client import RequestBudget, VlmPoint
from mission.perception_plugins.vlm.families import PROMPTS, AnswerReader, resolve_family
from mission.perception_plugins.vlm.pointing import ReadAnswer, prompt_for
from mission.perception_plugins.vlm.remote import ModelCallError, RemoteCaller, jpeg_base64, sent_size
from mission.perception_plugins.vlm.settings import OpenAiSettings, RemoteSettings

if TYPE_CHECKING:
    from mission.perception_plugins.vlm.source import VlmParams


class OpenAiChatClient:
    """A VlmClient on an OpenAI-compatible ``/chat/completions``: the image and the family's prompt in,
    normalised [y, x] points out."""

    def __init__(
        self,
        settings: OpenAiSettings,
        remote: RemoteSettings,
        budget: RequestBudget | None,
        *,
        api_key: str | None = None,
        seed: int = 0,
    ) -> None:
        if not settings.model:
            raise ConfigError("name the served model (as the server lists it at /v1/models)", key="openai.model")
        self.settings = settings
        self.remote = remote
        self._key = api_key
        self._caller = RemoteCaller(remote, budget, secrets=[api_key] if api_key else [], seed=seed)
        self.url = f"{settings.base_url.rstrip('/')}/chat/completions"
        self.family = resolve_family(settings.family, settings.model, key="openai.family")
        self.last_note = ""
        self.last_read: ReadAnswer | None = None

    @property
    def usage(self) -> Any:
        return self._caller.usage

    def request_body(self, image: np.ndarray, label: str) -> dict[str, Any]:
        """The chat-completions request for one question (OpenAI's documented shape, which vLLM and Ollama
        accept)."""
        s = self.settings
        data = jpeg_base64(image, max_side=self.remote.max_image_side_px, quality=self.remote.jpeg_quality)
        messages: list[dict[str, Any]] = []
        if s.system_prompt:
            messages.append({"role": "system", "content": s.system_prompt})
        messages.append(
            {
                "role": "user",
                "content": [
                    {"type": "text", "text": prompt_for(s.prompt or PROMPTS[self.family], label)},
                    {"type": "image_url", "image_url": {"url": f"data:image/jpeg;base64,{data}"}},
                ],
            }
        )
        body: dict[str, Any] = {
            "model": s.model,
            "messages": messages,
            "max_tokens": s.max_tokens,
            "temperature": s.temperature,
        }
        if s.json_mode:
            body["response_format"] = {"type": "json_object"}
        return body

    def locate(self, image: np.ndarray, label: str) -> list[VlmPoint]:
        headers = {"content-type": "application/json"}
        if self._key:
            headers["authorization"] = f"Bearer {self._key}"
        answer = self._caller.post_json(self.url, self.request_body(image, label), headers)
        usage = answer.get("usage")
        if isinstance(usage, dict):
            self.usage.add_tokens(
                input_tokens=usage.get("prompt_tokens"),
                output_tokens=usage.get("completion_tokens"),
                total_tokens=usage.get("total_tokens"),
            )
        h, w = image.shape[:2]
        reader = AnswerReader(
            self.family,
            self.remote.default_confidence,
            sent_size(w, h, self.remote.max_image_side_px),
            min_pixels=self.settings.min_pixels,
            max_pixels=self.settings.max_pixels,
        )
        read = self._caller.read_answer(lambda: self._answer_text(answer), reader)
        self.last_note = read.note
        self.last_read = read
        return read.points

    def _answer_text(self, answer: dict[str, Any]) -> str:
        """The first choice's message content (a string, or a list of text parts)."""
        choices = answer.get("choices")
        if not isinstance(choices, list):
            raise ModelCallError("bad_response", f"POST {self.url}: the answer has no choices")
        if not choices or not isinstance(choices[0], dict):
            return ""
        content = (choices[0].get("message") or {}).get("content")
        if isinstance(content, list):
            return "".join(str(p.get("text", "")) for p in content if isinstance(p, dict))
        return content if isinstance(content, str) else ""

    def close(self) -> None:
        self._caller.close()


def openai_client(params: VlmParams, budget: RequestBudget) -> OpenAiChatClient:
    """An OpenAI-compatible chat-completions server (vLLM, Ollama, …); key (optional) from openai.api_key_env.

    The ``client: openai`` entry point."""
    s = params.openai
    key = None
    if s.api_key_env:
        key = os.environ.get(s.api_key_env, "").strip()
        if not key:
            raise ConfigError(
                f"the environment variable {s.api_key_env} is not set (or unset openai.api_key_env "
                "for a server without a key)",
                key="openai.api_key_env",
            )
    return OpenAiChatClient(s, params.remote, budget, api_key=key, seed=params.seed)
