"""Loopback stand-ins for the two remote model APIs the VLM clients speak: the edge of the system, the one
place a fake is allowed. Nothing here leaves 127.0.0.1.

:class:`FakeModelServer` is a real HTTP/1.1 server on 127.0.0.1 (an ephemeral port, its own threads) that
speaks, as documented:

* **Gemini** ``POST /v1beta/models/{model}:generateContent`` — the key in ``x-goog-api-key``, the image as
  an ``inline_data`` part (a JPEG it decodes), the prompt as a ``text`` part; it answers with
  ``candidates[0].content.parts[].text`` and ``usageMetadata``, and errors as Google RPC errors
  (``{"error": {"code", "message", "status", "details"}}`` with ``RetryInfo`` / ``QuotaFailure``);
* **OpenAI chat completions** ``POST /v1/chat/completions`` — an optional bearer key, a user message with a
  ``text`` part and an ``image_url`` data URL; it answers with ``choices[0].message.content`` and
  ``usage``, errors as ``{"error": {"message", "type", "code"}}``.

A request of the wrong shape is answered 400 and recorded in :attr:`FakeModelServer.problems` (a test
asserts there are none). What a well-formed request gets is scripted: :meth:`FakeModelServer.script`
queues :class:`Reply` values (an answer, an HTTP status with Retry-After, a slow answer, a dropped
connection, a body that is not JSON); with the queue empty, the ``answerer`` (image, prompt) → model
text decides, by default "nothing here" (``[]``). Every request is recorded (:class:`Received`) with the
time it arrived, so tests can check back-off and the budget from the server's side.
"""

from __future__ import annotations

import base64
import json
import re
import threading
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from typing import Any
from urllib.parse import urlsplit

import cv2
import numpy as np

Answerer = Callable[[np.ndarray, str], str]


@dataclass(frozen=True)
class Reply:
    """What the server does with one request."""

    kind: str  # "answer" | "status" | "slow" | "drop" | "raw"
    text: str = ""  # the model's text (answer, slow)
    status: int = 200
    retry_after: str | None = None  # the Retry-After header (status)
    retry_delay_s: float | None = None  # Gemini: a google.rpc.RetryInfo in the error body (status)
    per_day: bool = False  # Gemini 429: the QuotaFailure names a per-day quota
    message: str = ""  # the error message (status)
    delay_s: float = 0.0  # slow: wait this long before answering
    body: bytes = b""  # raw: exactly these bytes, as application/json

    @staticmethod
    def answer(text: str) -> Reply:
        return Reply("answer", text=text)

    @staticmethod
    def points(*yx: tuple[float, float], label: str = "red box") -> Reply:
        return Reply.answer(json.dumps([{"point": [y, x], "label": label} for y, x in yx]))

    @staticmethod
    def error(
        status: int,
        message: str = "",
        *,
        retry_after: str | None = None,
        retry_delay_s: float | None = None,
        per_day: bool = False,
    ) -> Reply:
        return Reply(
            "status",
            status=status,
            message=message,
            retry_after=retry_after,
            retry_delay_s=retry_delay_s,
            per_day=per_day,
        )

    @staticmethod
    def slow(seconds: float, text: str = "[]") -> Reply:
        return Reply("slow", text=text, delay_s=seconds)

    @staticmethod
    def drop() -> Reply:
        """Read the request, then close the connection without a word."""
        return Reply("drop")

    @staticmethod
    def raw(body: bytes, status: int = 200) -> Reply:
        return Reply("raw", body=body, status=status)


@dataclass
class Received:
    """One request as the server saw it."""

    t: float  # time.monotonic() when it arrived
    path: str
    headers: dict[str, str]
    body: dict[str, Any]
    image: np.ndarray | None  # the image it carried, decoded
    prompt: str
    reply: str = ""  # the kind of Reply it got


@dataclass
class Totals:
    """What the server charged: the tokens it reported, summed over its answers."""

    answers: int = 0
    input_tokens: int = 0
    output_tokens: int = 0


class FakeModelServer:
    """A Gemini or OpenAI-compatible model API on 127.0.0.1 (see the module doc). Use as a context manager."""

    def __init__(
        self,
        api: str,
        *,
        api_key: str | None = None,
        model: str | None = None,
        answerer: Answerer | None = None,
        on_request: Callable[[Received], None] | None = None,
    ) -> None:
        assert api in ("gemini", "openai"), api
        self.api = api
        self.api_key = api_key
        self.model = model or ("gemini-robotics-er-2-preview" if api == "gemini" else "local-pointing-model")
        self.answerer: Answerer = answerer or (lambda image, prompt: "[]")
        self.on_request = on_request  # called as each well-formed request arrives, before it is answered
        self.received: list[Received] = []
        self.problems: list[str] = []  # requests the real API would refuse as malformed
        self.totals = Totals()
        self._queue: deque[Reply] = deque()
        self._lock = threading.Lock()
        self._stop = threading.Event()
        server = self

        class Handler(BaseHTTPRequestHandler):
            protocol_version = "HTTP/1.1"  # keep-alive, as real API front ends

            def do_POST(self) -> None:
                server._handle(self)

            def log_message(self, *args: Any) -> None:  # quiet: tests read .received instead
                pass

        self._httpd = ThreadingHTTPServer(("127.0.0.1", 0), Handler)
        self._httpd.daemon_threads = True
        self._thread = threading.Thread(
            target=self._httpd.serve_forever, kwargs={"poll_interval": 0.02}, name=f"fake-{api}", daemon=True
        )

    # -- control -----------------------------------------------------------------------------------
    @property
    def port(self) -> int:
        return int(self._httpd.server_address[1])

    @property
    def url(self) -> str:
        """What the client config takes: gemini.endpoint or openai.base_url."""
        return f"http://127.0.0.1:{self.port}/v1beta" if self.api == "gemini" else f"http://127.0.0.1:{self.port}/v1"

    def script(self, *replies: Reply) -> FakeModelServer:
        with self._lock:
            self._queue.extend(replies)
        return self

    def replies(self) -> list[str]:
        return [r.reply for r in self.received]

    def __enter__(self) -> FakeModelServer:
        self._thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        self._stop.set()
        self._httpd.shutdown()
        self._httpd.server_close()
        self._thread.join(timeout=5)

    # -- one request -------------------------------------------------------------------------------
    def _handle(self, h: BaseHTTPRequestHandler) -> None:
        t = time.monotonic()
        length = int(h.headers.get("content-length") or 0)
        raw = h.rfile.read(length) if length else b""
        headers = {k.lower(): v for k, v in h.headers.items()}
        try:
            body = json.loads(raw or b"null")
        except ValueError:
            body = None
        problem, image, prompt = self._check(h.path, headers, body)
        rec = Received(t, h.path, headers, body if isinstance(body, dict) else {}, image, prompt)
        with self._lock:
            self.received.append(rec)
        if problem is not None:
            with self._lock:
                self.problems.append(problem)
            rec.reply = "malformed"
            status, message = (401, problem) if problem.startswith("key:") else (400, problem)
            self._send_json(h, status, self._error_body(status, message))
            return
        if self.on_request is not None:
            self.on_request(rec)
        with self._lock:
            reply = self._queue.popleft() if self._queue else None
        if reply is None:
            try:
                reply = Reply.answer(self.answerer(image, prompt))  # type: ignore[arg-type]
            except Exception as err:  # the harness's answerer failed: say so, as a server error
                with self._lock:
                    self.problems.append(f"answerer: {type(err).__name__}: {err}")
                reply = Reply.error(500, "the fake model's answerer failed")
        rec.reply = reply.kind if reply.kind != "status" else f"{reply.status}"
        if reply.kind == "drop":
            h.close_connection = True
            return
        if reply.kind == "raw":
            self._send(h, reply.status, reply.body, {"content-type": "application/json"})
            return
        if reply.kind == "status":
            extra = {"retry-after": reply.retry_after} if reply.retry_after is not None else {}
            self._send_json(h, reply.status, self._error_body(reply.status, reply.message, reply), extra)
            return
        if reply.kind == "slow" and self._stop.wait(reply.delay_s):
            return
        self._send_json(h, 200, self._answer_body(reply.text, prompt))

    def _check(self, path: str, headers: dict[str, str], body: Any) -> tuple[str | None, np.ndarray | None, str]:
        """(what is wrong with the request or None, its image, its prompt) — the API's documented shape."""
        split = urlsplit(path)
        if "key=" in split.query:
            return "the API key must not travel in the URL", None, ""
        if not isinstance(body, dict):
            return "the body is not a JSON object", None, ""
        if self.api == "gemini":
            m = re.fullmatch(r"/v1beta/models/([\w.\-]+):generateContent", split.path)
            if m is None:
                return f"no such method {split.path}", None, ""
            if self.api_key is not None and headers.get("x-goog-api-key") != self.api_key:
                return "key: API key not valid. Please pass a valid API key.", None, ""
            try:
                parts = body["contents"][0]["parts"]
                blobs = [p.get("inline_data") or p.get("inlineData") for p in parts]
                blob = next(b for b in blobs if b)
                data = blob["data"]
                mime = blob.get("mime_type") or blob.get("mimeType")
                prompt = " ".join(p["text"] for p in parts if "text" in p)
            except (KeyError, IndexError, TypeError, StopIteration):
                return "contents[0].parts needs an inline_data image and a text part", None, ""
            if mime not in ("image/jpeg", "image/png"):
                return f"unsupported mime type {mime!r}", None, ""
            config = body.get("generationConfig", {})
            if not isinstance(config, dict):
                return "generationConfig must be an object", None, ""
        else:
            if split.path != "/v1/chat/completions":
                return f"no such route {split.path}", None, ""
            if self.api_key is not None and headers.get("authorization") != f"Bearer {self.api_key}":
                return "key: Incorrect API key provided.", None, ""
            try:
                if not isinstance(body["model"], str) or not body["model"]:
                    return "model must be a non-empty string", None, ""
                content = next(m for m in body["messages"] if m["role"] == "user")["content"]
                prompt = " ".join(p["text"] for p in content if p.get("type") == "text")
                url = next(p["image_url"]["url"] for p in content if p.get("type") == "image_url")
                head, data = url.split(",", 1)
            except (KeyError, IndexError, TypeError, StopIteration, ValueError):
                return "messages needs a user message with a text part and an image_url part", None, ""
            if head not in ("data:image/jpeg;base64", "data:image/png;base64"):
                return f"image_url must be a base64 data URL, got {head[:40]!r}", None, ""
        try:
            image = cv2.imdecode(np.frombuffer(base64.b64decode(data, validate=True), np.uint8), cv2.IMREAD_COLOR)
        except (ValueError, TypeError):
            image = None
        if image is None:
            return "the image data is not a decodable image", None, prompt
        if not prompt.strip():
            return "the prompt is empty", image, prompt
        return None, image, prompt

    # -- bodies --------------------------------------------------------------------------------------
    def _answer_body(self, text: str, prompt: str) -> dict[str, Any]:
        tokens_in = 258 + len(prompt.split())  # an image is 258 tokens at Gemini's smallest tile
        tokens_out = max(1, len(text) // 4)
        with self._lock:
            self.totals.answers += 1
            self.totals.input_tokens += tokens_in
            self.totals.output_tokens += tokens_out
        if self.api == "gemini":
            return {
                "candidates": [
                    {"content": {"parts": [{"text": text}], "role": "model"}, "finishReason": "STOP", "index": 0}
                ],
                "usageMetadata": {
                    "promptTokenCount": tokens_in,
                    "candidatesTokenCount": tokens_out,
                    "totalTokenCount": tokens_in + tokens_out,
                },
                "modelVersion": self.model,
            }
        return {
            "id": f"chatcmpl-{len(self.received)}",
            "object": "chat.completion",
            "created": int(time.time()),
            "model": self.model,
            "choices": [{"index": 0, "message": {"role": "assistant", "content": text}, "finish_reason": "stop"}],
            "usage": {
                "prompt_tokens": tokens_in,
                "completion_tokens": tokens_out,
                "total_tokens": tokens_in + tokens_out,
            },
        }

    def _error_body(self, status: int, message: str, reply: Reply | None = None) -> dict[str, Any]:
        if self.api == "gemini":
            names = {
                400: "INVALID_ARGUMENT",
                401: "UNAUTHENTICATED",
                403: "PERMISSION_DENIED",
                404: "NOT_FOUND",
                429: "RESOURCE_EXHAUSTED",
                500: "INTERNAL",
                503: "UNAVAILABLE",
            }
            details: list[dict[str, Any]] = []
            if reply is not None and status == 429:
                quota = (
                    "GenerateRequestsPerDayPerProjectPerModel-FreeTier"
                    if reply.per_day
                    else "GenerateRequestsPerMinutePerProjectPerModel-FreeTier"
                )
                details.append(
                    {
                        "@type": "type.googleapis.com/google.rpc.QuotaFailure",
                        "violations": [
                            {
                                "quotaMetric": "generativelanguage.googleapis.com/generate_content_free_tier_requests",
                                "quotaId": quota,
                            }
                        ],
                    }
                )
            if reply is not None and reply.retry_delay_s is not None:
                details.append(
                    {"@type": "type.googleapis.com/google.rpc.RetryInfo", "retryDelay": f"{reply.retry_delay_s:g}s"}
                )
            return {
                "error": {
                    "code": status,
                    "message": message or names.get(status, "error"),
                    "status": names.get(status, "UNKNOWN"),
                    "details": details,
                }
            }
        return {
            "error": {
                "message": message or f"error {status}",
                "type": "server_error" if status >= 500 else "invalid_request_error",
                "code": status,
            }
        }

    def _send_json(
        self, h: BaseHTTPRequestHandler, status: int, data: dict[str, Any], extra: dict[str, str] | None = None
    ) -> None:
        self._send(h, status, json.dumps(data).encode(), {"content-type": "application/json", **(extra or {})})

    @staticmethod
    def _send(h: BaseHTTPRequestHandler, status: int, payload: bytes, headers: dict[str, str]) -> None:
        try:
            h.send_response(status)
            for k, v in headers.items():
                h.send_header(k, v)
            h.send_header("content-length", str(len(payload)))
            h.end_headers()
            h.wfile.write(payload)
        except (BrokenPipeError, ConnectionResetError):  # the client gave up (its timeout): nothing to tell
            h.close_connection = True


def model_text(points: list[tuple[float, float]], label: str = "red box") -> str:
    """The answer a pointing model gives for these [y, x] points (0–1000)."""
    return json.dumps([{"point": [round(y), round(x)], "label": label} for y, x in points])


@dataclass
class Oracle:
    """Ground truth for the fake model: what the target's pixel is in each image the harness saw.

    The harness records each frame it renders with the target's true pixel (or None); the server's
    answerer looks up the image it was sent — a JPEG of one of those frames, maybe scaled — by a small
    grey thumbnail, the nearest recorded one. So the fake model knows nothing of the simulation, and the
    simulation nothing of HTTP.
    """

    keep: int = 200
    _frames: deque[tuple[np.ndarray, tuple[float, float, int, int] | None]] = field(default_factory=deque)
    _cv: threading.Condition = field(default_factory=threading.Condition)

    @staticmethod
    def thumbnail(image: np.ndarray) -> np.ndarray:
        grey = cv2.cvtColor(image, cv2.COLOR_BGR2GRAY) if image.ndim == 3 else image
        return cv2.resize(grey, (40, 30), interpolation=cv2.INTER_AREA).astype(np.float32)

    def record(self, image: np.ndarray, pixel: tuple[float, float] | None) -> None:
        """A frame the harness saw, and where the target truly is in it (u, v px; None: not visible)."""
        h, w = image.shape[:2]
        entry = (self.thumbnail(image), None if pixel is None else (pixel[0], pixel[1], w, h))
        with self._cv:
            self._frames.append(entry)
            while len(self._frames) > self.keep:
                self._frames.popleft()
            self._cv.notify_all()

    def lookup(self, image: np.ndarray, timeout_s: float = 5.0, max_diff: float = 4.0) -> tuple[float, float] | None:
        """The target's [y, x] (0–1000) in `image`, None when not visible there. Waits (up to `timeout_s`)
        for the harness to record the frame: the request may arrive before the frame's record."""
        thumb = self.thumbnail(image)
        deadline = time.monotonic() + timeout_s
        with self._cv:
            while True:
                best = min(self._frames, key=lambda f: float(np.mean(np.abs(f[0] - thumb))), default=None)
                if best is not None and float(np.mean(np.abs(best[0] - thumb))) <= max_diff:
                    if best[1] is None:
                        return None
                    u, v, w, h = best[1]
                    return v / h * 1000.0, u / w * 1000.0
                left = deadline - time.monotonic()
                if left <= 0:
                    raise AssertionError("the fake model was sent an image the harness never recorded")
                self._cv.wait(left)
