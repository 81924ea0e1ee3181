"""`mission sim-robot`: the pybullet world as a ROS 2 robot (mission/ros/sim_robot_node.py) for the node to drive.

Run the node in another terminal (`ros2 run mission tree --ros-args -p use_sim_time:=true`). At the end of the
scenario's duration (or when the node's tree finishes, or on SIGINT/SIGTERM) the run is scored against ground
truth exactly as `mission run` scores it, and `--report DIR` gets the same report.json and pictures.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from mission.app.runner import WallClockPacer
from mission.app.sim_run import run_scenario
from mission.commands.run import DEFAULT_SCENARIO, _check_report_dir, result_line
from mission.ros import dds
from mission.viz.run_report import write_report


def main(args: argparse.Namespace) -> int:
    _check_report_dir(args)
    for note in dds.configure_transport():
        print(f"[sim_robot] {note}")
    from mission.ros.sim_robot_node import Faults, SimRobot

    faults = Faults.parse(args.fault or [])
    scenario = args.scenario or DEFAULT_SCENARIO
    label = f"{Path(scenario).stem} seed {args.seed} (sim-robot)"
    pacer = WallClockPacer(args.rate) if args.rate > 0 else None
    outcome, recorder, adapter = run_scenario(
        scenario,
        config_file=args.config,
        seed=args.seed,
        max_duration=args.max_duration,
        pacer=pacer,
        robot=lambda sim: SimRobot(sim, faults, serve=args.serve),
    )
    if args.report:
        write_report(args.report, outcome, recorder, adapter)
    return result_line(outcome, label, args.report, perception=False)
