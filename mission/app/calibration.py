"""Camera calibration files: what ``mission detect --calibration`` and ``mission replay --calibration`` read.

Two formats, told apart by their content:

* **ROS** (camera_info_manager, ``camera_calibration``'s ``ost.yaml``): ``image_width``, ``image_height``,
  ``camera_matrix: {rows: 3, cols: 3, data: [...]}``, ``distortion_model``,
  ``distortion_coefficients: {data: [...]}`` (``rectification_matrix`` and ``projection_matrix`` are
  read past: poses are computed on the unrectified image, as published);
* **OpenCV** (``cv2.FileStorage``: a ``%YAML`` directive, ``!!opencv-matrix`` entries, as ``calibrateCamera``
  samples write them): ``camera_matrix`` (or ``cameraMatrix``, ``K``), ``distortion_coefficients`` (or
  ``dist_coeffs``, ``distCoeffs``, ``D``), and ``image_width`` / ``image_height`` when present.

A file that is neither, or whose matrix is not a usable 3×3 camera matrix, is a ConfigError naming the
file and the key.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import cv2
import numpy as np
import yaml

from mission.core.errors import ConfigError
from mission.core.types import CameraIntrinsics

MATRIX_KEYS = ("camera_matrix", "cameraMatrix", "K")
DISTORTION_KEYS = ("distortion_coefficients", "dist_coeffs", "distCoeffs", "D")


def load_calibration(path: str | Path) -> CameraIntrinsics:
    """The camera model in a ROS or OpenCV calibration file."""
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8", errors="replace")
    except OSError as err:
        raise ConfigError(f"cannot read calibration ({err.strerror or err})", file=str(path)) from None
    if text.lstrip().startswith("%YAML") or "!!opencv-matrix" in text:
        fields = _opencv_fields(p)
    else:
        try:
            fields = yaml.safe_load(text)
        except yaml.YAMLError as err:
            why = str(err).splitlines()[0]
            raise ConfigError(f"not a calibration file: invalid YAML ({why})", file=str(path)) from None
    if not isinstance(fields, dict):
        raise ConfigError("not a calibration file: expected a mapping with camera_matrix", file=str(path))
    return _intrinsics(fields, str(path))


def _opencv_fields(path: Path) -> dict[str, Any]:
    try:
        fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_READ)
    except cv2.error as err:
        why = " ".join(str(err).split())[:160]
        raise ConfigError(f"not readable as an OpenCV calibration file ({why})", file=str(path)) from None
    root = fs.root()
    out: dict[str, Any] = {}
    for key in root.keys():  # noqa: SIM118 - a cv2.FileNode, not a dict
        node = root.getNode(key)
        if node.isMap() or node.isSeq() or node.type() == cv2.FILE_NODE_NONE:
            mat = node.mat()
            if mat is not None:
                out[key] = np.asarray(mat, dtype=np.float64)
        elif node.isReal() or node.isInt():
            out[key] = node.real()
        elif node.isString():
            out[key] = node.string()
    fs.release()
    return out


def _numbers(value: Any) -> np.ndarray | None:
    """A matrix given as numbers, a nested list, a numpy array or a ROS ``{rows, cols, data}`` mapping."""
    if isinstance(value, dict):
        value = value.get("data")
    if value is None:
        return None
    try:
        arr = np.asarray(value, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError):
        return None
    return arr


def _first(fields: dict[str, Any], keys: tuple[str, ...]) -> tuple[str, Any] | tuple[None, None]:
    for k in keys:
        if k in fields:
            return k, fields[k]
    return None, None


def _intrinsics(fields: dict[str, Any], file: str) -> CameraIntrinsics:
    key, raw = _first(fields, MATRIX_KEYS)
    if key is None:
        raise ConfigError(f"no camera matrix; expected one of {', '.join(MATRIX_KEYS)}", file=file)
    k = _numbers(raw)
    if k is None or k.size != 9:
        size = "no numbers" if k is None else f"{k.size} numbers"
        raise ConfigError(f"expected a 3×3 matrix (9 numbers), got {size}", file=file, key=key)
    dkey, draw = _first(fields, DISTORTION_KEYS)
    d = np.zeros(0) if dkey is None else _numbers(draw)
    if d is None:
        raise ConfigError("expected a list of numbers", file=file, key=dkey)
    width = int(fields.get("image_width", fields.get("width", 0)) or 0)
    height = int(fields.get("image_height", fields.get("height", 0)) or 0)
    intr = CameraIntrinsics(
        fx=float(k[0]),
        fy=float(k[4]),
        cx=float(k[2]),
        cy=float(k[5]),
        width=width,
        height=height,
        distortion=tuple(float(v) for v in d),
    )
    problem = intr.problem()
    if problem is not None:
        raise ConfigError(problem, file=file, key=key if "distortion" not in problem else dkey)
    return intr
