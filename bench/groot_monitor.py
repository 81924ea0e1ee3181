"""Benchmark: what watching a mission in Groot2 costs the loop — the .btlog writer and the live monitor.

A live `mission_full` run is recorded tick by tick (bench/tick_recording.py) and replayed into the real
``mission.xml`` by the real runner (bench/tree_tick.ReplayWorld: no detector, no renderer), three ways
in turn, on the same ticks and the same machine load: with no observer (the baseline), with
``--btlog`` (BtLogWriter), and with ``--groot`` (Groot2Publisher) while a Groot2 protocol client on
loopback asks for STATUS every POLL_S (faster than Groot2 itself polls). Timed: each ``runner.step()``
(the tick with its visitor, then the observers' ``on_tick``), with GAP_S between steps. Passes
alternate so a change of load hits all three alike. Target: each ratio ≤ 1.3 on the step; what is
added is also given against the 15 Hz tick period, the budget it comes out of.
"""

from __future__ import annotations

import struct
import threading
import time
from pathlib import Path
from typing import Any

import numpy as np
import py_trees
import zmq

from bench.common import Figure, pct, progress
from bench.tick_recording import Recording, record
from bench.tree_tick import ReplayWorld
from mission.app.runner import TreeRunner
from mission.app.sim_run import shipped_config
from mission.core.config import load_config
from mission.core.observers import RunObserver
from mission.groot.btlog import BtLogWriter
from mission.groot.publisher import Groot2Publisher

TARGET = 1.3
POLL_S = 0.01  # the client's STATUS period: 100 Hz
GAP_S = 0.005  # between two steps (not timed), in every mode alike, so the client's requests fall among them
TICK_PERIOD_US = 1e6 / 15


def _steps_us(rec: Recording, observers: list[RunObserver]) -> list[float]:
    """µs of each runner.step() over the recording, with `observers` attached."""
    config_path = shipped_config(rec.config)
    py_trees.blackboard.Blackboard.clear()
    world = ReplayWorld(rec)
    runner = TreeRunner(
        load_config(config_path), world, rec.tree, config_file=config_path, sources=[], observers=observers
    )
    out: list[float] = []
    try:
        runner.setup()
        while not world.exhausted:
            t0 = time.perf_counter()
            runner.step()
            out.append((time.perf_counter() - t0) * 1e6)
            world.advance(runner.dt)
            time.sleep(GAP_S)
        runner.finish(None)
    finally:
        runner.close()
        py_trees.blackboard.Blackboard.clear()
    return out


class _Poller(threading.Thread):
    """A Groot2-side client asking for STATUS every POLL_S until stopped; counts the replies."""

    def __init__(self, port: int) -> None:
        super().__init__(daemon=True)
        self.port = port
        self.replies = 0
        self.stop = threading.Event()

    def run(self) -> None:
        ctx = zmq.Context()
        sock = ctx.socket(zmq.REQ)
        sock.setsockopt(zmq.LINGER, 0)
        sock.setsockopt(zmq.RCVTIMEO, 1000)
        sock.connect(f"tcp://127.0.0.1:{self.port}")
        try:
            while not self.stop.is_set():
                sock.send(struct.pack("<BBI", 2, ord("S"), self.replies))
                try:
                    sock.recv_multipart()
                except zmq.Again:
                    break
                self.replies += 1
                self.stop.wait(POLL_S)
        finally:
            sock.close(linger=0)
            ctx.term()


def run(quick: bool, out: Path) -> dict[str, Any]:
    seconds, passes = (12.0, 2) if quick else (60.0, 5)
    rec = record("mission_full", seconds)
    progress(f"groot: recorded {len(rec.ticks)} ticks of mission_full; replaying ×{passes} (none / btlog / groot)")
    base: list[float] = []
    btlog: list[float] = []
    groot: list[float] = []
    replies = 0
    polled_s = 0.0
    for i in range(passes):
        base.extend(_steps_us(rec, []))
        btlog.extend(_steps_us(rec, [BtLogWriter(out / f"groot_bench_{i}.btlog")]))
        publisher = Groot2Publisher(0, quiet=True)
        poller = _Poller(publisher.port)
        poller.start()
        t0 = time.perf_counter()
        try:
            groot.extend(_steps_us(rec, [publisher]))
        finally:
            polled_s += time.perf_counter() - t0
            poller.stop.set()
            poller.join(timeout=5)
            publisher.close()
        replies += poller.replies
        (out / f"groot_bench_{i}.btlog").unlink(missing_ok=True)
    med = {k: float(np.median(v)) for k, v in (("base", base), ("btlog", btlog), ("groot", groot))}
    figures = [
        Figure(
            "mission.xml step with --btlog: median µs",
            round(med["btlog"], 1),
            "µs",
            baseline="the same step with no observer, same ticks",
            baseline_value=round(med["base"], 1),
            ratio=round(med["btlog"] / med["base"], 2),
            target=f"ratio ≤ {TARGET}",
            meets_target=med["btlog"] / med["base"] <= TARGET,
        ),
        Figure(
            f"mission.xml step with --groot, a client polling STATUS at {1 / POLL_S:g} Hz: median µs",
            round(med["groot"], 1),
            "µs",
            baseline="the same step with no observer, same ticks",
            baseline_value=round(med["base"], 1),
            ratio=round(med["groot"] / med["base"], 2),
            target=f"ratio ≤ {TARGET}",
            meets_target=med["groot"] / med["base"] <= TARGET,
        ),
        Figure(
            "mission.xml step with --groot: p99",
            pct(groot, 99, 1),
            "µs",
            baseline="no observer p99",
            baseline_value=pct(base, 99, 1),
        ),
        Figure(
            "--groot: median µs added per step",
            round(med["groot"] - med["base"], 1),
            "µs",
            baseline="the 15 Hz tick period it comes out of",
            baseline_value=round(TICK_PERIOD_US, 1),
            ratio=round((med["groot"] - med["base"]) / TICK_PERIOD_US, 5),
        ),
    ]
    return {
        "title": "Groot2: the cost of a .btlog and of a connected Groot2 monitor, per step",
        "figures": [f.to_json() for f in figures],
        "details": {
            "scenario": rec.scenario,
            "sim_seconds": seconds,
            "ticks": len(rec.ticks),
            "passes": passes,
            "status_replies": replies,
            "status_replies_per_s": round(replies / polled_s, 1) if polled_s else None,
            "base_us_p50_p90_p99": [pct(base, q, 1) for q in (50, 90, 99)],
            "btlog_us_p50_p90_p99": [pct(btlog, q, 1) for q in (50, 90, 99)],
            "groot_us_p50_p90_p99": [pct(groot, q, 1) for q in (50, 90, 99)],
        },
        "plots": [],
    }
