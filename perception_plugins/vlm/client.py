"""What the VLM source asks of a model, and how the configured model client is chosen.

A vision-language model such as Gemini Robotics-ER is asked "where is the <label>?" and answers with
points ``[y, x]`` normalised to 0–1000 (the image's height and width), each with a confidence. That is
the whole interface (:class:`VlmClient`), so a real remote client replaces the stub without touching the
budget, consensus and latch around it (source.py).

The source's ``client`` param names the client: an entry point of the group ``mission.vlm_clients``
(core/plugins.py, the one way every kind of plugin registers). Each names a :data:`ClientFactory`, given the
source's validated params and the request budget. This package registers ``stub``, the colour-and-shape
stand-in (stub.py); ``gemini``, Google's generateContent REST API (gemini.py); and ``openai``, an
OpenAI-compatible chat-completions server such as vLLM or Ollama (openai_chat.py). A third-party package adds
a model by declaring its own factory in its pyproject.toml::

    [project.entry-points."mission.vlm_clients"]
    acme = "acme_vlm.client:acme_client"      # def acme_client(params, budget) -> VlmClient

Entry points load only when named, so an HTTP client library is loaded only by the configs that use one.
The older spelling ``client: package.module:Class`` (a class built with ``client_params`` as its keyword
arguments) still works for this release, with a deprecation warning.

A remote client sends more than one request for a call when it retries; each retry asks the source's
:class:`RequestBudget` first (quota.py), so the persisted per-minute and per-day limits hold for every
request sent, not only for the call that began it. A client may also expose ``usage`` (an object with
``to_json()``: requests, retries, tokens …): the source reports it as the run's cost.
"""

from __future__ import annotations

import importlib
import warnings
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np

from mission.core import plugins
from mission.core.errors import ConfigError, PluginError

if TYPE_CHECKING:
    from mission.perception_plugins.vlm.source import VlmParams


@dataclass(frozen=True)
class VlmPoint:
    """One answer of a VLM: a point [y, x] normalised to 0–1000, and the model's confidence in it; `box`
    (ymin, xmin, ymax, xmax in 0–1000) when the model answered with a box (the point is its centre)."""

    y: float
    x: float
    confidence: float
    box: tuple[float, float, float, float] | None = None

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


ClientFactory = Callable[["VlmParams", RequestBudget], VlmClient]


def make_client(params: VlmParams, budget: RequestBudget) -> VlmClient:
    """The client `params.client` names: an installed ``mission.vlm_clients`` entry point, given the params and
    the budget. A name that is not installed, or a factory that fails, is a ConfigError on the ``client`` key,
    so a typo stops start-up instead of every model call failing later."""
    spec = params.client
    if ":" in spec:
        return _deprecated_class_client(spec, params)
    try:
        factory: ClientFactory = plugins.load(plugins.VLM_CLIENTS, spec)
    except PluginError as err:
        raise ConfigError(
            f"{err} (or register one: entry-point group {plugins.VLM_CLIENTS.group})", key="client"
        ) from None
    return factory(params, budget)  # its ConfigErrors name its own keys (the stub's: label)


def _deprecated_class_client(spec: str, params: VlmParams) -> VlmClient:
    """``client: package.module:Class`` built with ``client_params``: the spelling before entry points."""
    module, _, cls_name = spec.partition(":")
    if not module or not cls_name:
        names = ", ".join(repr(n) for n in plugins.installed(plugins.VLM_CLIENTS))
        raise ConfigError(
            f"expected {names} or an installed {plugins.VLM_CLIENTS.group} entry point, got {spec!r}", key="client"
        )
    warnings.warn(
        f"client: {spec!r} is deprecated; register the client as an entry point of the group "
        f"{plugins.VLM_CLIENTS.group!r} and name it",
        DeprecationWarning,
        stacklevel=3,
    )
    try:
        cls: Callable[..., Any] = getattr(importlib.import_module(module), cls_name)
        return cls(**params.client_params)
    except Exception as err:
        raise ConfigError(f"cannot create VLM client {spec!r}: {err}", key="client") from None
