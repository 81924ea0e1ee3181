"""The VLM's request budget — a minimum interval between calls and a daily quota — kept in a small file.

A remote VLM's free tier allows a few requests per minute and ~20 per day. If that state lived only in
memory, a node that crashes and restarts in a loop would call the model on every start and burn the
day's quota in minutes. So a call is *recorded on disk before it is made*, and the file is written
atomically (mission.core.files) so a crash mid-write leaves the old state, never a torn file.

The quota day is the UTC calendar day of the wall clock passed in. Sources that share a state file share
one budget (as nodes sharing one API key do); by default the file is per client kind, under the user's
cache directory.

Three limits, as a remote API's free tier states them (Gemini Robotics-ER: 5 requests a minute, 20 a day):

* ``min_interval_s`` between *calls* — the source's own pacing of its questions (publish_rate_limit_hz);
* ``requests_per_minute`` in any 60 s window and ``daily_quota`` per UTC day, counting every *request*
  sent — a call's retries included — because that is what the service counts;
* a pause the service itself asked for (a Retry-After longer than a call waits, :meth:`QuotaStore.defer`)
  or a daily quota it says is spent (:meth:`QuotaStore.spend_day`), so a restart does not ask again early.

:class:`QuotaBudget` is the part a remote client sees (client.py ``RequestBudget``): before each retry it
asks for a request, which is recorded on disk before it is sent, like the call's first one.
"""

from __future__ import annotations

import errno
import json
import logging
import math
import os
import tempfile
import threading
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from pathlib import Path

from mission.core.files import atomic_write_text, ensure_parent

log = logging.getLogger(__name__)


def default_state_file(client: str) -> Path:
    """``$XDG_CACHE_HOME/mission/vlm_quota_<client>.json`` (``~/.cache`` when XDG_CACHE_HOME is unset)."""
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "mission" / f"vlm_quota_{client}.json"


def utc_day(wall_time: float) -> str:
    return time.strftime("%Y-%m-%d", time.gmtime(wall_time))


WINDOW_S = 60.0  # the "per minute" of requests_per_minute


@dataclass
class QuotaState:
    """What survives a restart: today's request count, when the last call began, the requests of the last
    minute and a pause the service asked for (wall clock, s)."""

    day: str = ""
    calls_today: int = 0  # requests sent this UTC day (every call's first request and its retries)
    last_call: float | None = None
    recent: list[float] = field(default_factory=list)  # request times within the last WINDOW_S
    not_before: float | None = None  # no request before this time (the service's Retry-After)


class QuotaStore:
    """Says whether a model call may be made now, and records calls (persisted before the call)."""

    RATE_LIMITED = "rate_limited"
    QUOTA_EXHAUSTED = "quota_exhausted"

    def __init__(
        self, path: Path | None, *, daily_quota: int, min_interval_s: float, requests_per_minute: int | None = None
    ) -> None:
        self.path = path
        self.daily_quota = daily_quota
        self.min_interval_s = min_interval_s
        self.requests_per_minute = requests_per_minute
        self.state = QuotaState()
        self._warned = False
        self._lock = threading.RLock()  # the tick asks for calls, a client's worker thread for retries
        self._load()

    # -- persistence -------------------------------------------------------------------------------
    def check_writable(self) -> None:
        """Raise OSError now if the state could not be saved later (a directory in the way, no permission).

        A call is only made once it is recorded on disk, so an unsaveable state file would silently stop
        every model call; checked at start-up instead, without touching an existing state file."""
        if self.path is None:
            return
        if self.path.is_dir():
            raise IsADirectoryError(errno.EISDIR, os.strerror(errno.EISDIR), str(self.path))
        ensure_parent(self.path)
        fd, probe = tempfile.mkstemp(dir=self.path.parent, prefix=f".{self.path.name}.", suffix=".probe")
        os.close(fd)
        os.unlink(probe)

    def _load(self) -> None:
        if self.path is None or not self.path.exists():
            return
        try:
            raw = json.loads(self.path.read_text(encoding="utf-8"))
            last = raw.get("last_call")
            pause = raw.get("not_before")
            self.state = QuotaState(
                day=str(raw.get("day", "")),
                calls_today=int(raw.get("calls_today", 0)),
                last_call=None if last is None else float(last),
                recent=[float(t) for t in raw.get("recent", [])],  # absent in files of older versions
                not_before=None if pause is None else float(pause),
            )
        except (OSError, ValueError, TypeError, AttributeError) as err:
            # Unreadable state must not reset the budget silently: keep what we had in memory and say so.
            if not self._warned:
                log.warning("VLM quota state %s is unreadable (%s); delete it to reset the budget", self.path, err)
                self._warned = True

    def _save(self) -> None:
        if self.path is None:
            return
        atomic_write_text(self.path, json.dumps(asdict(self.state)))

    # -- the budget --------------------------------------------------------------------------------------
    def _calls_on(self, day: str) -> int:
        return self.state.calls_today if self.state.day == day else 0

    def _in_window(self, now: float) -> list[float]:
        return [t for t in self.state.recent if now - WINDOW_S < t <= now + 1.0]

    def _request_wait(self, now: float) -> float:
        """Seconds until a request may be sent (0: now; inf: not today) by the daily quota, the
        service's pause and the per-minute window — not by the interval between calls."""
        if self._calls_on(utc_day(now)) >= self.daily_quota:
            return math.inf
        wait = 0.0
        pause = self.state.not_before
        if pause is not None and now < pause:
            wait = pause - now
        window = self._in_window(now)
        if self.requests_per_minute is not None and len(window) >= self.requests_per_minute:
            wait = max(wait, sorted(window)[-self.requests_per_minute] + WINDOW_S - now)
        return wait

    def _refusal_in_memory(self, now: float) -> str | None:
        wait = self._request_wait(now)
        if math.isinf(wait):
            return self.QUOTA_EXHAUSTED
        if wait > 0:
            return self.RATE_LIMITED
        last = self.state.last_call
        if last is not None:
            if now < last - 1.0:  # the wall clock stepped back: count from now, not from the future
                self.state.last_call = last = now
                self.state.recent = [min(t, now) for t in self.state.recent]
                self._save()
            if now - last < self.min_interval_s:
                return self.RATE_LIMITED
        return None

    def refusal(self, now: float) -> str | None:
        """Why a call may not be made at wall time `now` ("rate_limited", "quota_exhausted"), or None.

        Re-reads the file before allowing a call, so another process sharing it is respected.
        """
        with self._lock:
            reason = self._refusal_in_memory(now)
            if reason is None:
                self._load()
                reason = self._refusal_in_memory(now)
            return reason

    def next_allowed(self, now: float) -> float | None:
        """Wall time of the next permitted call (None if the day's quota is spent)."""
        with self._lock:
            wait = self._request_wait(now)
            if math.isinf(wait):
                return None
            last = self.state.last_call
            start = now if last is None else last + self.min_interval_s
            return max(now + wait, start)

    def _count_request(self, now: float) -> None:
        day = utc_day(now)
        self.state.day, self.state.calls_today = day, self._calls_on(day) + 1
        self.state.recent = [*self._in_window(now), now]

    def record_call(self, now: float) -> None:
        """Count a call's first request at wall time `now` and persist it (before the request is sent)."""
        with self._lock:
            self._count_request(now)
            self.state.last_call = now
            self._save()

    def take_request(self, now: float) -> float:
        """A further request of a call in progress (a retry): 0 when it may be sent now — it is then counted
        and persisted, before it is sent — else the seconds to wait for one (inf: none today)."""
        with self._lock:
            self._load()  # another process sharing the file may have spent the budget
            wait = self._request_wait(now)
            if wait <= 0:
                self._count_request(now)
                self._save()
            return wait

    def defer(self, until: float) -> None:
        """The service asked for no request before wall time `until` (a long Retry-After): kept on disk."""
        with self._lock:
            if self.state.not_before is None or until > self.state.not_before:
                self.state.not_before = until
                self._save()

    def spend_day(self, now: float) -> None:
        """The service says today's quota is spent (its count may differ from ours): no more requests today."""
        with self._lock:
            day = utc_day(now)
            self.state.day, self.state.calls_today = day, max(self._calls_on(day), self.daily_quota)
            self._save()

    def calls_today(self, now: float) -> int:
        return self._calls_on(utc_day(now))

    def requests_last_minute(self, now: float) -> int:
        return len(self._in_window(now))


class QuotaBudget:
    """What a remote client may do with the budget (client.py ``RequestBudget``), on `clock`'s time: the
    source's own clock, so retries and calls are counted on one time base."""

    def __init__(self, store: QuotaStore, clock: Callable[[], float]) -> None:
        self.store = store
        self.clock = clock

    def take_retry(self) -> float:
        return self.store.take_request(self.clock())

    def defer(self, seconds: float) -> None:
        self.store.defer(self.clock() + seconds)

    def spend_day(self) -> None:
        self.store.spend_day(self.clock())
