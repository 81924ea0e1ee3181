"""`mission replay BAG`: the tree on a recorded bag (ROS 1 or rosbag2), through the ROS node's adapter code.

``--json`` prints one line per processed frame: ``{"stamp", "frame_id", "detections": [Detection]}``;
the summary goes to stderr. Without it, one summary line on stdout. Exit 0 when the bag was replayed.
"""

from __future__ import annotations

import argparse
import json
import sys

from mission.app.calibration import load_calibration
from mission.core.config import MissionConfig, load_config, validate_model
from mission.ros.bag_replay import TOPIC_KEYS, FrameResult, recorded_config, replay


def main(args: argparse.Namespace) -> int:
    config = load_config(args.config)
    if args.config is None and (recorded := recorded_config(args.bag)) is not None:
        config = validate_model(MissionConfig, recorded, file=f"{args.bag} (its recorded config)")
        print(
            f"mission replay: using the config recorded with {args.bag} (`mission run --record-bag`); "
            "--config FILE replays it with another",
            file=sys.stderr,
        )
    if args.rate < 0:
        print("mission: error: --rate must be >= 0 (0 = as fast as possible, 1.0 = recorded rate)", file=sys.stderr)
        return 2

    calibration = load_calibration(args.calibration) if args.calibration else None
    topics = {key: getattr(args, key) for key in TOPIC_KEYS}

    def show(fr: FrameResult) -> None:
        print(json.dumps(fr.to_json()), flush=True)

    result = replay(
        args.bag,
        config,
        config_file=args.config,
        rate=args.rate,
        on_frame=show if args.json else None,
        warn=lambda message: print(f"mission replay: warning: {message}", file=sys.stderr),
        topics=topics,
        calibration=calibration,
    )
    with_dets = sum(1 for f in result.frames if f.detections)
    ids = sorted({d.marker_id for f in result.frames for d in f.detections if d.marker_id is not None})
    dropped = result.stats.get("dropped_total", 0)
    read = ", ".join(f"{k} {v}" for k, v in result.read.items())
    summary = (
        f"replayed {args.bag} ({result.kind}; {read}): {result.bag_s:.1f} s of recording in {result.wall_s:.1f} s, "
        f"{len(result.frames)} frames processed ({with_dets} with detections, marker ids {ids}), "
        f"{dropped} messages dropped, {result.ticks} ticks, mission state {result.mission_state or '-'}, "
        f"commands {result.commands or '{}'}"
    )
    if result.interrupted:
        summary = f"interrupted: {summary}"
    print(summary, file=sys.stderr if args.json else sys.stdout)
    # the shell's convention for a run a signal ended: 128 + the signal (130 SIGINT, 143 SIGTERM)
    return 128 + result.stop_signal if result.stop_signal is not None else 0
