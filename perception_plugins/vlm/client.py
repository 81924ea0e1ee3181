"""What the VLM source asks of a model, and how the configured model client is chosen.

A vision-language model such as Gemini Robotics-ER is asked "where is the <label>?" and answers with
points ``[y, x]`` normalised to 0–1000 (the image's height and width), each with a confidence. That is
the whole interface (:class:`VlmClient`), so a real remote client replaces the stub without touching the
budget, consensus and latch around it (source.py).

The source's ``client`` param chooses the client:

* a built-in name (:data:`BUILTIN_CLIENTS`): ``stub``, the colour-and-shape stand-in (stub.py);
  ``gemini``, Google's generateContent REST API (gemini.py); ``openai``, an OpenAI-compatible
  chat-completions server such as vLLM or Ollama (openai_chat.py). A built-in is a factory given the
  source's validated params and the request budget, named by import path so that it is imported only
  when chosen — an HTTP client library is then loaded only by the configs that use one;
* ``package.module:Class``: any class with VlmClient's two methods, built with ``client_params`` as its
  keyword arguments — how a third-party package adds a model without changing this one.

A remote client sends more than one request for a call when it retries; each retry asks the source's
:class:`RequestBudget` first (quota.py), so the persisted per-minute and per-day limits hold for every
request sent, not only for the call that began it. A client may also expose ``usage`` (an object with
``to_json()``: requests, retries, tokens …): the source reports it as the run's cost.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np

from mission.core.errors import ConfigError

if TYPE_CHECKING:
    from mission.perception_plugins.vlm.source import VlmParams


@dataclass(frozen=True)
class VlmPoint:
    """One answer of a VLM: a point [y, x] normalised to 0–1000, and the model's confidence in it."""

    y: float
    x: float
    confidence: float

    def to_pixel(self, width: int, height: int) -> tuple[float, float]:
        """(u, v) in pixels of an image of that size."""
        return self.x / 1000.0 * width, self.y / 1000.0 * height


class RequestBudget(Protocol):
    """The part of the source's persisted quota a remote client uses (quota.py QuotaBudget)."""

    def take_retry(self) -> float:
        """Ask for one more request of the call in progress: 0 = granted (counted and persisted now, before
        it is sent), else the seconds until one could be (``inf``: none today)."""
        ...

    def defer(self, seconds: float) -> None:
        """The service asked for no request for this long (a Retry-After the call does not wait out)."""
        ...

    def spend_day(self) -> None:
        """The service says today's quota is spent: no more requests until the next UTC day."""
        ...


class VlmClient(Protocol):
    """What the VLM source asks of a model. `locate` may block (a network call); the source runs it
    on a worker thread, never on the tick."""

    def locate(self, image: np.ndarray, label: str) -> list[VlmPoint]: ...

    def close(self) -> None: ...


#: Built-in clients by the name the ``client`` param uses → "module:factory", the factory taking the
#: source's validated params. Paths rather than functions, so a client's dependencies load only when chosen.
BUILTIN_CLIENTS: dict[str, str] = {
    "stub": "mission.perception_plugins.vlm.stub:stub_client",
    "gemini": "mission.perception_plugins.vlm.gemini:gemini_client",
    "openai": "mission.perception_plugins.vlm.openai_chat:openai_client",
}

ClientFactory = Callable[["VlmParams", RequestBudget], VlmClient]


def make_client(params: VlmParams, budget: RequestBudget) -> VlmClient:
    """The client `params.client` names: a built-in (given the params and the budget) or a third-party class
    (given `params.client_params`). A name that is neither, or a class that cannot be built, is a
    ConfigError on the ``client`` key, so a typo stops start-up instead of every model call failing later."""
    spec = params.client
    if spec in BUILTIN_CLIENTS:
        module, attr = BUILTIN_CLIENTS[spec].split(":")
        factory: ClientFactory = getattr(importlib.import_module(module), attr)
        return factory(params, budget)  # its ConfigErrors name its own keys (the stub's: target_label)
    module, _, cls_name = spec.partition(":")
    if not module or not cls_name:
        names = ", ".join(repr(n) for n in BUILTIN_CLIENTS)
        raise ConfigError(f"expected {names} or 'package.module:Class', got {spec!r}", key="client")
    try:
        cls: Callable[..., Any] = getattr(importlib.import_module(module), cls_name)
        return cls(**params.client_params)
    except Exception as err:
        raise ConfigError(f"cannot create VLM client {spec!r}: {err}", key="client") from None
