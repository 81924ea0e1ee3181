"""The VLM source: find an object by a text label with a few rate-limited vision-language-model calls.

The design notes' Gemini Robotics-ER node, with the model behind a small client interface (client.py;
the ``client`` param chooses one: the colour-and-shape stub in stub.py by default, ``gemini`` (gemini.py)
or an OpenAI-compatible local server, ``openai`` (openai_chat.py)):

* a model call runs on a worker thread, never on the tick: ``process()`` submits a request when the
  budget allows and returns what is ready;
* the budget — ``publish_rate_limit_hz`` between calls, ``requests_per_minute`` and ``daily_quota`` per
  UTC day — is recorded in ``state_file`` *before* each request, atomically, so a crash loop cannot burn
  the quota; a remote client's retries ask the same budget first (quota.py); with ``clock: frame``
  (simulation) budget and latency run on frame stamps instead and nothing is persisted, so a seeded sim
  run repeats whatever the machine's speed;
* the remote clients ask each model family in its trained form and read its answer in its own convention
  (families.py); a point outside the image, or an answer at a depth the agreeing answers contradict, is
  counted and dropped (misreads.py), and after a few misreads ``status()["misread_cause"]``
  names the likely cause ("answers look like [x, y] …; set family");
* each answer (a pixel; a box bounds its depth patch) becomes a pose: back-projection with depth,
  MAD-filtered SVD plane (z axis), Canny + PCA in-plane axis (x axis) — depth_pose.py;
* answers are repeated until ``min_consecutive_detections`` agree within ``latch_position_tolerance_m``
  in the anchor frame (``map_frame``); the pose is then latched there and re-emitted at
  ``republish_rate_hz`` as ``inv(T_anchor_camera_now) @ T_anchor_target`` with no further calls
  (latch.py);
* the camera's anchor pose comes with each frame (``Frame.T_anchor_camera`` / ``Frame.anchor_frame``,
  filled by the world adapter); when it is missing at an attempt, the attempt fails. A model call that
  gives no answer (a timeout, a dropped connection, 5xx after the client's retries) fails too. After
  ``max_failed_latch_attempts`` consecutive failed attempts — or at once when the service rejects the
  request as such (a bad key, an unknown model: the same request would fail every time) — the circuit
  breaker stops all model calls until :meth:`VlmSource.reset_latch` (the /mission/redetect request). Its
  reason is in :meth:`VlmSource.status` (``breaker_reason``), so the heartbeat and the run report say why.
  Being told to slow down (429, our own budget) is not a failure: the budget waits it out.

A latched pose is only right while the target stays put. So, while latched, the source checks the depth
image where the target should appear: nearer than expected means something is in front (occluded: not
emitted), farther than expected for ``stale_after_frames`` frames means the target has gone (the latch
is dropped and the model is asked again, within the budget). Detections are flagged
``extra["precision"] = "coarse"``: with perception ``policy: hybrid`` a precise fiducial source that sees
the same target wins (long-range discovery by the VLM, close-range precision from the tag).
"""

from __future__ import annotations

import logging
import math
import threading
import time
from collections import Counter
from collections.abc import Callable
from concurrent.futures import Future, ThreadPoolExecutor
from concurrent.futures import wait as wait_futures
from dataclasses import dataclass
from pathlib import Path
from typing import Any, ClassVar, Literal

import numpy as np
from pydantic import Field

from mission.core import se3
from mission.core.config import Renamed, StrictModel, validate_model
from mission.core.errors import ConfigError
from mission.core.perception import TARGET_LABEL
from mission.core.types import CameraIntrinsics, Detection, Frame
from mission.perception_plugins.vlm.client import VlmClient, make_client
from mission.perception_plugins.vlm.depth_pose import SurfacePose, depth_at, estimate_surface_pose
from mission.perception_plugins.vlm.latch import Candidate, OneShotLatch
from mission.perception_plugins.vlm.misreads import AnswerScreen, MisreadLedger
from mission.perception_plugins.vlm.quota import QuotaBudget, QuotaStore, default_state_file
from mission.perception_plugins.vlm.settings import GeminiSettings, OpenAiSettings, RemoteSettings

log = logging.getLogger(__name__)


class VlmParams(StrictModel):
    """Params of the `vlm` source (defaults follow the design notes' Gemini node)."""

    renamed_keys: ClassVar[dict[str, Renamed]] = {"target_label": "label"}  # before one word for it (issue 31)

    label: str = Field(TARGET_LABEL, min_length=1)  # what to find; detections carry it (stub: colour word [+ shape])
    client: str = "stub"  # a mission.vlm_clients entry point: stub, gemini, openai shipped (`mission plugins`)
    client_params: dict[str, Any] = Field(default_factory=dict)  # the client's own settings (a third-party client's)
    confidence_threshold: float = Field(0.4, ge=0.0, le=1.0)  # answers below this are ignored
    publish_rate_limit_hz: float = Field(0.025, gt=0.0)  # model calls per second (0.025 = one per 40 s)
    requests_per_minute: int = Field(5, ge=1)  # requests in any 60 s, retries included (Gemini free tier: 5)
    daily_quota: int = Field(20, ge=0)  # requests per UTC day, retries included, shared by users of state_file
    state_file: str | None = None  # None = $XDG_CACHE_HOME/mission/vlm_quota_<client>.json
    # "wall": budget and latency in wall-clock time, budget persisted (a real model); "frame": in frame
    # stamps, nothing persisted — a simulation's time base, so seeded sim runs repeat whatever the CPU speed
    clock: Literal["wall", "frame"] = "wall"  # wall: real time, quota on disk; frame: frame stamps (sim)
    # the remote clients (gemini, openai): their manners and what each API is asked
    remote: RemoteSettings = Field(default_factory=RemoteSettings)  # client gemini / openai: timeouts, retries, image
    gemini: GeminiSettings = Field(default_factory=GeminiSettings)  # client gemini: model, prompt, response schema
    openai: OpenAiSettings = Field(default_factory=OpenAiSettings)  # client openai: base_url, model, prompt
    # client stub: its imitation of a remote model (custom clients take client_params; latency_s also paces
    # answers with clock: frame)
    latency_s: float = Field(1.0, ge=0.0)  # seconds from request to answer
    miss_rate: float = Field(0.05, ge=0.0, le=1.0)  # fraction of calls answered with nothing
    pixel_noise: float = Field(2.0, ge=0.0)  # px, standard deviation
    seed: int = 0  # seed of the stub's misses and pixel noise
    min_blob_area_px: int = Field(40, ge=1)  # smaller colour blobs are not the object
    # the latch
    latch_in_map: bool = True  # false: no latch — each answer is emitted once (for moving targets)
    map_frame: str = Field("map", min_length=1)  # the anchor frame frames must carry (Frame.anchor_frame)
    republish_rate_hz: float = Field(30.0, gt=0.0)  # rate of the latched pose, re-projected into the camera
    min_consecutive_detections: int = Field(3, ge=1)  # agreeing answers needed to latch
    latch_position_tolerance_m: float = Field(0.10, gt=0.0)  # answers agree when this close in the map frame
    latch_bearing_tolerance_rad: float = Field(0.08, ge=0.0)  # or this bearing apart at their range (heading error)
    target_speed_mps: float = Field(1.0, ge=0.0)  # m/s it may move between answers: that far off is no misread
    max_failed_latch_attempts: int = Field(5, ge=1)  # failures before the circuit breaker stops calls
    # the pose from depth
    patch_radius_m: float = Field(0.05, gt=0.0)  # depth patch around the answered pixel
    mad_k: float = Field(2.5, gt=0.0)  # depth outliers beyond k × MAD are dropped
    # keeping a latched pose honest
    republish_only_in_view: bool = True  # emit the latch only while it projects into the image
    verify_with_depth: bool = True  # compare the latch with the measured depth each frame
    depth_tolerance_m: float = Field(0.25, gt=0.0)  # depth farther than expected by more than this is a miss
    stale_after_frames: int = Field(15, ge=1)  # consecutive depth misses that drop the latch
    max_latch_age_s: float = Field(0.0, ge=0.0)  # 0 = a latch never expires by age


@dataclass(frozen=True)
class _Request:
    image: np.ndarray
    depth: np.ndarray
    intrinsics: CameraIntrinsics
    stamp: float
    frame_id: str
    T_anchor_camera: np.ndarray | None


@dataclass(frozen=True)
class _Answer:
    request: _Request
    outcome: str  # "ok" | "miss" | "no_depth"
    pose: SurfacePose | None = None
    confidence: float = 0.0
    pixel: tuple[float, float] | None = None
    dropped: int = 0  # points the client's reader set aside (outside the image, unreadable)
    hint: str = ""  # the reader's guess that the answer is in another family's convention


def colour_image_problem(image: object) -> str | None:
    """Why `image` is not an H×W×3 uint8 BGR picture a VLM can look at (None when it is)."""
    if not isinstance(image, np.ndarray):
        return f"expected an H×W×3 uint8 BGR image, got {type(image).__name__}"
    if image.dtype != np.uint8:
        return f"expected an H×W×3 uint8 BGR image, got dtype {image.dtype}"
    if image.ndim != 3 or image.shape[2] != 3 or image.size == 0:
        return f"expected an H×W×3 uint8 BGR image (the VLM finds objects by colour), got shape {tuple(image.shape)}"
    return None


class VlmSource:
    """A VLM source: a few rate-limited model calls, a consensus, then a latched pose re-emitted as the
    robot moves. Registered as `vlm`, and as `vlm_stub` (its first name, from when the stub was the only
    built-in client) so existing configs keep working."""

    description: ClassVar[str] = (
        "Vision-language model (client: stub finds '<colour> [shape]', e.g. 'red box'): latches the object's "
        "pose in the map frame after 3 agreeing rate-limited model calls (coarse)"
    )
    requires: ClassVar[frozenset[str]] = frozenset({"depth", "intrinsics"})  # an answer is placed in 3D by depth
    # What a batch tool (mission detect: one frame per image, no camera pose to latch in) runs it with
    # unless told otherwise: each answer reported as it comes, not latched in the map.
    # Each image is a request the user made, not a frame of a stream: no pacing between them (the service's
    # requests_per_minute and daily_quota still hold).
    batch_params: ClassVar[dict[str, Any]] = {"latch_in_map": False, "publish_rate_limit_hz": 1000.0}

    def __init__(
        self,
        params: dict,
        name: str = "vlm",
        *,
        clock: Callable[[], float] | None = None,
        client: VlmClient | None = None,
    ) -> None:
        """`clock` is the wall clock of the rate limit and quota (time.time; tests pass a fake one);
        `client` replaces the configured client with an instance."""
        self.params = validate_model(VlmParams, params)
        self.name = name
        p = self.params
        self._clock = clock or time.time
        client_kind = p.client.replace(":", ".")  # the budget is per client kind (one API key each)
        path = Path(p.state_file).expanduser() if p.state_file else default_state_file(client_kind)
        if p.clock == "frame":
            path = None  # frame stamps restart with every run: a budget in them is per run, not persisted
        elif p.client == "stub" and not p.state_file:
            path = None  # no service counts the stub's answers: its budget is per run, never carried to the next
        self._last_stamp = 0.0
        self._min_interval = 1.0 / p.publish_rate_limit_hz
        self.quota = QuotaStore(
            path,
            daily_quota=p.daily_quota,
            min_interval_s=self._min_interval,
            requests_per_minute=p.requests_per_minute,
        )
        try:
            self.quota.check_writable()
        except OSError as err:
            why = err.strerror or str(err)
            if err.filename and Path(err.filename) != path and not str(err.filename).endswith(".probe"):
                why += f": {err.filename}"  # the parent in the way
            raise ConfigError(
                f"cannot save the call budget to {path} ({why}); expected a writable file path", key="state_file"
            ) from None
        # the client's retries ask the same budget, on the same clock as the calls
        self._client: VlmClient = client if client is not None else make_client(p, QuotaBudget(self.quota, self._now))
        self.latch = OneShotLatch(
            min_consecutive=p.min_consecutive_detections,
            tolerance_m=p.latch_position_tolerance_m,
            bearing_tolerance_rad=p.latch_bearing_tolerance_rad,
            max_failed_attempts=p.max_failed_latch_attempts,
        )
        self._lock = threading.RLock()
        self._executor: ThreadPoolExecutor | None = None
        self._pending: Future[_Answer] | None = None
        self._pending_stamp = 0.0
        self._next_attempt = -math.inf  # budget-clock time; paces attempts that fail before a call is made
        self._next_emit: float | None = None  # frame-stamp schedule of republishing
        self._stale_frames = 0
        self._fresh: list[_Answer] = []  # unlatched mode: answers not yet emitted
        self.model_calls = 0
        self.state = "idle"
        self.counters: Counter[str] = Counter()
        self.last_error = ""  # the last failed model call, one line (no secrets: the clients redact them)
        self.misreads = MisreadLedger()
        self.screen = AnswerScreen(
            p.latch_position_tolerance_m, p.latch_bearing_tolerance_rad, p.depth_tolerance_m, p.target_speed_mps
        )
        self._logged: set[str] = set()

    # -- public controls ---------------------------------------------------------------------------
    def reset_latch(self) -> None:
        """Forget the latched pose, the candidates and the circuit breaker (the redetect request)."""
        with self._lock:
            self.latch.reset()
            self._next_emit = None
            self._stale_frames = 0
            self._next_attempt = -math.inf
            self.state = "idle"
            self._logged.discard("breaker")
            self.misreads.clear()
            self.screen.reset()

    def wait_idle(self, timeout: float) -> bool:
        """Block until the model call in flight (if any) has answered; False on timeout.

        For batch tools and tests; the tick path never calls it.
        """
        fut = self._pending
        if fut is None:
            return True
        done, _ = wait_futures([fut], timeout=timeout)
        if self.params.clock == "wall":  # with the frame clock the answer is due at a frame stamp
            with self._lock:
                self._collect()
        return bool(done)

    def status(self) -> dict[str, Any]:
        """What the source is doing, for logs, viewers, the ROS heartbeat and the run report: its state, the
        budget, the breaker and why it opened, the last failure, and what the calls cost."""
        with self._lock:
            now = self._now()
            return {
                "state": self.state,
                "client": self.params.client,
                "latched": self.latch.latched,
                "model_calls": self.model_calls,
                "calls_today": self.quota.calls_today(now),
                "daily_quota": self.params.daily_quota,
                "requests_last_minute": self.quota.requests_last_minute(now),
                "requests_per_minute": self.params.requests_per_minute,
                "run": len(self.latch.run),
                "failed_latch_attempts": self.latch.failed_attempts,
                "breaker_open": self.latch.breaker_open,
                "breaker_reason": self.latch.breaker_reason,
                "last_error": self.last_error,
                "misread_cause": self.misread_cause(),
                "in_flight": self._pending is not None,
                "cost": self.cost(),
                **{k: int(v) for k, v in self.counters.items()},
            }

    def misread_cause(self) -> str:
        """The likely cause once a few answers were misread ("" before; misreads.py): the most
        frequent guess ("answers look like [x, y]; set family"), or, when most answers are misread, that
        points keep missing the target."""
        read_right = self.counters["answers"] + self.counters["points_dropped"]
        return self.misreads.likely_cause(read_right, getattr(self._client, "family", None))

    def cost(self) -> dict[str, Any]:
        """What the model calls spent: the client's own accounting (requests, retries, tokens where the
        service reports them) when it keeps one, else the calls made (each one request)."""
        usage = getattr(self._client, "usage", None)
        to_json = getattr(usage, "to_json", None)
        if callable(to_json):
            return dict(to_json())
        return {"requests": self.model_calls, "retries": 0}

    # -- the tick ----------------------------------------------------------------------------------
    def process(self, frame: Frame) -> list[Detection]:
        """Detections for this frame (the latched target, re-expressed in this camera pose); never blocks.

        An image the model cannot look at is a ValueError before any model call is spent on it."""
        problem = colour_image_problem(frame.image)
        if problem is not None:
            raise ValueError(problem)
        with self._lock:
            out = self._answers(frame)
            self._maybe_request(frame)
            return out

    def answer(self, frame: Frame, timeout: float) -> list[Detection]:
        """Ask about this one frame and wait for the answer (batch tools: `mission detect`); the tick path
        never calls it. No second call is made for the same frame."""
        out = self.process(frame)
        if out or not self.wait_idle(timeout):
            return out
        with self._lock:
            return self._answers(frame)

    def _answers(self, frame: Frame) -> list[Detection]:
        """What has come back for this frame: fresh answers, or the latched target re-expressed in it."""
        self._last_stamp = float(frame.stamp)
        self._collect()
        if not self.params.latch_in_map:
            out = [self._unlatched_detection(a, frame) for a in self._fresh]
            self._fresh = []
            return out
        return self._republish(frame) if self.latch.latched else []

    def close(self) -> None:
        self._client.close()
        if self._executor is not None:
            self._executor.shutdown(wait=False, cancel_futures=True)
            self._executor = None

    # -- internals ---------------------------------------------------------------------------------
    def _anchor(self, frame: Frame) -> np.ndarray | None:
        t = frame.T_anchor_camera
        if t is None or frame.anchor_frame != self.params.map_frame:
            return None
        return np.asarray(t, dtype=np.float64)

    def _log_once(self, kind: str, msg: str, *args: object, level: int = logging.WARNING) -> None:
        if kind not in self._logged:
            self._logged.add(kind)
            log.log(level, "%s: " + msg, self.name, *args)

    def _maybe_request(self, frame: Frame) -> None:
        p = self.params
        if self._pending is not None:
            self.state = "waiting_for_model"
            return
        if p.latch_in_map and self.latch.latched:
            self.state = "latched"
            return
        if self.latch.breaker_open:
            self.state = "breaker_open"
            return
        k = frame.intrinsics
        if frame.depth is None or k is None or k.problem(frame.width, frame.height) is not None:
            self.state = "no_depth"  # an answer could not be placed in 3D: do not spend a call on it
            self.counters["frames_without_depth"] += 1
            return
        depth_problem = self._depth_problem(frame)
        if depth_problem is not None:
            self.state = "bad_depth"
            self.counters["frames_bad_depth"] += 1
            self._log_once("bad_depth", "%s; frame skipped (no model call spent)", depth_problem)
            return
        now = self._now()
        refusal = self.quota.refusal(now)
        if refusal is None and now < self._next_attempt:
            refusal = QuotaStore.RATE_LIMITED
        if refusal is not None:
            self.state = refusal
            if refusal == QuotaStore.QUOTA_EXHAUSTED:
                self._log_once(
                    "quota",
                    "daily quota of %d model calls is spent (%s); no more calls today",
                    p.daily_quota,
                    self.quota.path,
                )
            return
        anchor = self._anchor(frame)
        if p.latch_in_map and anchor is None:
            self._next_attempt = now + self._min_interval
            self.counters["anchor_failures"] += 1
            if self._attempt_failed(f"no camera pose in {p.map_frame!r} (frames carry {frame.anchor_frame!r})"):
                self.state = "breaker_open"
            else:
                self.state = "no_anchor"
            return
        self.quota.record_call(now)  # persisted before the call: a crash now still counts it
        self._next_attempt = now + self._min_interval
        self.model_calls += 1
        request = _Request(
            image=frame.image.copy(),
            depth=np.asarray(frame.depth, dtype=np.float32).copy(),
            intrinsics=frame.intrinsics,
            stamp=frame.stamp,
            frame_id=frame.frame_id,
            T_anchor_camera=anchor,
        )
        if self._executor is None:
            self._executor = ThreadPoolExecutor(max_workers=1, thread_name_prefix=f"vlm-{self.name}")
        self._pending = self._executor.submit(self._ask, request)
        self._pending_stamp = float(frame.stamp)
        self.state = "waiting_for_model"

    def _attempt_failed(self, why: str, *, permanent: bool = False) -> bool:
        """Count a failed attempt; True when the breaker is (now) open. Logged once per opening."""
        opened = self.latch.attempt_failed(why, permanent=permanent)
        if opened:
            self._log_once(
                "breaker", "circuit breaker open, no more model calls until redetect: %s", self.latch.breaker_reason
            )
        return opened

    def _ask(self, req: _Request) -> _Answer:
        """Worker thread: the model call, then the geometry (kept off the tick too)."""
        p = self.params
        located = self._client.locate(req.image, p.label)
        read = getattr(self._client, "last_read", None)  # what the reader set aside, and its hint
        dropped, hint = (int(read.dropped), str(read.hint)) if read is not None else (0, "")
        points = [q for q in located if q.confidence >= p.confidence_threshold]
        if not points:
            return _Answer(req, "miss", dropped=dropped, hint=hint)
        best = max(points, key=lambda q: q.confidence)
        h, w = req.image.shape[:2]
        u, v = best.to_pixel(w, h)
        box = None
        if best.box is not None:  # the box bounds the depth patch: (u0, v0, u1, v1) px
            ymin, xmin, ymax, xmax = best.box
            box = (xmin / 1000 * w, ymin / 1000 * h, xmax / 1000 * w, ymax / 1000 * h)
        pose = estimate_surface_pose(
            req.image, req.depth, req.intrinsics, u, v, patch_radius_m=p.patch_radius_m, mad_k=p.mad_k, box=box
        )
        if pose is None:
            return _Answer(req, "no_depth", pixel=(u, v), dropped=dropped, hint=hint)
        return _Answer(req, "ok", pose, best.confidence, (u, v), dropped=dropped, hint=hint)

    @staticmethod
    def _depth_problem(frame: Frame) -> str | None:
        """Why this frame's depth cannot place an answer in 3D (None when it can).

        Checked before a model call: an answer on a frame whose depth is unusable could never latch, so
        the call (and its share of the daily quota) would be wasted."""
        depth = frame.depth
        if not isinstance(depth, np.ndarray) or depth.ndim != 2:
            shape = getattr(depth, "shape", type(depth).__name__)
            return f"depth has shape {shape}, expected H×W float metres"
        if depth.shape != frame.image.shape[:2]:
            return f"depth {depth.shape} does not match image {frame.image.shape[:2]}"
        if not np.issubdtype(depth.dtype, np.floating):
            return f"depth has dtype {depth.dtype}, expected float metres (convert 16UC1 millimetres first)"
        if not np.any(np.isfinite(depth) & (depth > 0)):
            return "depth has no valid return (every pixel NaN, inf or ≤ 0)"
        return None

    def _now(self) -> float:
        return self._clock() if self.params.clock == "wall" else self._last_stamp

    def _collect(self) -> None:
        """Take the model's answer if it is ready: count it, and add it to the consensus (or the outbox)."""
        fut = self._pending
        if fut is None or not fut.done():
            return
        if self.params.clock == "frame" and self._last_stamp < self._pending_stamp + self.params.latency_s:
            return  # the simulated model has not answered yet (latency in frame time)
        self._pending = None
        try:
            answer = fut.result()
        except Exception as err:  # a failing client must not take the tick down
            self._call_failed(err)
            self.state = "breaker_open" if self.latch.breaker_open else "idle"
            return
        self.state = "idle"  # until the next frame says what the source waits for
        self.latch.attempt_ok()  # the model answered (even with nothing): failures must be consecutive
        if answer.dropped:
            self.counters["points_dropped"] += answer.dropped
        if answer.hint or (answer.dropped and answer.outcome == "miss"):
            self._misread(answer.hint)
        if answer.outcome != "ok" or answer.pose is None:
            self.counters["misses" if answer.outcome == "miss" else "answers_without_depth"] += 1
            return
        self.counters["answers"] += 1
        req = answer.request
        if not self.params.latch_in_map:
            self._fresh.append(answer)
            return
        assert req.T_anchor_camera is not None
        candidate = Candidate(
            se3.compose(req.T_anchor_camera, answer.pose.T_camera_target),
            answer.confidence,
            req.stamp,
            answer.pose.sigma_m,
            float(np.linalg.norm(answer.pose.T_camera_target[:3, 3])),
        )
        if not self._screened_in(candidate, answer):
            return
        if self.latch.add(candidate):
            self.state = "latched"
            self.counters["latches"] += 1
            self._stale_frames = 0
            self._next_emit = None
            pos = self.latch.T_anchor_target[:3, 3]  # type: ignore[index]
            log.info(
                "%s: latched %r at %s in %s after %d model calls",
                self.name,
                self.params.label,
                np.round(pos, 3).tolist(),
                self.params.map_frame,
                self.model_calls,
            )

    def _misread(self, cause: str) -> None:
        self.counters["answers_misread"] += 1
        self.misreads.add(cause)
        cause = self.misread_cause()
        if cause:
            self._log_once("misread", "answers are being misread: %s", cause)

    def _screened_in(self, candidate: Candidate, answer: _Answer) -> bool:
        """Screen an answer against the run (misreads.py) and count what it was; False when it is held back."""
        req = answer.request
        assert req.T_anchor_camera is not None and answer.pose is not None
        screened = self.screen.screen(
            candidate,
            self.latch.run,
            req.T_anchor_camera,
            answer.pose.T_camera_target[:3, 3],
            answer.pixel,
            req.image.shape[:2],
            req.intrinsics,
        )
        if screened.verdict == "walked":
            self.counters["target_moved"] += 1
        elif screened.verdict == "confirms":  # the target moved: the answer held back was read right
            self.counters["answers_misread"] -= 1
            self.counters["target_moved"] += 1
            self.misreads.withdraw(screened.cause)
            assert screened.held is not None
            self.latch.add(screened.held)  # and counts again
        elif screened.verdict == "held":
            self.counters["answers_off_depth"] += 1
            self._misread(screened.cause)
            return False
        return True

    def _call_failed(self, err: Exception) -> None:
        """A model call gave no answer: count it by kind and, unless the service only asked us to slow
        down, count it towards the breaker (a rejected request opens it at once)."""
        kind = getattr(err, "kind", None)
        why = " ".join(str(err).split())  # one line, whatever the client raised (cv2 errors span lines)
        self.counters["client_errors"] += 1
        if kind:
            self.counters[f"client_errors_{kind}"] += 1
        self.last_error = f"{type(err).__name__}: {why}" if not kind else why
        self._log_once(f"client:{kind or type(err).__name__}", "VLM client failed: %s", self.last_error)
        if getattr(err, "throttled", False):
            return
        permanent = bool(getattr(err, "permanent", False))
        self._attempt_failed(
            f"{'the service rejected the request' if permanent else 'model call failed'}: {self.last_error}",
            permanent=permanent,
        )

    def _detection(
        self, t_cam: np.ndarray, frame: Frame, confidence: float, latched: bool, extra: dict[str, Any]
    ) -> Detection:
        pos, quat = se3.to_pos_quat(t_cam)
        return Detection(
            source=self.name,
            marker_id=None,
            label=self.params.label,
            corners=None,
            position=pos,
            orientation=quat,
            confidence=float(np.clip(confidence, 0.0, 1.0)),
            reprojection_error=0.0,
            stamp=frame.stamp,
            frame_id=frame.frame_id,
            extra={
                "precision": "coarse",
                "latched": latched,
                "model_calls": self.model_calls,
                "client": self.params.client,
                **extra,
            },
        )

    def _unlatched_detection(self, answer: _Answer, frame: Frame) -> Detection:
        """An answer emitted once, moved into the current camera frame when both camera poses are known."""
        req = answer.request
        assert answer.pose is not None
        t_then = answer.pose.T_camera_target
        now_anchor = self._anchor(frame)
        if req.T_anchor_camera is not None and now_anchor is not None:
            t_cam = se3.compose(se3.invert(now_anchor), req.T_anchor_camera, t_then)
            where = frame
        else:  # keep the stamp and frame of the image the model saw
            t_cam = t_then
            where = Frame(image=req.image, stamp=req.stamp, frame_id=req.frame_id)
        return self._detection(
            t_cam,
            where,
            answer.confidence,
            False,
            {"pixel": [round(c, 1) for c in answer.pixel or (0.0, 0.0)], "age_s": round(frame.stamp - req.stamp, 3)},
        )

    def _republish(self, frame: Frame) -> list[Detection]:
        p = self.params
        latch = self.latch
        age = frame.stamp - latch.latched_at if latch.latched_at is not None else 0.0
        if p.max_latch_age_s > 0 and age > p.max_latch_age_s:
            self._drop_latch("older than max_latch_age_s")
            return []
        anchor = self._anchor(frame)
        if anchor is None:
            self.counters["republish_without_anchor"] += 1
            return []
        period = 1.0 / p.republish_rate_hz
        if self._next_emit is not None and frame.stamp < self._next_emit - 0.1 * period:
            return []  # paced on a fixed schedule, so the average rate never exceeds republish_rate_hz
        t_cam = latch.camera_pose(anchor)
        z = float(t_cam[2, 3])
        intr = frame.intrinsics
        pixel: tuple[float, float] | None = None
        if intr is not None and z > 1e-3:
            u, v = intr.project(t_cam[:3, 3])[0]
            if 0 <= u < frame.width and 0 <= v < frame.height:
                pixel = (float(u), float(v))
        if pixel is None and p.republish_only_in_view:
            self.counters["latched_out_of_view"] += 1
            return []
        if pixel is not None and p.verify_with_depth and frame.depth is not None:
            seen = depth_at(frame.depth, *pixel)
            if seen is not None and seen < z - p.depth_tolerance_m:
                self.counters["latched_occluded"] += 1
                self._stale_frames = 0
                return []
            if seen is not None and seen > z + p.depth_tolerance_m:
                self._stale_frames += 1
                if self._stale_frames >= p.stale_after_frames:
                    self._drop_latch(f"depth behind the latched pose for {self._stale_frames} frames (target moved)")
                return []
            self._stale_frames = 0
        behind = self._next_emit is None or frame.stamp - self._next_emit > period
        self._next_emit = frame.stamp + period if behind else self._next_emit + period  # type: ignore[operator]
        self.counters["republished"] += 1
        return [
            self._detection(
                t_cam,
                frame,
                latch.confidence,
                True,
                {
                    "anchor_frame": p.map_frame,
                    "pose_anchor": [
                        round(float(x), 5)
                        for x in (
                            *latch.T_anchor_target[:3, 3],  # type: ignore[index]
                            *se3.matrix_to_quat(latch.T_anchor_target),
                        )
                    ],
                    "pixel": None if pixel is None else [round(pixel[0], 1), round(pixel[1], 1)],
                    "latch_age_s": round(frame.stamp - (latch.latched_at or frame.stamp), 3),
                },
            )
        ]

    def _drop_latch(self, why: str) -> None:
        self.latch.unlatch()
        self._stale_frames = 0
        self._next_emit = None
        self.counters["unlatches"] += 1
        log.info("%s: latch on %r dropped: %s", self.name, self.params.label, why)
