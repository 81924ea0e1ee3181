"""Benchmark: what the simulation costs — render time per frame and simulated seconds per wall second.

* Render: the `follow_open` room seen from poses along the robot's usual path (target near and far,
  walls, boxes), TinyRenderer at 320×240, 640×480 and 1280×720 (and EGL when its plugin loads), median
  and p90 wall ms per ``SimAdapter.capture()`` (render + floor/wall painting + image noise), single
  process — against pybullet's bare ``getCameraImage`` with the same matrices, renderer and pose,
  interleaved in the same loop (so the ratio is our capture's overhead).
* Sim only: the `follow_open` scenario driven by a scripted follower on ground truth (navigator goals
  at 5 Hz, camera 15 Hz at 640×480, lidar 10 Hz) — the world's own cost without perception or a tree.
* Closed loop: ``mission run`` 's code path (``mission.app.sim_run.run_scenario``: aruco perception + the
  follow tree + the sim) on `follow_open`, simulated seconds per wall second — against the sim alone.

Wall time on a shared machine varies with load; the load average is reported with the figures.

Run: ``mission bench --only sim`` (or ``python -m bench.sim_bench [--quick] [--json]``).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

from bench.common import Figure, progress
from mission.core import blackboard as bbk
from mission.core.errors import MissionError
from mission.core.types import NavGoal, Pose2D
from mission.sim.scenario import load_scenario
from mission.sim.sim_adapter import SimAdapter

RENDER_POSES = [(1.3, 2.0, 0.0), (1.3, 2.0, 0.6), (4.0, 4.0, 2.0), (4.5, 2.0, 0.0), (5.0, 5.0, -2.5), (3.0, 6.0, 3.1)]


def _load() -> float:
    try:
        return round(os.getloadavg()[0], 2)
    except OSError:  # pragma: no cover - not on Linux
        return float("nan")


def render_times(width: int, height: int, renderer: str, frames: int) -> dict[str, float]:
    """Wall ms per captured frame over RENDER_POSES (each pose `frames` times), and of the bare render."""
    import pybullet as p

    from mission.sim.quiet import quiet

    sc = load_scenario("follow_open")
    sc.camera.width, sc.camera.height = width, height
    adapter = SimAdapter(sc, seed=0, renderer=renderer)
    adapter.setup()
    times, bare = [], []
    try:
        assert adapter.base is not None and adapter.world is not None
        cam, cid = sc.camera, adapter.world.cid
        flag = p.ER_BULLET_HARDWARE_OPENGL if renderer == "egl" else p.ER_TINY_RENDERER
        for x, y, yaw in RENDER_POSES:
            adapter.base.state.x, adapter.base.state.y, adapter.base.state.yaw = x, y, yaw
            adapter.capture()  # warm up
            T = adapter.T_map_optical()
            eye, fwd, up = T[:3, 3], T[:3, 2], -T[:3, 1]
            view = p.computeViewMatrix(eye.tolist(), (eye + fwd).tolist(), up.tolist(), physicsClientId=cid)
            proj = p.computeProjectionMatrixFOV(
                cam.vfov_deg, width / height, cam.near_m, cam.far_m, physicsClientId=cid
            )
            for _ in range(frames):
                t0 = time.perf_counter()
                adapter.capture()
                t1 = time.perf_counter()
                with quiet():
                    p.getCameraImage(
                        width,
                        height,
                        view,
                        proj,
                        shadow=0,
                        renderer=flag,
                        flags=p.ER_NO_SEGMENTATION_MASK,
                        physicsClientId=cid,
                    )
                t2 = time.perf_counter()
                times.append(1000 * (t1 - t0))
                bare.append(1000 * (t2 - t1))
    finally:
        adapter.close()
    return {
        "median_ms": round(float(np.median(times)), 1),
        "p90_ms": round(float(np.percentile(times, 90)), 1),
        "bare_median_ms": round(float(np.median(bare)), 1),
    }


def sim_only(duration_s: float) -> dict[str, float]:
    """The world alone: a ground-truth follower, camera 15 Hz 640×480, lidar, navigator."""
    adapter = SimAdapter(load_scenario("follow_open"), seed=1)
    adapter.setup()
    bb = bbk.writer("bench")
    bbk.set_(bb, bbk.TWIST, None)
    bbk.set_(bb, bbk.NAV_GOAL, None)
    seq, last_goal = 0, -1.0
    t0, c0 = time.perf_counter(), time.process_time()
    try:
        while adapter.t < duration_s:
            adapter.sense(bb)
            truth = adapter.ground_truth()
            if adapter.t - last_goal >= 0.2 and truth.target is not None:
                dx, dy = truth.target.x - truth.robot.x, truth.target.y - truth.robot.y
                d = max(math.hypot(dx, dy), 1e-6)
                seq += 1
                goal = Pose2D(truth.target.x - dx / d, truth.target.y - dy / d, math.atan2(dy, dx))
                bbk.set_(bb, bbk.NAV_GOAL, NavGoal(goal, adapter.t, seq))
                last_goal = adapter.t
            adapter.act(bb)
            adapter.advance(1 / 15)
        wall, cpu = time.perf_counter() - t0, time.process_time() - c0
        frames = adapter.frames_rendered
    finally:
        adapter.close()
    return {
        "sim_s": round(adapter.t, 1),
        "wall_s": round(wall, 2),
        "cpu_s": round(cpu, 2),
        "sim_s_per_wall_s": round(adapter.t / wall, 2),
        "frames": frames,
    }


def closed_loop(duration_s: float) -> dict[str, Any]:
    """The `mission run` code path on follow_open (aruco + follow tree + sim)."""
    from mission.app.sim_run import run_scenario  # the application layer: imported only for this figure

    c0 = time.process_time()
    outcome, _, _ = run_scenario("follow_open", seed=1, max_duration=duration_s)
    cpu = time.process_time() - c0
    return {
        "sim_s": outcome.sim_time_s,
        "wall_s": outcome.wall_time_s,
        "cpu_s": round(cpu, 2),
        "sim_s_per_wall_s": round(outcome.sim_time_s / max(outcome.wall_time_s, 1e-9), 2),
        "success": outcome.success,
    }


def egl_available() -> bool:
    try:
        render_times(64, 48, "egl", 1)
    except MissionError:
        return False
    return True


def measure(quick: bool = False) -> dict[str, Any]:
    frames = 2 if quick else 10
    duration = 8.0 if quick else 60.0
    out: dict[str, Any] = {"load_average_before": _load(), "render": {}}
    renderers = ["tiny"] if quick else (["tiny", "egl"] if egl_available() else ["tiny"])
    sizes = ((320, 240), (640, 480)) if quick else ((320, 240), (640, 480), (1280, 720))
    for renderer in renderers:
        for w, h in sizes:
            out["render"][f"{renderer} {w}x{h}"] = render_times(w, h, renderer, frames)
            progress(f"sim: render {renderer} {w}x{h}: {out['render'][f'{renderer} {w}x{h}']}")
    out["sim_only_follow_open"] = sim_only(duration)
    progress(f"sim: sim only {out['sim_only_follow_open']}")
    out["closed_loop_follow_open"] = closed_loop(duration)
    progress(f"sim: closed loop {out['closed_loop_follow_open']}")
    out["load_average_after"] = _load()
    return out


def run(quick: bool, out: Path) -> dict[str, Any]:
    """Registered benchmark `sim`: render ms/frame vs bare getCameraImage; closed loop vs the sim alone."""
    res = measure(quick)
    figures = []
    for label, r in res["render"].items():
        figures.append(
            Figure(
                f"capture {label}: median ms per frame",
                r["median_ms"],
                "ms",
                baseline="bare pybullet getCameraImage, same matrices and pose",
                baseline_value=r["bare_median_ms"],
                ratio=round(r["median_ms"] / r["bare_median_ms"], 3) if r["bare_median_ms"] else None,
            ).to_json()
        )
    cl, so = res["closed_loop_follow_open"], res["sim_only_follow_open"]
    figures.append(
        Figure(
            "closed loop (aruco + follow tree + sim) on follow_open",
            cl["sim_s_per_wall_s"],
            "sim-s per wall-s",
            baseline="the sim alone with a ground-truth follower (no perception, no tree)",
            baseline_value=so["sim_s_per_wall_s"],
            ratio=round(cl["sim_s_per_wall_s"] / so["sim_s_per_wall_s"], 3),
        ).to_json()
    )
    return {
        "title": "Simulation: render cost per frame and simulated seconds per wall second",
        "figures": figures,
        "details": res,
        "plots": [],
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="fewer frames, TinyRenderer only, 8 s runs instead of 60 s")
    ap.add_argument("--json", action="store_true", help="print JSON")
    args = ap.parse_args()
    res = run(args.quick, Path(tempfile.gettempdir()))["details"]
    if args.json:
        print(json.dumps(res, indent=2))
        return
    print(f"load average before/after: {res['load_average_before']} / {res['load_average_after']}")
    for label, r in res["render"].items():
        print(
            f"render {label:>16}: median {r['median_ms']:6.1f} ms  p90 {r['p90_ms']:6.1f} ms per frame "
            f"(bare getCameraImage {r['bare_median_ms']:.1f} ms)"
        )
    for key in ("sim_only_follow_open", "closed_loop_follow_open"):
        r = res[key]
        print(
            f"{key:>24}: {r['sim_s']:.0f} s simulated in {r['wall_s']:.1f} s wall ({r['cpu_s']:.1f} s CPU) "
            f"= {r['sim_s_per_wall_s']:.2f} sim-s per wall-s"
        )


if __name__ == "__main__":
    main()
