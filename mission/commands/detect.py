"""`mission detect IMAGE... --source NAME`: run one perception source over image files.

All images go through ONE source instance, in the order given, as consecutive frames (stamps 1/30 s
apart), so per-marker temporal logic (pose flip disambiguation) applies across a sequence. A file that
cannot be read is reported on stderr and skipped; the exit code is then 1.
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

from mission.core.config import merge_mappings
from mission.core.errors import ConfigError
from mission.core.types import CameraIntrinsics, Detection, Frame
from mission.perception_plugins import registry
from mission.sim.quiet import quiet

FRAME_PERIOD_S = 1.0 / 30.0


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


def _table(path: str, img: np.ndarray, dets: list[Detection]) -> str:
    h, w = img.shape[:2]
    lines = [f"{path}  ({w}×{h}): {len(dets)} detection{'s' if len(dets) != 1 else ''}"]
    if dets:
        lines.append(f"  {'id':>5} {'label':<12} {'dist m':>7} {'x':>7} {'y':>7} {'z':>7} {'conf':>5} {'reproj px':>9}")
        for d in dets:
            x, y, z = (float(v) for v in d.position)
            mid = "-" if d.marker_id is None else str(d.marker_id)
            label = d.label or "-"
            lines.append(f"  {mid:>5} {label:<12} {d.distance:7.3f} {x:7.3f} {y:7.3f} {z:7.3f} "
                         f"{d.confidence:5.2f} {d.reprojection_error:9.3f}")  # fmt: skip
        if any(d.extra.get("intrinsics") == "fallback" for d in dets):
            lines.append("  (no --intrinsics: fallback pinhole fx = fy = 0.9·width; distances are approximate)")
    return "\n".join(lines)


def main(args: argparse.Namespace) -> int:
    params = parse_set(args.set)
    if args.intrinsics is not None:
        parse_intrinsics(args.intrinsics, 1, 1)  # fail on a bad value before touching any file
    cls = registry.load_class(args.source)
    try:
        source = cls(params, name=args.source)
    except ConfigError as err:
        raise err.within("--set", sep=" ") from None
    failures = 0
    try:
        for i, path in enumerate(args.images):
            try:
                img = read_image(path)
            except (OSError, ValueError) as err:
                print(f"mission: error: {path}: cannot read image ({err})", file=sys.stderr)
                failures += 1
                continue
            h, w = img.shape[:2]
            frame = Frame(image=img, stamp=i * FRAME_PERIOD_S, frame_id="camera_optical_frame",
                          intrinsics=parse_intrinsics(args.intrinsics, w, h))  # fmt: skip
            try:
                dets = source.process(frame)
            except ValueError as err:
                print(f"mission: error: {path}: {err}", file=sys.stderr)
                failures += 1
                continue
            if args.json:
                rec = {"image": path, "width": w, "height": h, "detections": [d.to_json() for d in dets]}
                print(json.dumps(rec), flush=True)
            else:
                print(_table(path, img, dets), flush=True)
    finally:
        source.close()
    return 1 if failures else 0
