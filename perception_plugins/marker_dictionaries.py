"""ArUco dictionaries by name or from a file: every OpenCV predefined dictionary, and custom ones.

* A name is one of OpenCV's predefined dictionaries (:data:`PREDEFINED`, matched without regard to case,
  so ``DICT_APRILTAG_36H11`` is ``DICT_APRILTAG_36h11``).
* A path (ending in ``.yml``, ``.yaml`` or ``.json``, or containing a ``/``) is an OpenCV dictionary file
  as ``cv2.aruco.Dictionary.readDictionary`` reads it: ``nmarkers``, ``markersize``, optionally
  ``maxCorrectionBits``, and ``marker_0 … marker_{n-1}`` bit strings, row by row, 1 = white. A file
  without ``maxCorrectionBits`` (OpenCV's own tutorial dictionary has none) would let OpenCV correct no
  bit at all, so it gets what the codes allow: half their smallest distance to each other in any of the
  four rotations, less one, as OpenCV's generator computes it.

Anything else is not a dictionary: :func:`resolve` says so with the list of names that exist, and the
sources warn and fall back to their default (the design notes' behaviour for an unknown name).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from mission.core.errors import ConfigError

PREDEFINED = (
    "DICT_4X4_50", "DICT_4X4_100", "DICT_4X4_250", "DICT_4X4_1000",
    "DICT_5X5_50", "DICT_5X5_100", "DICT_5X5_250", "DICT_5X5_1000",
    "DICT_6X6_50", "DICT_6X6_100", "DICT_6X6_250", "DICT_6X6_1000",
    "DICT_7X7_50", "DICT_7X7_100", "DICT_7X7_250", "DICT_7X7_1000",
    "DICT_ARUCO_ORIGINAL", "DICT_ARUCO_MIP_36h12",
    "DICT_APRILTAG_16h5", "DICT_APRILTAG_25h9", "DICT_APRILTAG_36h10", "DICT_APRILTAG_36h11",
)  # fmt: skip
_BY_LOWER = {name.lower(): name for name in PREDEFINED}
FILE_SUFFIXES = (".yml", ".yaml", ".json")


@dataclass(frozen=True)
class MarkerDictionary:
    """A dictionary ready for detection: the OpenCV object and what a detection reports it as."""

    name: str  # the predefined name, or the file's path as given
    dictionary: cv2.aruco.Dictionary
    custom: bool = False

    @property
    def marker_bits(self) -> int:
        return int(self.dictionary.markerSize)

    @property
    def size(self) -> int:
        """How many ids it has (0 … size − 1)."""
        return len(self.dictionary.bytesList)


def is_path(value: str) -> bool:
    """Does `value` name a dictionary file rather than a predefined dictionary?"""
    return "/" in value or "\\" in value or value.lower().endswith(FILE_SUFFIXES)


def canonical_name(value: str) -> str | None:
    """The predefined dictionary `value` names (any case), or None."""
    return _BY_LOWER.get(value.strip().lower())


def predefined(name: str) -> MarkerDictionary:
    """A predefined dictionary by its canonical name (a KeyError for anything else)."""
    canonical = canonical_name(name)
    if canonical is None:
        raise KeyError(name)
    return MarkerDictionary(canonical, cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, canonical)))


def correctable_bits(dictionary: cv2.aruco.Dictionary) -> int:
    """Bits a dictionary can correct: (its smallest code distance over rotations − 1) // 2, at least 0."""
    n = int(dictionary.markerSize)
    rows = dictionary.bytesList
    codes = np.stack([cv2.aruco.Dictionary.getBitsFromByteList(rows[i : i + 1], n) for i in range(len(rows))])
    codes = codes.astype(bool).reshape(len(rows), n, n)
    if len(codes) < 2:
        return max(0, (n * n - 1) // 2)
    flat = codes.reshape(len(codes), -1)
    best = n * n
    for k in range(4):  # another marker's code, in any of the four rotations
        rotated = np.rot90(codes, k, axes=(1, 2)).reshape(len(codes), -1)
        dist = (flat[:, None, :] != rotated[None, :, :]).sum(axis=2)
        if k == 0:
            np.fill_diagonal(dist, n * n)
        best = min(best, int(dist.min()))
    return max(0, (best - 1) // 2)


def from_file(path: str, key: str = "dictionary") -> MarkerDictionary:
    """A custom dictionary from an OpenCV dictionary file; a ConfigError naming `key` and the file when
    it is missing or not one."""
    p = Path(path).expanduser()
    if not p.is_file():
        why = "no such file" if not p.exists() else "not a file"
        raise ConfigError(
            f"{path}: {why} (expected an OpenCV dictionary file or one of {', '.join(PREDEFINED)})", key=key
        )
    try:
        storage = cv2.FileStorage(str(p), cv2.FILE_STORAGE_READ)
        root = storage.root()
        nmarkers = int(root.getNode("nmarkers").real()) if not root.getNode("nmarkers").empty() else 0
        bits = int(root.getNode("markersize").real()) if not root.getNode("markersize").empty() else 0
        has_correction = not root.getNode("maxCorrectionBits").empty()
        d = cv2.aruco.Dictionary()
        ok = bool(d.readDictionary(root)) if nmarkers > 0 and bits > 0 else False
        storage.release()
    except cv2.error as err:
        raise ConfigError(f"{path}: not readable as an OpenCV dictionary file ({_first_line(err)})", key=key) from None
    if not ok or len(d.bytesList) != nmarkers:
        raise ConfigError(
            f"{path}: not an OpenCV dictionary file (expected nmarkers, markersize and marker_0 … marker_N bit "
            f"strings of markersize² bits)",
            key=key,
        )
    if not has_correction:
        d.maxCorrectionBits = correctable_bits(d)
    return MarkerDictionary(str(path), d, custom=True)


def _first_line(err: Exception) -> str:
    text = " ".join(str(err).split())
    return text[:160]


def resolve(value: str, key: str = "dictionary") -> MarkerDictionary | None:
    """The dictionary `value` names: a predefined one, a file's (errors as :func:`from_file`), or None
    when it is neither (the caller warns and falls back)."""
    if is_path(value):
        return from_file(value, key)
    canonical = canonical_name(value)
    return None if canonical is None else predefined(canonical)
