"""The config sections of the remote model clients: ``remote`` (the manners every remote call shares),
``gemini`` and ``openai`` (what each API is asked). They are sections of the `vlm` source's params
(source.py), so one params table documents them and ``--set`` reaches them.

No section holds an API key: keys come from the environment (``api_key_env`` names the variable), so a
config file, a run's provenance (which records the resolved config) and a report never contain one. A
key written into a section anyway is a config error saying where the key belongs.
"""

from __future__ import annotations

import copy
from typing import Any

from pydantic import Field, model_validator

from mission.core.config import StrictModel

#: The question asked of a model; ``{label}`` is replaced by the source's label (no other braces are
#: special, so a prompt may show JSON). The points come back as the design notes' Gemini Robotics-ER
#: gives them: [y, x] normalised to 0–1000.
DEFAULT_PROMPT = (
    "Point to the {label} in the image. Answer with JSON only, a list of at most 5 objects of the form "
    '[{"point": [y, x], "label": "<what it is>"}], most likely first, where [y, x] is the centre of the '
    "object with y and x normalised to 0-1000 (y down from the top edge, x right from the left edge). "
    "Answer [] if there is no {label} in the image."
)

#: Gemini's structured output for DEFAULT_PROMPT (the API's OpenAPI-subset schema): a list of points.
DEFAULT_RESPONSE_SCHEMA: dict[str, Any] = {
    "type": "ARRAY",
    "items": {
        "type": "OBJECT",
        "properties": {
            "point": {"type": "ARRAY", "items": {"type": "INTEGER"}},
            "label": {"type": "STRING"},
        },
        "required": ["point", "label"],
    },
}

GEMINI_ENDPOINT = "https://generativelanguage.googleapis.com/v1beta"


def _schema() -> dict[str, Any]:
    return copy.deepcopy(DEFAULT_RESPONSE_SCHEMA)


_KEY_FIELDS = ("api_key", "key", "apikey", "token", "api_token")


def _no_key_in_config(data: Any, env_default: str) -> Any:
    if isinstance(data, dict):
        for name in _KEY_FIELDS:
            if name in data:
                raise ValueError(
                    f"{name}: an API key is never read from config (a report would record it); export it "
                    f"as {data.get('api_key_env') or env_default} instead"
                )
    return data


class RemoteSettings(StrictModel):
    """client gemini / openai: timeouts, retries, the image sent (client stub: not used)"""

    timeout_s: float = Field(30.0, gt=0)  # one request: connect + answer, else it is retried
    max_retries: int = Field(3, ge=0)  # retries of a call after a timeout, a dropped connection, 429 or 5xx
    backoff_s: float = Field(2.0, gt=0)  # wait before the first retry; doubled for each further one
    max_backoff_s: float = Field(60.0, gt=0)  # longest wait; a Retry-After beyond it ends the call
    max_image_side_px: int = Field(1024, ge=64)  # longer side of the JPEG sent (points are normalised)
    jpeg_quality: int = Field(90, ge=10, le=100)  # of the image sent
    default_confidence: float = Field(0.8, ge=0.0, le=1.0)  # of a point the model gives no confidence for


class GeminiSettings(StrictModel):
    """client gemini: Google's generateContent REST API (Gemini Robotics-ER)"""

    model: str = Field("gemini-robotics-er-1.6-preview", min_length=1)  # the design notes' model
    endpoint: str = GEMINI_ENDPOINT  # API root: requests go to {endpoint}/models/{model}:generateContent
    api_key_env: str = Field("GOOGLE_API_KEY", min_length=1)  # environment variable holding the API key
    prompt: str = Field(DEFAULT_PROMPT, min_length=1)  # {label} is the source's label; ask for [y, x] in 0–1000
    response_schema: dict[str, Any] | None = Field(default_factory=_schema)  # JSON output schema; null: free text
    temperature: float = Field(0.5, ge=0.0, le=2.0)  # generationConfig.temperature
    thinking_budget: int | None = None  # generationConfig.thinkingConfig.thinkingBudget; null: the model's default

    @model_validator(mode="before")
    @classmethod
    def _no_key(cls, data: Any) -> Any:
        return _no_key_in_config(data, "GOOGLE_API_KEY")


class OpenAiSettings(StrictModel):
    """client openai: an OpenAI-compatible chat-completions server (vLLM, Ollama, llama.cpp, …)"""

    base_url: str = "http://127.0.0.1:8000/v1"  # the server's /v1 (vLLM: port 8000, Ollama: 11434)
    model: str | None = None  # the served model's name (required with client: openai)
    api_key_env: str | None = None  # environment variable sent as a bearer token (vLLM --api-key); none: no key
    prompt: str = Field(DEFAULT_PROMPT, min_length=1)  # {label} is the source's label; ask for [y, x] in 0–1000
    system_prompt: str | None = None  # a system message before the question (none by default)
    max_tokens: int = Field(512, ge=16)  # of the answer
    temperature: float = Field(0.0, ge=0.0, le=2.0)  # of the answer
    json_mode: bool = False  # ask for response_format json_object (servers that support it)

    @model_validator(mode="before")
    @classmethod
    def _no_key(cls, data: Any) -> Any:
        return _no_key_in_config(data, "an environment variable named by openai.api_key_env")
