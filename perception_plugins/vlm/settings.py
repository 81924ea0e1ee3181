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

from pydantic import Field, field_validator, model_validator

from mission.core.config import StrictModel
from mission.perception_plugins.vlm.families import QWEN_MAX_PIXELS, QWEN_MIN_PIXELS, Family

#: The Gemini Robotics-ER models the `gemini` client asks by default, and the ones it refuses (shut down:
#: name → successor). The streaming variant is served over the Live API, not generateContent.
GEMINI_MODEL = "gemini-robotics-er-2-preview"
GEMINI_STREAMING_MODEL = "gemini-robotics-er-2-streaming-preview"
SHUT_DOWN_MODELS: dict[str, tuple[str, str]] = {
    "gemini-robotics-er-1.6-preview": ("2026-08-31", GEMINI_MODEL),
}

#: Gemini's structured output for its prompt (families.py GEMINI_PROMPT; the API's OpenAPI-subset schema).
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

    model: str = Field(GEMINI_MODEL, min_length=1)  # Gemini Robotics-ER 2 (ER 1.6 was shut down on 2026-08-31)
    family: Family | None = None  # how it is asked and read; null: from the model's name (gemini-er)
    endpoint: str = GEMINI_ENDPOINT  # API root: requests go to {endpoint}/models/{model}:generateContent
    api_key_env: str = Field("GOOGLE_API_KEY", min_length=1)  # environment variable holding the API key
    prompt: str | None = Field(None, min_length=1)  # {label} is the source's label; null: the family's own
    response_schema: dict[str, Any] | None = Field(default_factory=_schema)  # gemini-er's JSON schema; null: none
    temperature: float = Field(0.5, ge=0.0, le=2.0)  # generationConfig.temperature
    thinking_budget: int | None = None  # generationConfig.thinkingConfig.thinkingBudget; null: the model's default
    thinking_level: str | None = Field(None, min_length=1)  # thinkingConfig.thinkingLevel (low, high); null: default

    @field_validator("model")
    @classmethod
    def _model_served(cls, model: str) -> str:
        if model in SHUT_DOWN_MODELS:
            when, successor = SHUT_DOWN_MODELS[model]
            raise ValueError(f"{model} was shut down on {when}; use its successor {successor}")
        if model == GEMINI_STREAMING_MODEL:
            raise ValueError(f"{model} is served over the Live API only, not generateContent; use {GEMINI_MODEL}")
        return model

    @model_validator(mode="before")
    @classmethod
    def _no_key(cls, data: Any) -> Any:
        return _no_key_in_config(data, "GOOGLE_API_KEY")


class OpenAiSettings(StrictModel):
    """client openai: an OpenAI-compatible chat-completions server (vLLM, Ollama, llama.cpp, …)"""

    base_url: str = "http://127.0.0.1:8000/v1"  # the server's /v1 (vLLM: port 8000, Ollama: 11434)
    model: str | None = None  # the served model's name (required with client: openai)
    family: Family | None = None  # how it is asked and read; null: from the model's name, else generic
    api_key_env: str | None = None  # environment variable sent as a bearer token (vLLM --api-key); none: no key
    prompt: str | None = Field(None, min_length=1)  # {label} is the source's label; null: the family's own
    min_pixels: int = Field(QWEN_MIN_PIXELS, ge=1)  # family qwen2.5-vl: the server's processor min_pixels
    max_pixels: int = Field(QWEN_MAX_PIXELS, ge=1)  # family qwen2.5-vl: the server's processor max_pixels
    system_prompt: str | None = None  # a system message before the question (none by default)
    max_tokens: int = Field(512, ge=16)  # of the answer
    temperature: float = Field(0.0, ge=0.0, le=2.0)  # of the answer
    json_mode: bool = False  # ask for response_format json_object (servers that support it)

    @model_validator(mode="before")
    @classmethod
    def _no_key(cls, data: Any) -> Any:
        return _no_key_in_config(data, "an environment variable named by openai.api_key_env")
