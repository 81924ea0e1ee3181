"""`mission detect IMAGE... --source NAME`: run one perception source over image files.

All images go through ONE source instance, in the order given, as consecutive frames (stamps 1/30 s
apart), so per-marker temporal logic (pose flip disambiguation) applies across a sequence. A file that
cannot be read is reported on stderr and skipped; the exit code is then 1.

The camera model is ``--intrinsics fx,fy,cx,cy`` or ``--calibration FILE`` (mission/app/calibration.py).
A source that declares what a frame must carry (``requires``, e.g. the VLM's depth) gets it or the
command says what is missing before reading any image: ``--depth FILE`` gives one depth image per IMAGE.
A source that answers off the tick (``answer``, the VLM) is asked about each image and waited for; when it
finds nothing, stderr says why (its ``status()["state"]``: rate limited, no depth, …), never a silent empty
result.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import yaml

from mission.app.calibration import load_calibration
from mission.core.config import merge_mappings
from mission.core.errors import ConfigError, MissionError
from mission.core.types import CameraIntrinsics, Detection, Frame
from mission.perception_plugins import registry
from mission.sim.quiet import quiet

FRAME_PERIOD_S = 1.0 / 30.0
ANSWER_TIMEOUT_S = 60.0  # how long to wait for a source that answers off the tick (a remote model)
DEPTH_FORMATS = "a 16-bit PNG/TIFF in millimetres, or a .npy or 32-bit float TIFF in metres"


def parse_set(items: list[str]) -> dict[str, Any]:
    """`key=value` pairs with YAML values (`marker_size_m=0.15`, `allowed_ids=[1,2]`) → params dict. A dotted
    key sets a key of a params section (`gemini.model=…` is `gemini: {model: …}`, the rest of it kept)."""
    out: dict[str, Any] = {}
    for item in items:
        key, sep, raw = item.partition("=")
        key = key.strip()
        if not sep or not key or any(not part for part in key.split(".")):
            raise ConfigError(f"expected KEY=VALUE, got {item!r}", key="--set")
        try:
            value = yaml.safe_load(raw) if raw.strip() else None
        except yaml.YAMLError as err:
            why = str(err).splitlines()[0]
            raise ConfigError(f"value {raw!r} is not valid YAML ({why})", key=f"--set {key}") from None
        for part in reversed(key.split(".")[1:]):
            value = {part: value}
        out = merge_mappings(out, {key.split(".")[0]: value})
    return out


def parse_intrinsics(text: str | None, width: int, height: int) -> CameraIntrinsics | None:
    """`fx,fy,cx,cy` → CameraIntrinsics for an image of this size (None when not given)."""
    if text is None:
        return None
    parts = [p.strip() for p in text.split(",")]
    try:
        vals = [float(p) for p in parts]
    except ValueError:
        vals = []
    if len(vals) != 4 or not all(math.isfinite(v) for v in vals) or vals[0] <= 0 or vals[1] <= 0:
        raise ConfigError(f"expected four numbers fx,fy,cx,cy with fx, fy > 0, got {text!r}", key="--intrinsics")
    fx, fy, cx, cy = vals
    return CameraIntrinsics(fx=fx, fy=fy, cx=cx, cy=cy, width=width, height=height)


def read_image(path: str) -> np.ndarray:
    """The image at `path` as BGR or mono uint8; OSError/ValueError with the reason when it cannot be read."""
    p = Path(path)
    if not p.exists():
        raise OSError("no such file")
    if not p.is_file():
        raise OSError("not a file")
    data = np.fromfile(str(p), dtype=np.uint8)  # fromfile + imdecode: works for any path, reads once
    if data.size == 0:
        raise ValueError("empty file")
    try:
        with quiet():  # libpng / libjpeg print their own complaints to fd 2; the user gets our one line instead
            img = cv2.imdecode(data, cv2.IMREAD_UNCHANGED)
    except cv2.error as err:  # e.g. a header claiming more pixels than OpenCV's CV_IO_MAX_IMAGE_PIXELS
        why = "larger than OpenCV's pixel limit" if "MAX_IMAGE_PIXELS" in str(err) else "decoder error"
        raise ValueError(f"not a decodable image: {why}") from None
    if img is None:
        raise ValueError("not a decodable image")
    if img.dtype != np.uint8:  # 16-bit PNG/TIFF: scale to 8 bits as a camera driver would
        img = cv2.convertScaleAbs(img, alpha=255.0 / max(1.0, float(img.max())))
    if img.ndim == 3 and img.shape[2] == 4:
        img = cv2.cvtColor(img, cv2.COLOR_BGRA2BGR)
    return img


def read_depth(path: str) -> np.ndarray:
    """A depth image as H×W float32 metres (NaN = no return); OSError/ValueError with the reason."""
    p = Path(path)
    if not p.is_file():
        raise OSError("no such file" if not p.exists() else "not a file")
    if p.suffix.lower() == ".npy":
        try:
            arr = np.load(p, allow_pickle=False)
        except (OSError, ValueError) as err:
            raise ValueError(f"not a readable .npy array ({err})") from None
    else:
        with quiet():
            arr = cv2.imread(str(p), cv2.IMREAD_UNCHANGED | cv2.IMREAD_ANYDEPTH)
        if arr is None:
            raise ValueError(f"not a decodable depth image (expected {DEPTH_FORMATS})")
    arr = np.asarray(arr)
    if arr.ndim != 2:
        raise ValueError(f"depth must be one channel (H×W), got shape {tuple(arr.shape)}")
    if arr.dtype == np.uint8:
        raise ValueError(f"an 8-bit image is not depth (expected {DEPTH_FORMATS})")
    if np.issubdtype(arr.dtype, np.integer):  # millimetres, 0 = no return
        depth = arr.astype(np.float32) / 1000.0
        depth[arr == 0] = np.nan
        return depth
    depth = arr.astype(np.float32)
    depth[~np.isfinite(depth) | (depth <= 0)] = np.nan
    return depth


def _table(path: str, img: np.ndarray, dets: list[Detection]) -> str:
    h, w = img.shape[:2]
    lines = [f"{path}  ({w}×{h}): {len(dets)} detection{'s' if len(dets) != 1 else ''}"]
    if dets:
        lines.append(f"  {'id':>5} {'label':<12} {'dist m':>7} {'x':>7} {'y':>7} {'z':>7} {'conf':>5} {'reproj px':>9}")
        for d in dets:
            x, y, z = (float(v) for v in d.position)
            mid = "-" if d.marker_id is None else str(d.marker_id)
            label = d.label or "-"
            lines.append(
                f"  {mid:>5} {label:<12} {d.distance:7.3f} {x:7.3f} {y:7.3f} {z:7.3f} "
                f"{d.confidence:5.2f} {d.reprojection_error:9.3f}"
            )
        if any(d.extra.get("intrinsics") == "fallback" for d in dets):
            lines.append("  (no --intrinsics: fallback pinhole fx = fy = 0.9·width; distances are approximate)")
    return "\n".join(lines)


def _requirements(args: argparse.Namespace, cls: type) -> set[str]:
    """What the source needs in a frame; a MissionError saying how to give it when the command line does not."""
    requires = set(getattr(cls, "requires", ()))
    if "depth" in requires and not args.depth:
        raise MissionError(
            f"--source {args.source} needs a depth image for each IMAGE (it places what it finds in 3D with "
            f"depth): give --depth FILE ({DEPTH_FORMATS}), one per IMAGE in the same order"
        )
    if args.depth and len(args.depth) != len(args.images):
        raise MissionError(
            f"--depth: {len(args.depth)} depth image(s) for {len(args.images)} image(s); give one "
            "per IMAGE, in the same order"
        )
    return requires


def _intrinsics(
    args: argparse.Namespace, calibration: CameraIntrinsics | None, w: int, h: int, requires: set[str]
) -> CameraIntrinsics | None:
    if calibration is not None:
        problem = calibration.problem(w, h)
        if problem is not None:
            raise ValueError(f"--calibration {args.calibration}: {problem}")
        return calibration
    given = parse_intrinsics(args.intrinsics, w, h)
    if given is None and "intrinsics" in requires:  # the source cannot fall back by itself
        return CameraIntrinsics.fallback(w, h)
    return given


def _detect(source: object, frame: Frame) -> list[Detection]:
    """The source's detections of `frame`; a source that answers off the tick is given time to answer."""
    answer = getattr(source, "answer", None)
    if callable(answer):  # it asks a model: ask about this image and wait for the reply
        return answer(frame, ANSWER_TIMEOUT_S)
    return source.process(frame)  # type: ignore[attr-defined]


def _why_nothing(source: object) -> str | None:
    status = getattr(source, "status", None)
    if status is None:
        return None
    state = status().get("state")
    return None if state in (None, "idle", "latched") else str(state).replace("_", " ")


def main(args: argparse.Namespace) -> int:
    params = parse_set(args.set)
    if args.intrinsics is not None and args.calibration is not None:
        raise ConfigError("give --intrinsics or --calibration, not both", key="--calibration")
    if args.intrinsics is not None:
        parse_intrinsics(args.intrinsics, 1, 1)  # fail on a bad value before touching any file
    calibration = load_calibration(args.calibration) if args.calibration is not None else None
    cls = registry.load_class(args.source)
    requires = _requirements(args, cls)
    params = {**dict(getattr(cls, "batch_params", {})), **params}
    try:
        source = cls(params, name=args.source)
    except ConfigError as err:
        raise err.within("--set", sep=" ") from None
    failures = 0
    try:
        for i, path in enumerate(args.images):
            which = path
            try:
                img = read_image(path)
                which = args.depth[i] if args.depth else path
                depth = read_depth(which) if args.depth else None
            except (OSError, ValueError) as err:
                kind = "depth image" if which != path else "image"
                print(f"mission: error: {which}: cannot read {kind} ({err})", file=sys.stderr)
                failures += 1
                continue
            h, w = img.shape[:2]
            try:
                if depth is not None and depth.shape != (h, w):
                    raise ValueError(f"depth {args.depth[i]} is {depth.shape[1]}×{depth.shape[0]}, the image {w}×{h}")
                intrinsics = _intrinsics(args, calibration, w, h, requires)
                frame = Frame(
                    image=img,
                    stamp=i * FRAME_PERIOD_S,
                    frame_id="camera_optical_frame",
                    intrinsics=intrinsics,
                    depth=depth,
                )
                dets = _detect(source, frame)
            except ValueError as err:
                print(f"mission: error: {path}: {err}", file=sys.stderr)
                failures += 1
                continue
            if not dets:
                why = _why_nothing(source)
                if why is not None:
                    print(f"mission: {path}: {args.source}: nothing found ({why})", file=sys.stderr)
            if args.json:
                rec = {"image": path, "width": w, "height": h, "detections": [d.to_json() for d in dets]}
                print(json.dumps(rec), flush=True)
            else:
                print(_table(path, img, dets), flush=True)
    finally:
        source.close()
    return 1 if failures else 0
