"""Tracking mode for the marker sources: look where the markers were, not at the whole frame (issue 34).

A full-frame detection costs the same on every frame, whether anything moved or not; between frames a
tracked marker's next quad is its last one moved on by its last motion, to within the robot's. So with
``tracking`` on, a source given a `follow` (both marker sources, with edges refinement) first *follows*
each tracked marker: its predicted quad is refined onto the frame's edges, and kept when the refined quad
holds the id's pattern and its four edges lie where the quad puts them (perception_plugins/marker_bits.py):
no detector call at all.
The markers not followed (it moved further than the refiner reaches, something hid part of it) are detected
in a window round each predicted quad instead of the whole frame, and the whole frame only:

* on the first frame, and every ``full_frame_every``-th frame after, so a marker that comes into view is
  found at most ``full_frame_every − 1`` frames after the full-frame detector would have found it;
* at once, on the same frame, when a tracked marker is not found in its window (it moved faster than
  predicted, or something hid it) nor in its window alone: a marker the full frame finds is not lost to the
  tracking — unless every other marker tracked, EXCUSE_MIN_FOUND at least, was found where its motion put it
  (:meth:`RegionTracker.excuse`): then the scene did not jump, the marker was not detected rather than moved,
  and it coasts (below) while the search pass looks everywhere else.

On every frame that is not a full-frame pass, a *search pass* looks over the whole frame at reduced resolution
(the windows masked) for markers coming into view: one it finds is detected again in a window of its own, on
that frame (and where that window does not find it again, the frame goes to the full detector), so the bound
above holds only for markers under the search's floor (~36 px at 1280×720). With nothing found last frame —
exploring, searching, the view empty of markers, or tracks only coasting — the full frame comes every
IDLE_FULL_FRAME_EVERY-th frame instead, and the search pass alone between: a full-frame pass on each such frame
was two fifths of a rendered explore_dock run's frames, and every 10th left 14–17 px markers of a ChArUco board
coming into a webcam's empty view unfound for up to 9 frames (recall 0.85 on caliscope's cal_cam_1 against 0.99).
The search pass between samples the frame one step finer then (320×240 → 640×480, 427×240 → 640×360): with no
marker to follow and no window, the frame is cheap, and at 320×240 a tag36h11 marker (8 modules across) under
~32 px had under 2 px a module — the target coming back into view at 26–30 px in typical-realism missions waited
for the next frame's full pass.

A window is sized for the marker it expects: OpenCV's size thresholds are fractions of the image it is
given (``minMarkerPerimeterRate`` 0.03 of the larger side), so on a 200-px window they would admit every
speck, and the window would cost more than the full frame did. :attr:`Window.min_perimeter_rate` sets
the window's floor at half the expected marker's perimeter instead.

A marker not found on a frame — the full frame's detector misses a small or blurred marker now and then, and
finds it again the next frame — is not forgotten at once: its track *coasts* for ``COAST_FRAMES`` frames, its
window still searched where constant motion would put it, but its absence sends no frame to the full detector.
Without it, a flickering 15–30 px marker on real video was lost for the 9 frames to the next full-frame pass
(recall 0.77–0.99 on public webcam footage).

A track is a quad, not an id: an id printed more than once (the sim's target wears its id on every face, and
two faces are often in view) is one track per copy, each moving on from the nearest of its id's last quads.
"""

from __future__ import annotations

import functools
from collections import Counter
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import cv2
import numpy as np

from mission.perception_plugins.marker_quads import Box, perimeter, shortest_side, side

MARGIN = 0.4  # a window reaches this many marker sides beyond the predicted quad (the quiet zone, ≤ 0.17, and some)
MIN_PERIMETER_FRACTION = 0.5  # a window's detector keeps quads down to this fraction of the expected perimeter
FULL_FRAME_EVERY = 10  # the sources' default `full_frame_every`: a new marker waits at most 9 frames
COAST_FRAMES = 3  # a marker not found is still looked for in its window this many frames (it flickers)
IDLE_FULL_FRAME_EVERY = 2  # with nothing tracked, the full frame every other frame (see the module)
SEARCH_EVERY = 1  # the search pass runs on every window frame (every third: ~15 % faster, recall 98.6 %)
GUTTER_PX = 8  # each window's border in the mosaic the windows are detected in (_tile)
EDGE_PX = 3  # of which its edge replicated (more drew streaks that lost markers: _tile), the rest flat
MIN_SHRINK = 0.4  # a window is never shrunk further: a pixel of it is 2.5 px of the frame, half the refiner's reach
MIN_WINDOW_PX = 32  # a window is never smaller than this on a side (the detector's own border and kernels)
EXCUSE_MIN_FOUND = 3  # a missed marker is excused (RegionTracker.excuse) only beside this many found as predicted
EXCUSE_REACH = 0.25  # … each within this many of its marker sides of where its motion put it
ALONE_MIN_SIDE_PX = 30.0  # a marker missed in the mosaic is looked for in its window alone from this side (_alone)


@dataclass(frozen=True)
class Window:
    """A region of the frame to detect in, the smallest marker perimeter (px) worth keeping there, and the
    shortest side (px) of the marker expected in it (what the window may be shrunk by: a marker seen
    obliquely is narrow one way, and its modules must stay readable that way)."""

    x0: int
    y0: int
    x1: int
    y1: int
    min_perimeter_px: float
    marker_side_px: float = 0.0  # 0: not known, the window is not shrunk

    @property
    def box(self) -> Box:
        return (self.x0, self.y0, self.x1, self.y1)

    @property
    def min_perimeter_rate(self) -> float:
        """``min_perimeter_px`` as OpenCV's fraction of the window's larger side."""
        return self.min_perimeter_px / max(self.x1 - self.x0, self.y1 - self.y0, 1)

    def overlaps(self, other: Window) -> bool:
        return self.x0 < other.x1 and other.x0 < self.x1 and self.y0 < other.y1 and other.y0 < self.y1

    def union(self, other: Window) -> Window:
        return Window(
            min(self.x0, other.x0),
            min(self.y0, other.y0),
            max(self.x1, other.x1),
            max(self.y1, other.y1),
            min(self.min_perimeter_px, other.min_perimeter_px),
            min(self.marker_side_px, other.marker_side_px),
        )


@dataclass(eq=False)
class _Track:
    marker_id: int
    quad: np.ndarray  # 4×2 px, the last one found
    motion: np.ndarray  # 2, px per frame: how far its centre moved between the last two frames it was found in
    missed: int = 0  # frames since it was last found (a coasting track: its quad is where it would be by now)
    extra: Any = None  # what its source kept of it when last detected (Found.extra), for a frame that follows it

    # Cached: a track is made anew each frame and never changed after, and these are read several times a frame
    # for every tracked marker (numpy's per-call overhead: bench "perception").
    @functools.cached_property
    def centre(self) -> np.ndarray:
        return self.quad.mean(axis=0)

    @functools.cached_property
    def predicted(self) -> np.ndarray:
        """Its quad in the next frame if it moves on as it last moved (4×2 px)."""
        return self.quad + self.motion

    @functools.cached_property
    def _predicted_box(self) -> tuple[float, float, float, float]:
        (x0, y0), (x1, y1) = self.predicted.min(axis=0).tolist(), self.predicted.max(axis=0).tolist()
        return x0, y0, x1, y1

    def leaves(self, width: int, height: int) -> bool:
        """Whether its predicted quad reaches off a `width`×`height` image: a marker leaving the view, which no
        detector finds whole."""
        x0, y0, x1, y1 = self._predicted_box
        return x0 < 0 or y0 < 0 or x1 > width - 1 or y1 > height - 1


@dataclass
class RegionTracker:
    """Where to look in the next frame, from where the markers were: one track per quad, so an id printed more
    than once (a target wearing its id on every face) is one track per copy."""

    full_frame_every: int = FULL_FRAME_EVERY
    tracks: list[_Track] = field(default_factory=list)
    since_full: int = 0  # frames since the last full-frame pass
    full_passes: int = 0
    window_passes: int = 0
    followed: int = 0  # tracked markers found on their predicted quad's edges, with no detector call (_follow)
    rescues: int = 0  # full-frame passes run because a tracked marker was not in its window
    discovered: int = 0  # markers the search pass found between full-frame passes
    leaving: list[_Track] = field(default_factory=list)  # tracks this frame's windows left out (off the edge)
    excused: list[_Track] = field(default_factory=list)  # tracks missed this frame where the rest were found (excuse)
    excused_misses: int = 0  # tracked markers excused from a full-frame pass (excuse)
    unconfirmed: int = 0  # full-frame passes run because the search pass saw a marker its window did not find

    def __post_init__(self) -> None:
        self.since_full = self.full_frame_every - 1  # the first frame is a full-frame pass

    @property
    def idle(self) -> bool:
        """No marker was found last frame: nothing is tracked, or the tracks only coast (see full_frame_due)."""
        return not any(tr.missed == 0 for tr in self.tracks)

    def full_frame_due(self) -> bool:
        """Whether this frame is a full-frame pass (every `full_frame_every`-th frame; with no marker found last
        frame, every IDLE_FULL_FRAME_EVERY-th).

        Tracks that only coast do not count as tracked: each is looked for where its last motion puts it, and a
        marker that vanished for a frame during a fast turn shows again anywhere. On aisle seed 5812 under
        `typical`, a followed target's coasting track kept the full frame away for the three frames it coasted
        while the target, ~70 px from it and under the search pass's floor, was in plain view."""
        every = min(self.full_frame_every, IDLE_FULL_FRAME_EVERY) if self.idle else self.full_frame_every
        return self.since_full + 1 >= every

    def followable(self, width: int, height: int) -> list[_Track]:
        """The tracks a window frame may follow (:func:`_follow`): found last frame, and predicted whole in view."""
        return [tr for tr in self.tracks if tr.missed == 0 and not tr.leaves(width, height)]

    def windows(self, width: int, height: int, followed: Sequence[_Track] = ()) -> list[Window] | None:
        """The windows to detect in this frame for the tracks not `followed` already (none when nothing is
        left to look for: the search pass alone), or None for a full-frame pass (:meth:`full_frame_due`)."""
        if self.full_frame_due():
            return None
        wins: list[Window] = []
        self.leaving = []
        self.excused = []
        for tr in self.tracks:
            if tr.leaves(width, height):
                self.leaving.append(tr)  # predicted partly off the image: not looked for, not missed
                continue
            if any(tr is t for t in followed):
                continue
            win = window_round(tr.quad, tr.motion, width, height, slack_px=tr.missed * side(tr.quad))
            if win is None:
                return None  # tiny: the full frame is as cheap and surer
            wins.append(win)
        return _merged(wins)

    def all_found(self, ids: list[int]) -> bool:
        """Whether a window pass that found `ids` found every marker it looked for (as many copies of each id
        as are tracked, found last frame and not leaving; a coasting track's marker may stay away)."""
        return not self.missing(ids)

    def missing(self, ids: list[int]) -> list[_Track]:
        """The tracks a window pass that found `ids` did not find (of those it had to: see all_found); of an id
        tracked more than once and found fewer times, every copy."""
        live = self._live()
        expected = Counter(tr.marker_id for tr in live)
        found = Counter(ids)
        return [
            tr for tr in live if found[tr.marker_id] < expected[tr.marker_id] and not any(tr is t for t in self.excused)
        ]

    def _live(self) -> list[_Track]:
        """The tracks a window pass has to find: found last frame, and not leaving the view."""
        return [tr for tr in self.tracks if tr.missed == 0 and not any(tr is t for t in self.leaving)]

    def excuse(self, missed: list[_Track], found: Sequence[Found]) -> bool:
        """Excuse the `missed` tracks from the full-frame pass when every other marker tracked last frame was
        `found` where its motion put it, and there were at least EXCUSE_MIN_FOUND of them: the prediction held
        for the scene, so a marker missing from it was not moved out of its window (a board is rigid, a scene
        still) but not detected on this frame — blurred, glared, at the detector's threshold. The full frame then
        misses it too, and a frame that went to it cost the window pass, the full pass and its rescue pass: on
        hand-held webcam video of a ChArUco board (caliscope, 6 fps), a third of the frames. An excused track
        coasts (COAST_FRAMES) as any track the full frame did not find. Whether they were excused."""
        others = [tr for tr in self._live() if not any(tr is t for t in missed)]
        if len(others) < EXCUSE_MIN_FOUND:
            return False
        for tr in others:
            reach = EXCUSE_REACH * side(tr.quad)
            at = tr.predicted.mean(axis=0)
            near = (f for f in found if f.marker_id == tr.marker_id)
            if not any(float(np.linalg.norm(f.quad.mean(axis=0) - at)) <= reach for f in near):
                return False
        self.excused = list(missed)
        self.excused_misses += len(missed)
        return True

    def found(self, quads: np.ndarray, ids: np.ndarray, full: bool, extras: Sequence[Any] | None = None) -> bool:
        """Take this frame's detections (M×4×2, M, and each one's Found.extra); False when a window pass missed
        a tracked marker (the caller then runs the full frame and calls again with ``full=True``)."""
        if not full and not self.all_found([int(i) for i in ids]):
            self.rescues += 1
            return False
        if full:
            self.full_passes += 1
            self.since_full = 0
        else:
            self.window_passes += 1
            self.since_full += 1
        old = list(self.tracks)
        tracks: list[_Track] = []
        for quad, mid, extra in zip(quads, ids, extras if extras is not None else [None] * len(ids), strict=True):
            quad = np.asarray(quad, dtype=np.float64).copy()
            centre = quad.mean(axis=0)
            same = [tr for tr in old if tr.marker_id == int(mid)]
            if len(same) > 1:  # an id printed more than once: the copy nearest where it was going
                prev = min(same, key=lambda tr: float(np.linalg.norm(tr.centre + tr.motion - centre)))
            else:
                prev = same[0] if same else None
            if prev is not None:
                old = [tr for tr in old if tr is not prev]  # each copy moves on from the nearest of its id's quads
            motion = centre - prev.centre if prev is not None else np.zeros(2)
            tracks.append(_Track(int(mid), quad, motion, extra=extra))
        for tr in old:  # not found this frame: looked for a few frames more where it would be, then forgotten
            if tr.missed < COAST_FRAMES and not any(tr is t for t in self.leaving):
                tracks.append(_Track(tr.marker_id, tr.predicted, tr.motion, tr.missed + 1, tr.extra))
        self.tracks = tracks
        return True

    def reset(self) -> None:
        self.tracks.clear()
        self.since_full = self.full_frame_every - 1


def window_round(quad: np.ndarray, motion: np.ndarray, width: int, height: int, slack_px: float = 0.0) -> Window | None:
    """The window where a marker last seen at `quad` (4×2 px), moving `motion` px a frame, is looked for in the
    next frame, reaching `slack_px` further (a coasting track: the longer unseen, the less sure its motion); None
    when it would be under MIN_WINDOW_PX on a side (at the image's edge)."""
    moved = quad + motion
    lo, hi = moved.min(axis=0), moved.max(axis=0)
    reach = MARGIN * float(np.max(hi - lo)) + float(np.abs(motion).max()) + slack_px
    win = Window(
        max(0, int(np.floor(lo[0] - reach))),
        max(0, int(np.floor(lo[1] - reach))),
        min(width, int(np.ceil(hi[0] + reach))),
        min(height, int(np.ceil(hi[1] + reach))),
        MIN_PERIMETER_FRACTION * perimeter(quad),
        shortest_side(quad),
    )
    if win.x1 - win.x0 < MIN_WINDOW_PX or win.y1 - win.y0 < MIN_WINDOW_PX:
        return None
    return win


@dataclass(frozen=True)
class Found:
    """One marker a detector found: its quad (4×2 px, in the image it was given), its id, and what else its
    source keeps of it (the apriltag source: hamming distance and decision margin)."""

    quad: np.ndarray
    marker_id: int
    extra: Any = None
    refined: bool = False  # its corners are final (a followed marker's: follow_quads refined them)

    def moved(self, offset: np.ndarray) -> Found:
        return Found(self.quad + offset, self.marker_id, self.extra, self.refined)


Detect = Callable[[np.ndarray, float | None], list[Found]]  # (grey, min perimeter rate or None) → markers
# the whole frame, cheaply, these windows left out, one sampling step finer or not → markers (QuadDetector.search)
Search = Callable[[np.ndarray, list[Box], bool], list[Found]]
# (grey, predicted quads N×4×2, their ids) → for each, its quad refined onto the frame's edges, or None where the
# refined quad does not hold the id's pattern (see follow)
Follow = Callable[[np.ndarray, np.ndarray, np.ndarray], list[np.ndarray | None]]


@dataclass(frozen=True)
class Shrink:
    """How a source whose refiner finishes the corners at full resolution has its windows searched: each scaled
    down so its marker's narrowest side is `side_px` (a large marker needs no more pixels to be found), and
    those shrunk detected by `detect` (None: by the source's own detector, on one mosaic with the rest)."""

    side_px: float
    detect: Detect | None = None


def detect_tracked(
    grey: np.ndarray,
    tracker: RegionTracker,
    detect: Detect,
    search: Search | None = None,
    shrink: Shrink | None = None,
    recover: Detect | None = None,
    follow: Follow | None = None,
) -> list[Found]:
    """One frame through the tracker: windows where markers were, or the full frame (see the module). On a
    window frame, the tracks `follow` confirms (:func:`_follow`) need no window; `search` (when given) looks
    over the whole frame at reduced resolution for markers that are not tracked yet; each it finds is detected
    again in a window of its own, at full resolution. The
    markers' quads are in the frame's pixels. With `shrink`, windows of large markers are searched scaled
    down (for a source whose refiner finishes the corners at full resolution; :class:`Shrink`). A tracked
    marker the windows missed is looked for in its window alone (:func:`_alone`), by `recover` where given
    (a detector that reads what `detect` may drop), before the frame goes to the full-frame detector."""
    h, w = grey.shape[:2]
    followed: list[Found] = []
    following: list[_Track] = []
    if follow is not None and not tracker.full_frame_due():
        following, followed = _follow(grey, tracker.followable(w, h), follow)
        tracker.followed += len(followed)
    wins = tracker.windows(w, h, following)
    if wins is not None and (wins or followed or search is not None):
        # A window round another marker can hold a followed one too (a ChArUco board's markers are a module
        # or two apart): that is the same marker, not a second copy of its id.
        found = followed + [f for f in _in_windows(grey, wins, detect, shrink) if not _among(f, followed)]
        missed = tracker.missing([f.marker_id for f in found])
        if missed and tracker.excuse(missed, found):
            missed = []
        if missed and recover is not None:
            found += _alone(grey, missed, wins, found, recover, shrink and Shrink(shrink.side_px, recover))
        elif missed:
            found += _alone(grey, missed, wins, found, detect, shrink)
        due = tracker.window_passes % SEARCH_EVERY == 0 or not wins
        new: list[Found] | None = []
        if search is not None and due and tracker.all_found([f.marker_id for f in found]):
            boxes = [_box(f.quad) for f in followed]
            new = _new_markers(grey, wins, found, search, detect, shrink, boxes, finer=tracker.idle)
        if new is None:
            tracker.unconfirmed += 1
        elif tracker.found(*as_arrays(found + new), full=False, extras=[f.extra for f in found + new]):
            tracker.discovered += len(new)
            return found + new
    found = detect(grey, None)
    tracker.found(*as_arrays(found), full=True, extras=[f.extra for f in found])
    return found


def _follow(grey: np.ndarray, tracks: list[_Track], follow: Follow) -> tuple[list[_Track], list[Found]]:
    """The `tracks` that `follow` finds where their motion puts them, and what it found of each.

    A window pass costs a detector call on every window (at 1280×720 with eight 50–80 px markers, ~1.5 ms of
    a ~3.6 ms frame, against OpenCV's ~6 ms for the frame), yet a tracked marker's corners are known to
    within its motion's change since the last frame. So each predicted quad is refined onto the frame's
    edges directly, and kept when the refined quad holds its id's pattern; the rest are looked for in their
    windows as before."""
    if not tracks:
        return [], []
    predicted = np.stack([tr.predicted for tr in tracks])
    quads = follow(grey, predicted, np.array([tr.marker_id for tr in tracks], dtype=np.int64))
    pairs = [(tr, q) for tr, q in zip(tracks, quads, strict=True) if q is not None]
    return [tr for tr, _ in pairs], [Found(q, tr.marker_id, tr.extra, refined=True) for tr, q in pairs]


def _alone(
    grey: np.ndarray,
    missed: list[_Track],
    wins: list[Window],
    found: list[Found],
    detect: Detect,
    shrink: Shrink | None,
) -> list[Found]:
    """The `missed` markers, each looked for again in its window alone, before the frame goes to the full
    detector. In a textured scene a marker's white quiet zone can be ringed by dark texture; where a mosaic's
    neighbouring window closes that ring (the seam between two windows' borders thresholds dark), the ring
    wins OpenCV's candidate group and does not decode (opencv_contrib#2913), though the marker's own window
    alone shows it: at 1280×720 with eight 50–80 px markers, 1 of 70 frames; at 640×480, 35–49 px markers,
    7 of 70.

    Only markers of ALONE_MIN_SIDE_PX and more: a window reaches MARGIN of its marker's side beyond it, and
    for a smaller marker that is less than OpenCV's largest adaptive-threshold window reaches (11 px), so
    alone, with the window's border in that reach, a 20 px marker came back 0.9 px off where the full frame
    had it within 0.3 px. Those go to the full frame, as every miss did before."""
    by_window: dict[int, tuple[Window, set[int]]] = {}  # id(window) → the window, the ids missed in it
    for tr in missed:
        win = _holding(wins, tr)
        if win is not None and shortest_side(tr.quad) >= ALONE_MIN_SIDE_PX:
            by_window.setdefault(id(win), (win, set()))[1].add(tr.marker_id)
    out: list[Found] = []
    for win, ids in by_window.values():
        out += [f for f in _in_windows(grey, [win], detect, shrink) if f.marker_id in ids and not _among(f, found)]
    return out


def _holding(wins: list[Window], tr: _Track) -> Window | None:
    """The window that holds `tr`'s predicted centre."""
    x, y = tr.centre + tr.motion
    return next((win for win in wins if win.x0 <= x < win.x1 and win.y0 <= y < win.y1), None)


def _new_markers(
    grey: np.ndarray,
    wins: list[Window],
    found: list[Found],
    search: Search,
    detect: Detect,
    shrink: Shrink | None,
    followed: list[Box],
    finer: bool = False,
) -> list[Found] | None:
    """Markers `search` finds in `grey` (one sampling step `finer` or not) outside the windows `wins` and the
    `followed` markers' boxes (found already) that are not among `found`, each detected again in its own
    full-resolution window of `grey`; None as soon as one is not found again there: the frame then goes to the
    full detector (on the sim's dark floor a 140 px target, shrunk in its window, lost its group to its white
    quiet zone's contour, opencv_contrib#2913, and was reported on no frame until the next full pass)."""
    h, w = grey.shape[:2]
    new: list[Found] = []
    for candidate in search(grey, [win.box for win in wins] + followed, finer):
        if _among(candidate, found + new):
            continue
        win = window_round(candidate.quad, np.zeros(2), w, h)
        if win is None:
            continue  # at the image's edge: the next full-frame pass has it
        again = [
            f
            for f in _in_windows(grey, [win], detect, shrink)
            if f.marker_id == candidate.marker_id and _same_place(f.quad, candidate.quad)
        ]
        if not again:
            return None  # the rest would be looked for in vain: the full detector has the frame
        new += again
    return new


def _box(quad: np.ndarray) -> Box:
    """The box round a marker's quad that the search pass may leave out: the quad and its quiet zone."""
    lo, hi = quad.min(axis=0), quad.max(axis=0)
    reach = MARGIN * float((hi - lo).max())
    return (int(lo[0] - reach), int(lo[1] - reach), int(hi[0] + reach) + 1, int(hi[1] + reach) + 1)


def _among(f: Found, others: list[Found]) -> bool:
    """Whether `f` is one of `others`: the same id, in the same place."""
    return any(g.marker_id == f.marker_id and _same_place(g.quad, f.quad) for g in others)


def _same_place(a: np.ndarray, b: np.ndarray) -> bool:
    return float(np.linalg.norm(a.mean(axis=0) - b.mean(axis=0))) < 0.125 * max(perimeter(a), perimeter(b))


def _in_windows(grey: np.ndarray, wins: list[Window], detect: Detect, shrink: Shrink | None = None) -> list[Found]:
    """The markers in `wins`, found on a mosaic of the windows side by side (a detector call has a fixed cost,
    ~0.2 ms for OpenCV and ~0.4 ms for AprilTag 3, that eight windows would pay eight times). Each window is
    bordered as :func:`_tile` says, so no quad crosses between two.

    With `shrink`, each window is scaled down so its marker's narrowest side is ``shrink.side_px``; when
    ``shrink.detect`` is given, the shrunk windows are detected by it and those at their own scale (smaller
    markers) by `detect` on a second mosaic: a small marker is then read exactly as the full frame reads it
    (on real video, one threshold window put 14–27 px markers' corners 1.3–2 px further off than the full
    frame did)."""
    if not wins:
        return []
    shrunk: list[tuple[Window, np.ndarray, float]] = []
    native: list[tuple[Window, np.ndarray, float]] = []
    for win in wins:
        crop = grey[win.y0 : win.y1, win.x0 : win.x1]
        scale = 1.0
        if shrink is not None:
            crop, scale = _shrunk(crop, win.marker_side_px, shrink.side_px)
        (shrunk if scale < 1.0 and shrink is not None and shrink.detect is not None else native).append(
            (win, crop, scale)
        )
    out = _in_mosaic(native, detect)
    if shrunk:
        assert shrink is not None and shrink.detect is not None
        out += _in_mosaic(shrunk, shrink.detect)
    return out


def _in_mosaic(tiles: list[tuple[Window, np.ndarray, float]], detect: Detect) -> list[Found]:
    """The markers in (window, its crop, the crop's scale) tiles, by one call of `detect` on them side by side;
    quads in the frame's pixels."""
    if not tiles:
        return []
    placed: list[tuple[Window, float, int]] = []  # window, scale, left edge of its crop in the mosaic
    floor_px = np.inf
    x = 0
    for win, crop, scale in tiles:
        placed.append((win, scale, x + GUTTER_PX))
        x += crop.shape[1] + 2 * GUTTER_PX
        floor_px = min(floor_px, win.min_perimeter_px * scale)
    height = max(crop.shape[0] for _, crop, _ in tiles) + 2 * GUTTER_PX
    mosaic = np.hstack([_tile(crop, height) for _, crop, _ in tiles])
    out: list[Found] = []
    for f in detect(mosaic, floor_px / max(mosaic.shape)):
        cx = float(f.quad[:, 0].mean())
        for win, scale, left in placed:
            tile_w = (win.x1 - win.x0) * scale
            if left - GUTTER_PX <= cx < left + tile_w + GUTTER_PX:
                local = f.quad - np.array([left, GUTTER_PX], dtype=np.float64)
                frame_px = (local + 0.5) / scale - 0.5 + np.array([win.x0, win.y0], dtype=np.float64)
                out.append(Found(frame_px, f.marker_id, f.extra))
                break
    return out


def _tile(crop: np.ndarray, height: int) -> np.ndarray:
    """`crop` bordered for a mosaic `height` px tall: its edge replicated EDGE_PX (so the adaptive threshold near
    the edge sees about what it sees in the frame: a 20 px marker is read as the full frame reads it), then
    flat at its own mean grey to GUTTER_PX, and flat down to the mosaic's height.

    Not replicated all the way: the replicated rows of a short window (padded to the mosaic's height) or the
    gutters of two neighbours drew dark streaks that closed a contour round a marker's white quiet zone,
    which then won OpenCV's candidate group and did not decode (opencv_contrib#2913). 50–61 px markers the
    full frame found were lost in their windows, sending 7 of 90 frames at 1280×720 with eight markers to the
    full detector; replicating 6 px lost them too, 3 px none."""
    edged = cv2.copyMakeBorder(crop, EDGE_PX, EDGE_PX, EDGE_PX, EDGE_PX, cv2.BORDER_REPLICATE)
    flat = GUTTER_PX - EDGE_PX
    return cv2.copyMakeBorder(
        edged, flat, height - edged.shape[0] - flat, flat, flat, cv2.BORDER_CONSTANT, value=int(crop[::4, ::4].mean())
    )


def _shrunk(crop: np.ndarray, expected_side: float, side_px: float) -> tuple[np.ndarray, float]:
    """`crop` scaled so a marker `expected_side` px wide becomes `side_px` wide (never enlarged), and the scale.

    In two steps, because INTER_AREA at a fractional scale costs ~150 µs a window, more than the detection
    it feeds: INTER_AREA by a whole number (it then averages whole blocks: ~10 µs) to within 2× of the size,
    then INTER_LINEAR for the rest (a scale in (0.5, 1], where it does not alias). The marker must come out
    the same size every time: OpenCV's one threshold window (QuadDetector.window) reads markers of that size
    and misses some at half of it."""
    side_px = max(side_px, MIN_SHRINK * expected_side)
    step = max(1, int(expected_side // side_px))
    if step > 1:
        crop = cv2.resize(crop, None, fx=1 / step, fy=1 / step, interpolation=cv2.INTER_AREA)
    rest = min(1.0, side_px * step / max(expected_side, 1.0))
    if rest < 1.0:
        crop = cv2.resize(crop, None, fx=rest, fy=rest, interpolation=cv2.INTER_LINEAR)
    return crop, rest / step


def as_found(quads: np.ndarray, ids: np.ndarray) -> list[Found]:
    """A detector's (N×4×2 quads, N ids) as the tracker takes them."""
    return [Found(q, int(i)) for q, i in zip(quads, ids, strict=True)]


def as_arrays(found: list[Found]) -> tuple[np.ndarray, np.ndarray]:
    """The tracker's markers as (N×4×2 quads, N ids)."""
    quads = np.stack([f.quad for f in found]) if found else np.zeros((0, 4, 2))
    return quads, np.array([f.marker_id for f in found], dtype=np.int64)


def _merged(wins: list[Window]) -> list[Window]:
    """Overlapping windows joined (so a marker is never cut by another's window edge), until none overlap."""
    out = list(wins)
    merged = True
    while merged:
        merged = False
        for i in range(len(out)):
            for j in range(i + 1, len(out)):
                if out[i].overlaps(out[j]):
                    out[i] = out[i].union(out.pop(j))
                    merged = True
                    break
            if merged:
                break
    return out
