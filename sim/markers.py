"""Fiducial marker textures for the renderer: a PNG with a white quiet zone on an OBJ quad with UVs.

pybullet smears textures on primitive boxes (FIELD_NOTES), so each marker is its own mesh: a square in
its local x-y plane, normal +z, with ``vt`` v = 1 on the top image row. The quad's local frame *is* the
marker frame detectors report (z out of the face, x right, y up as seen facing the tag), so the pose a
detector finds can be compared with the quad's world pose directly.

Assets are generated at run time into a cache directory (content-named, written atomically), never
committed. The sim knows markers as textures only; it does not import perception plugins.
"""

from __future__ import annotations

import os
import tempfile
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from mission.core.files import atomic_write_bytes

PIXELS_PER_CELL = 32
# White cells around the black border (FIELD_NOTES: one). Measured on renders at 3 m: OpenCV's default
# detector with SUBPIX sometimes snaps a corner onto the quad's outer corner with one cell (+4.5 px,
# ~10 % range error) and not with two; the project's aruco and apriltag sources give the same errors
# with one or two. Scenarios can ask for more per marker (`quiet_cells`).
QUIET_CELLS = 1


def cache_dir() -> Path:
    """Where generated assets go: $MISSION_SIM_CACHE, else a per-user directory under the temp dir."""
    env = os.environ.get("MISSION_SIM_CACHE")
    uid = os.getuid() if hasattr(os, "getuid") else 0
    d = Path(env) if env else Path(tempfile.gettempdir()) / f"mission-sim-assets-{uid}"
    d.mkdir(parents=True, exist_ok=True)
    return d


def dictionary(name: str) -> cv2.aruco.Dictionary:
    """An OpenCV predefined dictionary by name (ValueError naming the choices when unknown)."""
    code = getattr(cv2.aruco, name, None) if name.startswith("DICT_") else None
    if not isinstance(code, int):
        choices = sorted(n for n in dir(cv2.aruco) if n.startswith("DICT_"))
        raise ValueError(f"unknown dictionary {name!r}; expected one of {', '.join(choices)}")
    return cv2.aruco.getPredefinedDictionary(code)


def dictionary_size(name: str) -> int:
    """How many ids a dictionary holds."""
    return int(dictionary(name).bytesList.shape[0])


@dataclass(frozen=True)
class MarkerAsset:
    obj_path: Path
    png_path: Path
    quad_side_m: float  # the quad including the quiet zone
    size_m: float  # the black square


def marker_image(
    dictionary_name: str, marker_id: int, quiet_cells: int = QUIET_CELLS, pixels_per_cell: int = PIXELS_PER_CELL
) -> np.ndarray:
    """The marker as a BGR image: black-bordered code plus a quiet zone of `quiet_cells` white cells."""
    d = dictionary(dictionary_name)
    cells = d.markerSize + 2  # code bits plus the one-cell black border
    img = cv2.aruco.generateImageMarker(d, marker_id, cells * pixels_per_cell, borderBits=1)
    pad = quiet_cells * pixels_per_cell
    img = cv2.copyMakeBorder(img, pad, pad, pad, pad, cv2.BORDER_CONSTANT, value=255)
    return cv2.cvtColor(img, cv2.COLOR_GRAY2BGR)


def quad_side(dictionary_name: str, size_m: float, quiet_cells: int = QUIET_CELLS) -> float:
    """Side of the textured quad for a marker whose black square is `size_m`."""
    cells = dictionary(dictionary_name).markerSize + 2
    return size_m * (cells + 2 * quiet_cells) / cells


def _write_atomic(path: Path, data: bytes) -> None:
    """Cache files are named by their content: one that exists is already right (another process made it)."""
    if not path.exists():
        atomic_write_bytes(path, data)


def marker_asset(
    dictionary_name: str, marker_id: int, size_m: float, quiet_cells: int = QUIET_CELLS, directory: Path | None = None
) -> MarkerAsset:
    """The OBJ/MTL/PNG triple for one marker, generated once per content into the cache directory."""
    d = directory or cache_dir()
    side = quad_side(dictionary_name, size_m, quiet_cells)
    stem = f"{dictionary_name.lower()}_{marker_id}_{round(side * 1e4)}_q{quiet_cells}"
    png = d / f"{stem}.png"
    ok, buf = cv2.imencode(".png", marker_image(dictionary_name, marker_id, quiet_cells))
    if not ok:  # pragma: no cover - cv2 always encodes PNG
        raise RuntimeError("cannot encode marker PNG")
    _write_atomic(png, buf.tobytes())
    h = side / 2
    mtl = d / f"{stem}.mtl"
    _write_atomic(mtl, f"newmtl tag\nKa 1 1 1\nKd 1 1 1\nKs 0 0 0\nd 1\nillum 1\nmap_Kd {png.name}\n".encode())
    obj = d / f"{stem}.obj"
    text = (
        f"mtllib {mtl.name}\n"
        f"v {-h:.6f} {-h:.6f} 0\nv {h:.6f} {-h:.6f} 0\nv {h:.6f} {h:.6f} 0\nv {-h:.6f} {h:.6f} 0\n"
        "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nvn 0 0 1\n"
        "usemtl tag\nf 1/1/1 2/2/1 3/3/1\nf 1/1/1 3/3/1 4/4/1\n"
    )
    _write_atomic(obj, text.encode())
    return MarkerAsset(obj_path=obj, png_path=png, quad_side_m=side, size_m=size_m)
