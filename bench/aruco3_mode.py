"""OpenCV's ArUco 3 mode against tracking's search pass (issue 34): where scale-normalised detection pays.

OpenCV's ``useAruco3Detection`` (Romero-Ramirez et al., 2018) detects on the image scaled so that a marker of
``minMarkerLengthRatioOriginalImg`` × the image's longer side comes out ``minSideLengthCanonicalImg`` (32) px
wide, and keeps nothing smaller: a marker must be 32 + ratio × W px in the frame. Tracking's search pass
(QuadDetector.search) also looks at a reduced frame, every 2nd–4th pixel, but keeps markers down to 12 sampled
px (36 px at 1280×720, 48 px at 1920×1080). This runs both, and OpenCV's default full-frame detection, on the
panning sequences of the tracking benchmark (bench/marker_sequences.py), interleaved per frame:

    python -m bench.aruco3_mode [--json OUT]

For each: mean ms per frame, the speed-up over the default, recall against the default (the sightings it
found that the default found too), and the smallest marker it found (mean side, px). Figures are ratios
measured in one run.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from bench.marker_sequences import panning_sequence
from bench.tracking_bench import _raw_aruco
from mission.perception_plugins.aruco_detection import QuadDetector, search_step
from mission.perception_plugins.marker_quads import perimeter

DICTIONARY = cv2.aruco.DICT_4X4_250
RATIOS = (0.005, 0.01, 0.02)  # minMarkerLengthRatioOriginalImg: floors of 38–42, 45–51 and 58–70 px
CASES = ((1280, 720, 8), (1920, 1080, 8), (1920, 1080, 1))
N_FRAMES = 90

Found = dict[int, np.ndarray]  # id → 4×2 corners
Detect = Callable[[np.ndarray], Found]


def _opencv(aruco3_ratio: float | None) -> Detect:
    params = cv2.aruco.DetectorParameters()
    if aruco3_ratio is not None:
        params.useAruco3Detection = True
        params.minMarkerLengthRatioOriginalImg = aruco3_ratio
    detect = _raw_aruco(DICTIONARY, params)
    return lambda grey: detect(grey, None)


def _search_pass() -> Detect:
    def unrefined(params: Any) -> None:
        params.cornerRefinementMethod = cv2.aruco.CORNER_REFINE_NONE

    quads = QuadDetector(cv2.aruco.getPredefinedDictionary(DICTIONARY), unrefined)

    def detect(grey: np.ndarray) -> Found:
        found, ids = quads.search(grey)
        return {int(i): q for q, i in zip(found, ids, strict=True)}

    return detect


def measure(width: int, height: int, markers: int, n_frames: int = N_FRAMES) -> list[dict[str, Any]]:
    """Every detector on one panning sequence, calls interleaved per frame."""
    _, frames = panning_sequence(width, height, n_frames, markers, dictionary=DICTIONARY)
    greys = [cv2.cvtColor(f.image, cv2.COLOR_BGR2GRAY) for f in frames]
    detectors: dict[str, Detect] = {"OpenCV default": _opencv(None)}
    detectors |= {f"ArUco 3 mode, ratio {r:g}": _opencv(r) for r in RATIOS}
    step = search_step(greys[0])
    detectors[f"search pass (every {step}{'nd' if step == 2 else 'rd' if step == 3 else 'th'} pixel)"] = _search_pass()
    times: dict[str, list[float]] = {name: [] for name in detectors}
    found: dict[str, list[Found]] = {name: [] for name in detectors}
    for grey in greys:
        for name, detect in detectors.items():
            t0 = time.perf_counter()
            out = detect(grey)
            times[name].append((time.perf_counter() - t0) * 1000)
            found[name].append(out)
    base = found["OpenCV default"]
    base_ms = float(np.mean(times["OpenCV default"]))
    sightings = sum(len(f) for f in base)
    rows = []
    for name in detectors:
        both = sum(len(f.keys() & b.keys()) for f, b in zip(found[name], base, strict=True))
        sides = [perimeter(q) / 4 for f in found[name] for q in f.values()]  # OpenCV's floors are perimeters
        ms = float(np.mean(times[name]))
        rows.append(
            {
                "resolution": f"{width}x{height}",
                "markers": markers,
                "detector": name,
                "ms": round(ms, 3),
                "speedup": round(base_ms / ms, 3),
                "recall": round(both / sightings, 4) if sightings else None,
                "smallest_px": round(min(sides), 1) if sides else None,
                "default_smallest_px": round(min(perimeter(q) / 4 for f in base for q in f.values()), 1),
            }
        )
    return rows


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m bench.aruco3_mode", description=__doc__.split("\n\n")[0])
    ap.add_argument("--json", type=Path, metavar="OUT", help="also write every row and the load average here")
    args = ap.parse_args(argv)
    rows = [row for w, h, n in CASES for row in measure(w, h, n)]
    print(f"{'case':22s} {'detector':36s} {'ms':>7s} {'speed-up':>9s} {'recall':>7s} {'smallest px':>11s}")
    for r in rows:
        case = f"{r['resolution']}, {r['markers']} marker{'s' if r['markers'] > 1 else ''}"
        print(
            f"{case:22s} {r['detector']:36s} {r['ms']:7.2f} {r['speedup']:8.2f}× {r['recall']:7.4f} "
            f"{r['smallest_px'] if r['smallest_px'] is not None else '—':>11}"
        )
    load = [round(x, 2) for x in os.getloadavg()]
    print(f"load average {load}; markers in the default's view are {rows[0]['default_smallest_px']} px and up")
    if args.json:
        args.json.write_text(json.dumps({"rows": rows, "load_average": load}, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
