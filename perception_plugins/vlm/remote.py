"""The manners of a remote model service, shared by the Gemini and the OpenAI-compatible clients.

:class:`RemoteCaller` posts one JSON request and returns the JSON answer, and is where a remote service's
manners live, once:

* a timeout on every request (``remote.timeout_s``); a timeout, a refused or dropped connection, HTTP 429
  and 5xx are retried up to ``remote.max_retries`` times after ``backoff_s``, doubled each time (with a
  seeded jitter of up to +25 %, so clients sharing a key do not retry in step);
* a 429's ``Retry-After`` (header, or the Google RPC ``RetryInfo`` the client reads from the body) is the
  wait instead; one longer than ``max_backoff_s`` ends the call, and the source is told not to ask again
  before it (persisted: quota.py ``defer``);
* before each retry is sent, the source's persisted budget is asked for a request (client.py
  ``RequestBudget``): the per-minute and per-day limits hold for every request, and a retry the budget
  cannot grant in time ends the call instead;
* other 4xx answers (a bad key, an unknown model, a malformed request) are not retried: the same request
  would fail the same way, so the error is marked *permanent* and the source opens its circuit breaker;
* what was spent is counted (:class:`Usage`: requests, retries, failures by kind, tokens where the
  service reports them), for the run report.

Errors are :class:`ModelCallError` with a one-line message naming the request and what went wrong. Every
message passes through :meth:`RemoteCaller.redact`, which removes the API key wherever it might appear;
the key itself travels only in a request header, never in a URL.
"""

from __future__ import annotations

import base64
import email.utils
import logging
import random
import threading
import time
from collections import Counter
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import cv2
import httpx
import numpy as np

from mission.perception_plugins.vlm.client import RequestBudget
from mission.perception_plugins.vlm.pointing import MAX_TEXT, ReadAnswer, read_points
from mission.perception_plugins.vlm.settings import RemoteSettings

log = logging.getLogger(__name__)

RETRIED_STATUS = frozenset({408, 425, 429, 500, 502, 503, 504})  # and any other 5xx
MESSAGE_CHARS = 240  # of a server's error message quoted in ours


class ModelCallError(Exception):
    """A model call that gave no answer. `kind` says why:

    ``timeout``, ``connection`` (refused, reset, closed without an answer), ``server`` (5xx),
    ``rate_limited`` (429 after every retry, or a Retry-After longer than the call waits), ``quota`` (the
    service says the day's quota is spent), ``budget`` (our own persisted budget had no request for a
    retry in time), ``rejected`` (another 4xx: bad key, unknown model — `permanent`), ``bad_response``
    (an answer that is not the API's JSON), ``closed`` (the client was closed during the call).
    """

    def __init__(self, kind: str, message: str, *, status: int | None = None, permanent: bool = False) -> None:
        super().__init__(message)
        self.kind = kind
        self.status = status
        self.permanent = permanent

    @property
    def throttled(self) -> bool:
        """The service (or our budget) asked us to slow down: not a fault of the service."""
        return self.kind in ("rate_limited", "quota", "budget", "closed")


@dataclass
class ErrorDetails:
    """What a client reads from an error answer's body (each API words its errors differently)."""

    message: str = ""
    retry_after_s: float | None = None  # a wait the body asks for (Google RPC RetryInfo)
    daily_quota_spent: bool = False  # the service says the day's quota is gone (Gemini's per-day QuotaFailure)


@dataclass
class Usage:
    """What a client has spent: the run report's cost section. Tokens are None until a service reports them."""

    requests: int = 0  # HTTP requests sent, retries included
    retries: int = 0
    answers: int = 0  # answers read (2xx with the API's JSON)
    failures: Counter[str] = field(default_factory=Counter)  # calls that gave no answer, by ModelCallError.kind
    input_tokens: int | None = None
    output_tokens: int | None = None
    total_tokens: int | None = None
    thinking_tokens: int | None = None  # Gemini's thoughtsTokenCount, where reported
    unread_answers: int = 0  # answers with nothing readable in the family's form (prose only)
    request_seconds: float = 0.0  # time spent waiting for the service

    def add_tokens(self, **counts: Any) -> None:
        """Add the token counts a service reported (unknown or missing ones are skipped)."""
        for name, value in counts.items():
            if isinstance(value, int) and not isinstance(value, bool) and value >= 0:
                setattr(self, name, (getattr(self, name) or 0) + value)

    def to_json(self) -> dict[str, Any]:
        return {
            "requests": self.requests,
            "retries": self.retries,
            "answers": self.answers,
            "failures": dict(sorted(self.failures.items())),
            "input_tokens": self.input_tokens,
            "output_tokens": self.output_tokens,
            "total_tokens": self.total_tokens,
            "thinking_tokens": self.thinking_tokens,
            "unread_answers": self.unread_answers,
            "request_seconds": round(self.request_seconds, 3),
        }


def sent_size(width: int, height: int, max_side: int) -> tuple[int, int]:
    """(width, height) of the image :func:`jpeg_base64` sends for one of this size."""
    scale = max_side / max(height, width)
    if scale >= 1.0:
        return width, height
    return max(1, round(width * scale)), max(1, round(height * scale))


def jpeg_base64(image: np.ndarray, *, max_side: int, quality: int) -> str:
    """The BGR `image` as a base64 JPEG, scaled down so its longer side is at most `max_side` (the model's
    points are read as fractions of the image sent, so they hold for the full-size image)."""
    h, w = image.shape[:2]
    size = sent_size(w, h, max_side)
    if size != (w, h):
        image = cv2.resize(image, size, interpolation=cv2.INTER_AREA)
    ok, data = cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, int(quality)])
    if not ok:
        raise ValueError("the image could not be encoded as JPEG")
    return base64.b64encode(data.tobytes()).decode("ascii")


def retry_after_header(value: str | None, now: float) -> float | None:
    """Seconds a ``Retry-After`` header asks for: delta-seconds or an HTTP date (None when absent or unreadable)."""
    if not value:
        return None
    value = value.strip()
    try:
        return max(0.0, float(value))
    except ValueError:
        pass
    try:
        when = email.utils.parsedate_to_datetime(value)
    except (TypeError, ValueError):
        return None
    return max(0.0, when.timestamp() - now) if when is not None else None


def one_line(text: str, limit: int = MESSAGE_CHARS) -> str:
    text = " ".join(str(text).split())
    return text if len(text) <= limit else text[: limit - 1] + "…"


class RemoteCaller:
    """POST JSON to a model service with the manners above. One per client; calls one at a time (the
    source has one worker thread); :meth:`close` interrupts a wait between retries."""

    def __init__(
        self,
        settings: RemoteSettings,
        budget: RequestBudget | None,
        *,
        secrets: Sequence[str] = (),
        error_details: Callable[[httpx.Response], ErrorDetails] | None = None,
        seed: int = 0,
    ) -> None:
        self.settings = settings
        self.budget = budget
        self.usage = Usage()
        self._secrets = [s for s in secrets if s and len(s) >= 4]
        self._error_details = error_details or generic_error_details
        self._rng = random.Random(seed)
        self._closed = threading.Event()
        t = settings.timeout_s
        self._http = httpx.Client(timeout=httpx.Timeout(t, connect=min(t, 10.0)), follow_redirects=False)

    def redact(self, text: str) -> str:
        for secret in self._secrets:
            text = text.replace(secret, "***")
        return text

    def _error(self, kind: str, text: str, *, status: int | None = None, permanent: bool = False) -> ModelCallError:
        """An error whose message has had the key taken out, whatever echoed it (a server, a URL)."""
        return ModelCallError(kind, self.redact(text), status=status, permanent=permanent)

    def close(self) -> None:
        self._closed.set()
        self._http.close()

    def read_answer(
        self, answer_text: Callable[[], str], reader: Callable[[str], ReadAnswer] | None = None
    ) -> ReadAnswer:
        """The points of an answer whose text `answer_text` takes out of the API's body, read by `reader`
        (the model family's; default: Gemini's form), counted in the usage: a body of the wrong shape is a
        failure of its kind (and raised), text with nothing readable in it an unread answer — the same for
        every API, whatever shape its body has."""
        try:
            text = answer_text()
        except ModelCallError as err:
            self.usage.failures[err.kind] += 1
            raise
        if reader is None:
            read = read_points(text, default_confidence=self.settings.default_confidence)
        else:
            read = reader(text[:MAX_TEXT] if text else "")
        if not read.found_json:
            self.usage.unread_answers += 1
        return read

    def post_json(self, url: str, body: dict[str, Any], headers: dict[str, str]) -> dict[str, Any]:
        """The JSON object the service answered; ModelCallError when it did not, after the retries."""
        s = self.settings
        what = f"POST {url}"
        attempt = 0
        try:
            while True:
                if attempt > 0:
                    self._take_retry(what)
                self.usage.requests += 1
                result = self._send(url, body, headers, what)
                if isinstance(result, dict):
                    return result
                err, wait = result
                if err.permanent or err.kind in ("bad_response", "quota") or attempt >= s.max_retries:
                    if attempt > 0:
                        err.args = (f"{err.args[0]} (after {attempt + 1} attempts)",)
                    if err.kind == "rate_limited" and wait is not None and self.budget is not None:
                        self.budget.defer(wait)  # the service's last word on when to ask again
                    raise err
                delay = wait if wait is not None else self._backoff(attempt)
                if delay > s.max_backoff_s:
                    if err.kind == "rate_limited" and self.budget is not None:
                        self.budget.defer(delay)  # the source waits it out between calls instead
                    why = f"{err.args[0]}; asked to wait {delay:.0f} s (> remote.max_backoff_s {s.max_backoff_s:g})"
                    raise self._error(err.kind, why, status=err.status)
                log.debug("%s failed (%s); retry %d in %.2f s", what, err, attempt + 1, delay)
                self._sleep(delay, what)
                attempt += 1
                self.usage.retries += 1
        except ModelCallError as err:
            self.usage.failures[err.kind] += 1
            raise

    # -- internals -----------------------------------------------------------------------------------
    def _backoff(self, attempt: int) -> float:
        s = self.settings
        return min(s.max_backoff_s, s.backoff_s * 2.0**attempt) * (1.0 + 0.25 * self._rng.random())

    def _sleep(self, seconds: float, what: str) -> None:
        if self._closed.wait(seconds):
            raise self._error("closed", f"{what}: the client was closed during the call")

    def _take_retry(self, what: str) -> None:
        """Wait for the budget to grant a retry (recorded before it is sent), or end the call."""
        if self.budget is None:
            return
        while True:
            wait = self.budget.take_retry()
            if wait <= 0:
                return
            if wait > self.settings.max_backoff_s:
                why = "the daily quota is spent" if wait == float("inf") else f"the next request is {wait:.0f} s away"
                raise self._error("budget", f"{what}: no retry within the request budget ({why})")
            self._sleep(wait, what)

    def _send(
        self, url: str, body: dict[str, Any], headers: dict[str, str], what: str
    ) -> dict[str, Any] | tuple[ModelCallError, float | None]:
        """One request: the answer's JSON, or the error and the wait the service asked for (None: none)."""
        if self._closed.is_set():
            raise self._error("closed", f"{what}: the client was closed")
        t0 = time.monotonic()
        try:
            resp = self._http.post(url, json=body, headers=headers)
        except httpx.TimeoutException:
            limit = self.settings.timeout_s
            return self._error("timeout", f"{what}: no answer within remote.timeout_s {limit:g} s"), None
        except httpx.TransportError as err:
            if self._closed.is_set():
                raise self._error("closed", f"{what}: the client was closed during the call") from None
            why = one_line(str(err)) or type(err).__name__
            return self._error("connection", f"{what}: {why}"), None
        finally:
            self.usage.request_seconds += time.monotonic() - t0
        status = resp.status_code
        if 200 <= status < 300:
            try:
                data = resp.json()
            except ValueError:
                data = None
            if not isinstance(data, dict):
                snippet = one_line(resp.text, 80)
                return self._error(
                    "bad_response", f"{what}: HTTP {status} but not a JSON object: {snippet!r}", status=status
                ), None
            self.usage.answers += 1
            return data
        details = self._details(resp)
        text = f"{what}: HTTP {status} {resp.reason_phrase}".rstrip()
        if details.message:
            text += f": {one_line(details.message)}"
        if status == 429 and details.daily_quota_spent:
            if self.budget is not None:
                self.budget.spend_day()
            return self._error("quota", f"{text} (the service's daily quota is spent)", status=status), None
        if status in RETRIED_STATUS or status >= 500:
            wait = retry_after_header(resp.headers.get("retry-after"), time.time())
            if wait is None:
                wait = details.retry_after_s
            kind = "rate_limited" if status == 429 else "server"
            return self._error(kind, text, status=status), wait
        return self._error("rejected", text, status=status, permanent=True), None

    def _details(self, resp: httpx.Response) -> ErrorDetails:
        try:
            return self._error_details(resp)
        except Exception:  # an error body we cannot read is still an error with a status
            return ErrorDetails()


def generic_error_details(resp: httpx.Response) -> ErrorDetails:
    """The message of an OpenAI-style error (``{"error": {"message": …}}``), a vLLM one (``{"message": …}``)
    or an Ollama one (``{"error": "…"}``); else the start of the body."""
    try:
        data = resp.json()
    except ValueError:
        return ErrorDetails(one_line(resp.text, 120))
    if isinstance(data, dict):
        err = data.get("error", data)
        if isinstance(err, dict):
            return ErrorDetails(str(err.get("message") or err.get("detail") or ""))
        return ErrorDetails(str(err))
    return ErrorDetails()
