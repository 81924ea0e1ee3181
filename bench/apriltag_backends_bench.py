"""Benchmark: the `apriltag` source's two backends on rendered tag36h11 views with ground truth.

For each range, random poses up to 40° off axis (tools/synthetic_views.py, blur 0.7 px,
noise 3 grey levels) are rendered at 640×480 and run through ``AprilTagSource.process`` with each
backend (naive per-frame flip choice, so frames are independent). Reported per backend and range:
detection rate, corner error (px, mean of the 4 corners' distance to the truth), translation error
(% of range, median and p90), rotation error (deg, median) and the median time of one ``process``
call (detect + pose), single-threaded.

The baseline of each figure is the other backend on the same views (the choice of default is a
comparison between the two); the times are single-threaded ``process`` calls in the same run.

Run: ``mission bench --only apriltag_backends`` (or ``python -m bench.apriltag_backends_bench [--quick] [--json]``).
"""

from __future__ import annotations

import argparse
import json
import math
import tempfile
import time
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from bench.common import Figure
from mission.core import se3
from mission.core.types import Frame
from mission.perception_plugins.apriltag import AprilTagSource
from tools import synthetic_views as sv

CONFIGS = {
    "apriltag3 (defaults: full resolution)": {"backend": "apriltag3"},
    "apriltag3 (decimate 2)": {"backend": "apriltag3", "decimate": 2.0, "min_contrast": 5},
    "opencv (fitted edges)": {"backend": "opencv"},
}


def measure(quick: bool = False, seed: int = 0) -> dict[str, Any]:
    """The per-backend, per-range table (what the script printed before it was a registered benchmark)."""
    ranges = (1.0, 2.0, 3.0)
    n = 10 if quick else 40
    size = 0.15
    k = sv.default_intrinsics(640, 480)
    rng = np.random.default_rng(seed)
    views = {
        d: [
            sv.render_marker_view(
                sv.random_pose(d, 40.0, rng, k, size),
                marker_id=7,
                marker_size_m=size,
                dictionary=cv2.aruco.DICT_APRILTAG_36h11,
                intrinsics=k,
                rng=rng,
            )
            for _ in range(n)
        ]
        for d in ranges
    }
    results: dict[str, Any] = {}
    for label, cfg in CONFIGS.items():
        src = AprilTagSource({**cfg, "tag_size_m": size, "threads": 1, "disambiguation": "naive"})
        per_range = {}
        for d in ranges:
            corner, trans, rot, times, found = [], [], [], [], 0
            for i, v in enumerate(views[d]):
                frame = Frame(v.image, stamp=float(i), intrinsics=k)
                t0 = time.perf_counter()
                dets = src.process(frame)
                times.append(time.perf_counter() - t0)
                dets = [x for x in dets if x.marker_id == 7]
                if not dets:
                    continue
                found += 1
                det = dets[0]
                corner.append(float(np.mean(np.linalg.norm(det.corners - v.corners, axis=1))))
                trans.append(float(np.linalg.norm(det.position - v.position) / v.distance * 100))
                rot.append(math.degrees(se3.rotation_angle(se3.quat_to_matrix(det.orientation), v.rotation)))
            per_range[f"{d:.0f} m"] = {
                "detected": f"{found}/{n}",
                "corner_px_mean": round(float(np.mean(corner)), 3) if corner else None,
                "trans_pct_median": round(float(np.median(trans)), 3) if trans else None,
                "trans_pct_p90": round(float(np.percentile(trans, 90)), 3) if trans else None,
                "rot_deg_median": round(float(np.median(rot)), 2) if rot else None,
                "time_ms_median": round(float(np.median(times)) * 1000, 2),
            }
        src.close()
        results[label] = per_range
    return {"image": "640x480", "tag": f"tag36h11 {size} m", "views_per_range": n, "results": results}


DEFAULT = "apriltag3 (defaults: full resolution)"
OTHER = "opencv (fitted edges)"


def run(quick: bool, out: Path) -> dict[str, Any]:
    """Registered benchmark `apriltag_backends`: the default backend's figures beside the other's."""
    table = measure(quick=quick)
    res = table["results"]
    figures = []
    for rng_label in res[DEFAULT]:
        a, b = res[DEFAULT][rng_label], res[OTHER][rng_label]
        for key, label, unit in (
            ("corner_px_mean", "mean corner error", "px"),
            ("trans_pct_median", "median translation error", "% of range"),
            ("time_ms_median", "median time per process()", "ms"),
        ):
            ratio = None if a[key] is None or not b[key] else round(a[key] / b[key], 3)
            figures.append(
                Figure(
                    f"{DEFAULT} {label} at {rng_label}",
                    a[key],
                    unit,
                    baseline=f"{OTHER} backend on the same views",
                    baseline_value=b[key],
                    ratio=ratio,
                ).to_json()
            )
    return {
        "title": "AprilTag backends: apriltag3 (pupil-apriltags) vs OpenCV on the same rendered tag36h11 views",
        "figures": figures,
        "details": table,
        "plots": [],
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    out = run(args.quick, Path(tempfile.gettempdir()))["details"]
    if args.json:
        print(json.dumps(out, indent=2))
        return 0
    print(f"{out['tag']}, {out['image']}, {out['views_per_range']} views per range, ≤ 40° off axis")
    cols = ("detected", "corner_px_mean", "trans_pct_median", "trans_pct_p90", "rot_deg_median", "time_ms_median")
    heads = ("found", "corner px", "t% med", "t% p90", "rot° med", "ms")
    print(f"{'backend':24} {'range':>5} " + " ".join(f"{h:>9}" for h in heads))
    for label, rows in out["results"].items():
        for rng_label, r in rows.items():
            print(f"{label:24} {rng_label:>5} " + " ".join(f"{r[c]!s:>9}" for c in cols))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
