"""The VLM's request budget — a minimum interval between calls and a daily quota — kept in a small file.

A remote VLM's free tier allows a few requests per minute and ~20 per day. If that state lived only in
memory, a node that crashes and restarts in a loop would call the model on every start and burn the
day's quota in minutes. So a call is *recorded on disk before it is made*, and the file is written
atomically (mission.core.files) so a crash mid-write leaves the old state, never a torn file.

The quota day is the UTC calendar day of the wall clock passed in. Sources that share a state file share
one budget (as nodes sharing one API key do); by default the file is per client kind, under the user's
cache directory.
"""

from __future__ import annotations

import errno
import json
import logging
import os
import tempfile
import time
from dataclasses import asdict, dataclass
from pathlib import Path

from mission.core.files import atomic_write_text, ensure_parent

log = logging.getLogger(__name__)


def default_state_file(client: str) -> Path:
    """``$XDG_CACHE_HOME/mission/vlm_quota_<client>.json`` (``~/.cache`` when XDG_CACHE_HOME is unset)."""
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "mission" / f"vlm_quota_{client}.json"


def utc_day(wall_time: float) -> str:
    return time.strftime("%Y-%m-%d", time.gmtime(wall_time))


@dataclass
class QuotaState:
    """What survives a restart: today's call count and when the last call was made (wall clock, s)."""

    day: str = ""
    calls_today: int = 0
    last_call: float | None = None


class QuotaStore:
    """Says whether a model call may be made now, and records calls (persisted before the call)."""

    RATE_LIMITED = "rate_limited"
    QUOTA_EXHAUSTED = "quota_exhausted"

    def __init__(self, path: Path | None, *, daily_quota: int, min_interval_s: float) -> None:
        self.path = path
        self.daily_quota = daily_quota
        self.min_interval_s = min_interval_s
        self.state = QuotaState()
        self._warned = False
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
            self.state = QuotaState(
                day=str(raw.get("day", "")),
                calls_today=int(raw.get("calls_today", 0)),
                last_call=None if last is None else float(last),
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

    # -- the budget --------------------------------------------------------------------------------
    def _calls_on(self, day: str) -> int:
        return self.state.calls_today if self.state.day == day else 0

    def _refusal_in_memory(self, now: float) -> str | None:
        if self._calls_on(utc_day(now)) >= self.daily_quota:
            return self.QUOTA_EXHAUSTED
        last = self.state.last_call
        if last is not None:
            if now < last - 1.0:  # the wall clock stepped back: count from now, not from the future
                self.state.last_call = last = now
                self._save()
            if now - last < self.min_interval_s:
                return self.RATE_LIMITED
        return None

    def refusal(self, now: float) -> str | None:
        """Why a call may not be made at wall time `now` ("rate_limited", "quota_exhausted"), or None.

        Re-reads the file before allowing a call, so another process sharing it is respected.
        """
        reason = self._refusal_in_memory(now)
        if reason is None:
            self._load()
            reason = self._refusal_in_memory(now)
        return reason

    def next_allowed(self, now: float) -> float | None:
        """Wall time of the next permitted call (None if the day's quota is spent)."""
        if self._calls_on(utc_day(now)) >= self.daily_quota:
            return None
        if self.state.last_call is None:
            return now
        return max(now, self.state.last_call + self.min_interval_s)

    def record_call(self, now: float) -> None:
        """Count one call at wall time `now` and persist it (before the call is made)."""
        day = utc_day(now)
        self.state = QuotaState(day=day, calls_today=self._calls_on(day) + 1, last_call=now)
        self._save()

    def calls_today(self, now: float) -> int:
        return self._calls_on(utc_day(now))
