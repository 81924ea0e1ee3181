"""Tracking mode on real footage (issue 34): the ``aruco`` source with ``tracking: true`` on a sequence of real
frames, against OpenCV's default detector on the whole frame and against the same source with tracking off.

The rendered sequences of bench/tracking_bench.py have exact truth but a renderer's blur, noise and motion;
real video has a real lens, rolling shutter, compression and a hand moving the board. Public footage is
fetched onto the measuring machine and never committed, so the measurement runs on whatever the command line
names, as one sequence, in the order a camera would deliver it:

    python -m bench.real_sequences FRAMES... --dictionary DICT_4X4_1000 \
        [--board 4x5 --square-m 0.054 --marker-m 0.0405] [--invert] [--every N] [--json OUT]

FRAMES are image files, directories (their images and videos, sorted by name) or videos (.mp4 .avi .mov .mkv,
every ``--every``-th frame kept). With ``--board`` each frame's truth is the ChArUco board's saddle points
(bench/charuco_truth.py), so corner accuracy is measured against something no marker detector made; without
it only recall, the new-marker wait and speed are.

Both comparisons run through tracking_bench.track_sequence (calls interleaved per frame, so both sides see the
same machine load), so the figures mean what the rendered benchmark's mean. On top of them, every marker the
baseline found that tracking did not, and every marker tracking placed > 0.5 px worse than the baseline did
(against the truth), is listed with its frame — the cases a mean hides.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from bench.charuco_truth import IMAGE_SUFFIXES, Board, charuco_truth, parse_board
from bench.marker_sequences import SequenceFrame
from bench.tracking_bench import Detect, _errors, _raw_aruco, _source, track_sequence
from mission.core.types import CameraIntrinsics, Frame
from mission.perception_plugins import marker_dictionaries
from mission.perception_plugins.aruco import ArucoSource

VIDEO_SUFFIXES = (".mp4", ".avi", ".mov", ".mkv")
WORSE_PX = 0.5  # tracking's worst corner of a marker this much beyond the baseline's: listed as a case
DEFAULT_MARKER_M = 0.05  # the source's marker size without --marker-m: only the pose needs it, and no figure here does


class InputError(Exception):
    """A frame source that cannot be read: one line naming it. A sequence with a hole in it is no longer what
    the camera delivered (the tracker would see a jump that never happened), so nothing is measured."""


@dataclass
class Sequence:
    """The frames, each with a label saying where it came from (``file`` or ``file#index`` for a video)."""

    frames: list[SequenceFrame] = field(default_factory=list)
    labels: list[str] = field(default_factory=list)


def frame_files(args: list[str]) -> list[Path]:
    """The image and video files the arguments name, in order (a directory: its images and videos, sorted by
    name, as a camera's numbered frames are)."""
    files: list[Path] = []
    usable = IMAGE_SUFFIXES + VIDEO_SUFFIXES
    for arg in args:
        p = Path(arg)
        if p.is_dir():
            found = sorted(f for f in p.iterdir() if f.is_file() and f.suffix.lower() in usable)
            if not found:
                raise InputError(f"{p}: no image or video files ({', '.join(usable)}) in this directory")
            files += found
        elif p.is_file():
            files.append(p)
        else:
            raise InputError(f"{p}: no such file or directory")
    return files


def _video_frames(path: Path, every: int) -> Iterator[tuple[str, np.ndarray]]:
    """Every `every`-th frame of a video (BGR), labelled ``path#index`` (the index in the whole video)."""
    cap = cv2.VideoCapture(str(path))
    if not cap.isOpened():
        raise InputError(f"{path}: cannot be opened as a video")
    n = 0
    try:
        index = 0
        while True:
            ok, image = cap.read()
            if not ok:
                break
            if index % every == 0:
                n += 1
                yield f"{path}#{index}", image
            index += 1
    finally:
        cap.release()
    if n == 0:
        raise InputError(f"{path}: no frame could be decoded")


def raw_frames(files: list[Path], every: int) -> Iterator[tuple[str, np.ndarray]]:
    """(label, BGR image) for every frame of `files`, in order."""
    for p in files:
        if p.suffix.lower() in VIDEO_SUFFIXES:
            yield from _video_frames(p, every)
            continue
        image = cv2.imread(str(p), cv2.IMREAD_COLOR)  # always 8-bit BGR, whatever the file holds
        if image is None or image.size == 0:
            raise InputError(f"{p}: cannot be read as an image")
        yield str(p), image


def load_sequence(files: list[Path], every: int, invert: bool, board: Board | None) -> Sequence:
    """The frames (negated when `invert`: a board printed white-on-black reads as a normal one) and each one's
    truth (empty without a board, or where too little of it is seen). Every frame must be the first one's size:
    a camera's does not change, and the tracker's windows would be meaningless if it did."""
    seq = Sequence()
    size: tuple[int, int] | None = None
    for label, image in raw_frames(files, every):
        if size is None:
            size = image.shape[:2]
        elif image.shape[:2] != size:
            h, w = image.shape[:2]
            raise InputError(f"{label}: {w}×{h}, but the sequence started at {size[1]}×{size[0]}")
        if invert:
            image = 255 - image
        grey = cv2.cvtColor(image, cv2.COLOR_BGR2GRAY)
        truth = charuco_truth(grey, board) if board is not None else {}
        seq.frames.append(SequenceFrame(np.ascontiguousarray(image), truth))
        seq.labels.append(label)
    return seq


class _RecordingSource:
    """Stands in for the tracked source inside track_sequence: passes each frame on and keeps what it found and
    whether the frame took a full-frame pass, so each miss can be placed and explained afterwards. Its own cost
    (a dict per frame) is microseconds against the milliseconds measured."""

    def __init__(self, source: ArucoSource) -> None:
        self.source = source
        self.found: list[dict[int, np.ndarray]] = []
        self.full: list[bool] = []

    @property
    def tracker(self) -> Any:
        return self.source.tracker

    def process(self, frame: Frame) -> list[Any]:
        before = self.source.tracker.full_passes
        detections = self.source.process(frame)
        self.full.append(self.source.tracker.full_passes > before)
        self.found.append({d.marker_id: d.corners for d in detections})
        return detections


def _recording(detect: Detect, found: list[dict[int, np.ndarray]]) -> Detect:
    """The baseline, keeping each frame's markers in `found`."""

    def run(grey: np.ndarray, frame: Frame) -> dict[int, np.ndarray]:
        markers = detect(grey, frame)
        found.append(markers)
        return markers

    return run


def _worst(corners: np.ndarray, truth: np.ndarray) -> float:
    """A marker's worst corner against its truth, as track_sequence measures it."""
    return _errors({0: np.asarray(corners, dtype=np.float64).reshape(4, 2)}, {0: truth})[0]


def _side(corners: np.ndarray) -> float:
    """A quad's shortest side (px): what decides whether a pass at reduced resolution can see the marker."""
    q = np.asarray(corners, dtype=np.float64).reshape(4, 2)
    return float(np.linalg.norm(q - np.roll(q, -1, axis=0), axis=1).min())


def cases(
    seq: Sequence, mine: _RecordingSource, base: list[dict[int, np.ndarray]], board_ids: set[int] | None
) -> dict[str, Any]:
    """Per frame: markers the baseline found and tracking did not (and why, as far as the tracker tells), markers
    tracking found and the baseline did not, and markers tracking placed > WORSE_PX worse than the baseline.

    With a board (`board_ids`), also the recall of the board's markers alone: an id the baseline reports that
    the board does not carry is a false detection (OpenCV decodes one now and then from a 1,000-id dictionary on
    a 6 px speck), and track_sequence's recall counts tracking's not repeating it as a miss.

    Also the longest run of frames in which the baseline kept finding a marker tracking did not report: what
    ``full_frame_every`` bounds. track_sequence's new-marker wait runs on across frames where the baseline lost
    the marker too, so on real footage, where a marker at the edge of detectability flickers, it can be far
    longer than anything tracking did wrong."""
    missed: list[dict[str, Any]] = []
    worse: list[dict[str, Any]] = []
    extra = 0
    run: dict[int, int] = {}  # marker → frames in a row the baseline had it and tracking did not
    longest = 0
    on_board = found_on_board = off_board = 0
    for i, (sf, found, ref) in enumerate(zip(seq.frames, mine.found, base, strict=True)):
        extra += len(found.keys() - ref.keys())
        if board_ids is not None:
            on_board += len(ref.keys() & board_ids)
            found_on_board += len(ref.keys() & board_ids & found.keys())
            off_board += len(ref.keys() - board_ids)
        run = {m: run.get(m, 0) + 1 for m in ref.keys() - found.keys()}
        longest = max([longest, *run.values()])
        for m in sorted(ref.keys() - found.keys()):
            if board_ids is not None and m not in board_ids:
                why = "not on the board: the baseline's false detection"
            elif mine.full[i]:
                why = "full-frame pass did not find it"
            elif i > 0 and m in mine.found[i - 1]:
                why = "tracked last frame, window pass did not find it"
            else:
                why = "not tracked: search pass did not find it, waiting for a full-frame pass"
            err = round(_worst(ref[m], sf.truth[m]), 3) if m in sf.truth else None
            missed.append(
                {"frame": i, "label": seq.labels[i], "marker_id": m, "why": why, "side_px": round(_side(ref[m]), 1),
                 "baseline_worst_px": err}
            )  # fmt: skip
        for m in sorted(ref.keys() & found.keys() & sf.truth.keys()):
            a, b = _worst(found[m], sf.truth[m]), _worst(ref[m], sf.truth[m])
            if a > b + WORSE_PX:
                worse.append(
                    {"frame": i, "label": seq.labels[i], "marker_id": m, "side_px": round(_side(ref[m]), 1),
                     "tracked_worst_px": round(a, 3), "baseline_worst_px": round(b, 3), "full_pass": mine.full[i]}
                )  # fmt: skip
    return {
        "missed": missed,
        "less_accurate": worse,
        "tracked_only": extra,
        "longest_miss_run_frames": longest,
        "recall_on_board": round(found_on_board / on_board, 4) if on_board else None,
        "baseline_off_board": off_board if board_ids is not None else None,
    }


def miss_runs(missed: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """The misses grouped into runs: the same marker, missed for the same reason, in consecutive frames (a
    marker waiting nine frames for a full-frame pass is one line, not nine)."""
    runs: list[dict[str, Any]] = []
    open_runs: dict[tuple[int, str], dict[str, Any]] = {}
    for c in missed:
        key = (c["marker_id"], c["why"])
        r = open_runs.get(key)
        if r is not None and r["last"] == c["frame"] - 1:
            r["last"] = c["frame"]
            r["sides"].append(c["side_px"])
            continue
        r = {**c, "first": c["frame"], "last": c["frame"], "sides": [c["side_px"]]}
        open_runs[key] = r
        runs.append(r)
    return sorted(runs, key=lambda r: (r["first"], r["marker_id"]))


COMPARISONS = (("opencv_default", "OpenCV default, full frame"), ("tracking_off", "aruco, tracking off"))


def measure(seq: Sequence, dictionary: str, marker_m: float, board: Board | None = None) -> dict[str, Any]:
    """track_sequence twice, each with a fresh tracked source: against OpenCV's default ArucoDetector on the
    whole frame (the issue's baseline) and against our source with tracking off (what tracking itself costs or
    saves, the corner refinement being the same on both sides)."""
    h, w = seq.frames[0].image.shape[:2]
    k = CameraIntrinsics.fallback(w, h)  # nothing measured here depends on the pose, so no calibration is needed
    params = {"dictionary": dictionary, "marker_size_m": marker_m}
    baselines: dict[str, Detect] = {
        "opencv_default": _raw_aruco(getattr(cv2.aruco, dictionary)),
        "tracking_off": _source(ArucoSource(params)),
    }
    out: dict[str, Any] = {}
    for key, baseline in baselines.items():
        tracked = ArucoSource({**params, "tracking": True})
        mine = _RecordingSource(tracked)
        base: list[dict[int, np.ndarray]] = []
        result = track_sequence(seq.frames, k, mine, _recording(baseline, base))
        tracked.close()
        board_ids = None if board is None else {int(i) for i in board.opencv().getIds().ravel()}
        out[key] = {**result, **cases(seq, mine, base, board_ids)}
    return out


def _cell(value: Any, unit: str = "") -> str:
    return "–" if value is None else f"{value}{unit}"


def report(seq: Sequence, summary: dict[str, Any]) -> list[str]:
    """One table, tracking against each baseline in a column, then every listed case."""
    h, w = seq.frames[0].image.shape[:2]
    with_truth = sum(1 for f in seq.frames if f.truth)
    lines = [
        f"frames: {len(seq.frames)} at {w}×{h}; with board truth: {with_truth} "
        f"({sum(len(f.truth) for f in seq.frames)} markers)",
        f"{'aruco tracking on, against':42}" + "".join(f"{label:>28}" for _, label in COMPARISONS),
    ]
    r = [summary[key] for key, _ in COMPARISONS]

    def row(label: str, cell: Any) -> None:
        lines.append(f"{label:42}" + "".join(f"{cell(x):>28}" for x in r))

    row("markers the baseline found", lambda x: x["markers_baseline"])
    row("mean ms, tracked / baseline", lambda x: f"{x['tracked_ms']:.2f} / {x['baseline_ms']:.2f}")
    row("median ms, tracked / baseline", lambda x: f"{x['tracked_median_ms']:.2f} / {x['baseline_median_ms']:.2f}")
    row("speed-up (means)", lambda x: _cell(x["speedup"], "×"))
    row("recall", lambda x: _cell(x["recall"]))
    if r[0]["recall_on_board"] is not None:
        row("recall of the board's markers", lambda x: _cell(x["recall_on_board"]))
        row("baseline's ids not on the board", lambda x: x["baseline_off_board"])
    row("new-marker wait, max frames", lambda x: x["new_marker_wait_max_frames"])
    row("new markers left unfound", lambda x: f"{x['new_markers_unfound']} of {x['new_markers']}")
    row("longest miss run, frames", lambda x: x["longest_miss_run_frames"])
    if with_truth:
        row(
            "corner p95 px, tracked / baseline",
            lambda x: f"{_cell(x['corner_p95_tracked_px'])} / {_cell(x['corner_p95_baseline_px'])}",
        )
        row(
            "corner worst px, tracked / baseline",
            lambda x: f"{_cell(x['corner_max_tracked_px'])} / {_cell(x['corner_max_baseline_px'])}",
        )
    row("full / window passes", lambda x: f"{x['full_passes']} / {x['window_passes']}")
    row("markers only tracking found", lambda x: x["tracked_only"])
    row("missed / > 0.5 px less accurate", lambda x: f"{len(x['missed'])} / {len(x['less_accurate'])}")
    for (_, label), x in zip(COMPARISONS, r, strict=True):
        for c in miss_runs(x["missed"]):
            frames = f"frame {c['first']}" if c["first"] == c["last"] else f"frames {c['first']}–{c['last']}"
            lines.append(
                f"  vs {label}: {frames} ({c['label']}): marker {c['marker_id']} "
                f"({min(c['sides']):.0f}–{max(c['sides']):.0f} px) missed: {c['why']}"
            )
        for c in x["less_accurate"]:
            lines.append(
                f"  vs {label}: frame {c['frame']} ({c['label']}): marker {c['marker_id']} ({c['side_px']:.0f} px) "
                f"worst corner {c['tracked_worst_px']} px tracked, {c['baseline_worst_px']} px baseline"
                f"{' (full-frame pass)' if c['full_pass'] else ' (window pass)'}"
            )
    return lines


def main(argv: list[str] | None = None) -> int:
    """Measure the sequence the arguments name; print the table (and write the figures as JSON with
    ``--json``). Exit 0, or 2 with one line on stderr when the input or an option is unusable."""
    ap = argparse.ArgumentParser(
        prog="python -m bench.real_sequences",
        description="aruco tracking mode on a real sequence: against OpenCV's default detector and tracking off",
    )
    ap.add_argument("frames", nargs="+", metavar="FRAMES", help="images, directories of them, or videos: one sequence")
    ap.add_argument("--dictionary", required=True, help="an OpenCV predefined dictionary, e.g. DICT_4X4_1000")
    ap.add_argument("--board", type=parse_board, metavar="COLSxROWS", help="a ChArUco board's squares: corner truth")
    ap.add_argument("--square-m", type=float, help="with --board: a chessboard square's side")
    ap.add_argument("--marker-m", type=float, help="with --board: a marker's side (same unit as --square-m)")
    ap.add_argument("--every", type=int, default=1, metavar="N", help="videos: keep every Nth frame (default 1)")
    ap.add_argument("--invert", action="store_true", help="negate every frame first (a board printed inverted)")
    ap.add_argument("--json", type=Path, metavar="OUT", help="also write the figures and every case here")
    args = ap.parse_args(argv)

    def fail(message: str) -> int:
        print(f"real_sequences: {message}", file=sys.stderr)
        return 2

    dictionary = marker_dictionaries.canonical_name(args.dictionary)
    if dictionary is None:
        return fail(f"--dictionary {args.dictionary}: unknown; one of {', '.join(marker_dictionaries.PREDEFINED)}")
    if args.every < 1:
        return fail(f"--every {args.every}: must be 1 or more")
    board = None
    if args.board is not None:
        if args.square_m is None or args.marker_m is None:
            return fail("--board needs --square-m and --marker-m")
        if not 0 < args.marker_m < args.square_m:
            return fail(f"--marker-m {args.marker_m}: must be > 0 and smaller than --square-m {args.square_m}")
        board = Board(args.board, args.square_m, args.marker_m, dictionary)
    try:
        seq = load_sequence(frame_files(args.frames), args.every, args.invert, board)
    except InputError as err:
        return fail(str(err))
    if not seq.frames:
        return fail("no frames: nothing measured")

    summary = measure(seq, dictionary, args.marker_m or DEFAULT_MARKER_M, board)
    print("\n".join(report(seq, summary)))
    if args.json is not None:
        h, w = seq.frames[0].image.shape[:2]
        out = {
            "inputs": args.frames, "frames": len(seq.frames), "resolution": f"{w}x{h}", "every": args.every,
            "invert": args.invert, "dictionary": dictionary,
            "board": None if board is None else {"squares": list(board.squares), "square_m": board.square_m,
                                                 "marker_m": board.marker_m},
            "frames_with_truth": sum(1 for f in seq.frames if f.truth), **summary,
        }  # fmt: skip
        args.json.write_text(json.dumps(out, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
