"""`mission tree`: the ROS 2 node, exactly what `ros2 run mission tree` (install/mission/lib/mission/tree) runs."""

from __future__ import annotations

import argparse


def main(args: argparse.Namespace) -> int:
    from mission.ros.node import main as node_main

    argv = ["mission-tree"]
    if args.config:
        argv += ["--config", args.config]
    if args.tree:
        argv += ["--tree", args.tree]
    for path in args.params_file or []:
        argv += ["--params-file", path]
    argv += [a for a in (args.ros_args or []) if a != "--"]
    return node_main(argv)
