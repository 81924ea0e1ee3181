"""A TF buffer: static transforms plus time-indexed dynamic ones, looked up along the frame tree with
interpolation — what tf2's BufferCore does, as far as the node needs it. No rclpy (tf2_ros is not on PyPI).

* ``/tf_static`` transforms are kept for ever; ``/tf`` transforms are kept ``cache_s`` seconds behind the
  newest one of each frame (tf2's default cache is 10 s).
* Each frame has one parent (the newest message decides, as in tf2). ``lookup(target, source, stamp)`` walks
  both frames up to their common ancestor and composes the links, each at `stamp`: between two samples the
  translation is interpolated linearly and the rotation by slerp; outside the samples it is an error,
  except within ``tolerance_s`` of the newest or oldest one (a camera image a few ms newer than the last
  odometry transform still gets it, held). ``stamp=None`` means the newest of every link.
* Every failure is a :class:`TfError` whose message names the frames and why, and whose ``kind`` is
  ``missing`` (no such frame, or the frames are in unconnected trees), ``stale`` (the link's newest sample
  is older than the requested time by more than the tolerance), ``past`` (older than the buffer holds) or
  ``loop`` (the parent links go round in a circle — a misconfigured publisher).
* :meth:`clear` forgets the dynamic transforms (what tf2 does when ROS time jumps backwards).
"""

from __future__ import annotations

import bisect
from dataclasses import dataclass, field

import numpy as np

from mission.core import se3

MAX_DEPTH = 100  # a chain this long is a loop


class TfError(LookupError):
    """A transform that cannot be looked up; `kind`: missing | stale | past | loop."""

    def __init__(self, kind: str, message: str) -> None:
        super().__init__(message)
        self.kind = kind


@dataclass
class _Link:
    """The transforms of one child frame to its parent: one for a static link, a time series otherwise."""

    parent: str
    static: bool
    stamps: list[float] = field(default_factory=list)
    transforms: list[np.ndarray] = field(default_factory=list)

    def insert(self, stamp: float, t: np.ndarray, cache_s: float) -> None:
        if self.static:
            self.stamps, self.transforms = [stamp], [t]
            return
        i = bisect.bisect_left(self.stamps, stamp)
        if i < len(self.stamps) and self.stamps[i] == stamp:
            self.transforms[i] = t
        else:
            self.stamps.insert(i, stamp)
            self.transforms.insert(i, t)
        cut = bisect.bisect_left(self.stamps, self.stamps[-1] - cache_s)
        if cut:
            del self.stamps[:cut], self.transforms[:cut]

    def at(self, child: str, stamp: float | None, tolerance_s: float) -> np.ndarray:
        """T_parent_child at `stamp` (None: the newest)."""
        if self.static or stamp is None or (len(self.stamps) == 1 and abs(stamp - self.stamps[0]) <= tolerance_s):
            return self.transforms[-1]
        newest, oldest = self.stamps[-1], self.stamps[0]
        if stamp > newest:
            if stamp - newest <= tolerance_s:
                return self.transforms[-1]
            raise TfError(
                "stale",
                f"{self.parent} → {child}: the newest transform ({newest:.3f} s) is "
                f"{stamp - newest:.2f} s older than the time asked for ({stamp:.3f} s)",
            )
        if stamp < oldest:
            if oldest - stamp <= tolerance_s:
                return self.transforms[0]
            raise TfError(
                "past", f"{self.parent} → {child}: {stamp:.3f} s is older than the buffer holds (from {oldest:.3f} s)"
            )
        i = bisect.bisect_left(self.stamps, stamp)
        t1 = self.stamps[i]
        if t1 == stamp:
            return self.transforms[i]
        t0 = self.stamps[i - 1]
        return se3.interpolate(self.transforms[i - 1], self.transforms[i], (stamp - t0) / (t1 - t0))


class TfBuffer:
    """Static and dynamic transforms by child frame (see the module doc)."""

    def __init__(self, cache_s: float = 10.0, tolerance_s: float = 0.1) -> None:
        self.cache_s = float(cache_s)
        self.tolerance_s = float(tolerance_s)
        self._links: dict[str, _Link] = {}
        self.received = 0

    # -- input ---------------------------------------------------------------------------------------
    def set_transform(self, parent: str, child: str, stamp: float, t: np.ndarray, *, static: bool = False) -> None:
        """Add T_parent_child at `stamp`. A frame given a new parent, or turned static/dynamic, starts afresh."""
        if not parent or not child or parent == child:
            raise TfError("missing", f"transform {parent!r} → {child!r}: expected two different, non-empty frames")
        link = self._links.get(child)
        if link is None or link.parent != parent or link.static != static:
            link = self._links[child] = _Link(parent, static)
        link.insert(float(stamp), np.asarray(t, dtype=np.float64), self.cache_s)
        self.received += 1

    def clear(self) -> None:
        """Forget every dynamic transform (the static ones stay): ROS time jumped backwards."""
        self._links = {child: link for child, link in self._links.items() if link.static}

    # -- queries -------------------------------------------------------------------------------------
    def has_frame(self, frame: str) -> bool:
        return frame in self._links or any(link.parent == frame for link in self._links.values())

    def parent_of(self, frame: str) -> str | None:
        link = self._links.get(frame)
        return None if link is None else link.parent

    def newest_stamp(self, child: str) -> float | None:
        """Stamp of the newest transform of `child` to its parent (None: static or unknown)."""
        link = self._links.get(child)
        return None if link is None or link.static else link.stamps[-1]

    def _ancestors(self, frame: str) -> list[str]:
        chain = [frame]
        while (link := self._links.get(chain[-1])) is not None:
            if link.parent in chain or len(chain) > MAX_DEPTH:
                loop = " → ".join([*chain[chain.index(link.parent) :], link.parent])
                raise TfError("loop", f"TF loop: {loop} (each frame must have one parent and no cycle)")
            chain.append(link.parent)
        return chain

    def lookup(self, target: str, source: str, stamp: float | None = None) -> np.ndarray:
        """T_target_source at `stamp` (seconds; None = the newest of each link): points in `source` → `target`."""
        if target == source:
            return np.eye(4)
        up_source, up_target = self._ancestors(source), self._ancestors(target)  # a loop is the news, first
        for frame in (target, source):
            if not self.has_frame(frame):
                raise TfError("missing", f"no transform to {frame!r}: no such frame on /tf or /tf_static yet")
        common = next((f for f in up_source if f in set(up_target)), None)
        if common is None:
            ends = f"{source!r} ends at {up_source[-1]!r}, {target!r} at {up_target[-1]!r}"
            why = f"their trees are not connected ({ends})"
            raise TfError("missing", f"no transform from {target!r} to {source!r}: {why}")
        t_common_source = self._down(up_source[: up_source.index(common) + 1], stamp)
        t_common_target = self._down(up_target[: up_target.index(common) + 1], stamp)
        return se3.compose(se3.invert(t_common_target), t_common_source)

    def _down(self, chain: list[str], stamp: float | None) -> np.ndarray:
        """T_top_bottom along `chain` = [bottom, …, top] (each a child of the next)."""
        out = np.eye(4)
        for child in chain[:-1]:
            out = self._links[child].at(child, stamp, self.tolerance_s) @ out
        return out

    def try_lookup(self, target: str, source: str, stamp: float | None = None) -> tuple[np.ndarray | None, str]:
        """(T_target_source, "") or (None, why not)."""
        try:
            return self.lookup(target, source, stamp), ""
        except TfError as err:
            return None, str(err)
