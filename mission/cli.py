"""The `mission` command line: one parser, one module per verb under mission/commands/.

Exit codes: 0 success, 1 the mission / detection failed, 2 usage or config error, 141 (128 + SIGPIPE)
when the reader of stdout went away (`… | head -1`), as for any Unix tool.
"""

from __future__ import annotations

import argparse
import contextlib
import errno
import importlib
import math
import os
import signal
import sys
from collections.abc import Callable, Sequence
from typing import Any

from mission.core.errors import MissionError

VERBS = {
    "run": "run a mission in the pybullet simulation (the embedded default world)",
    "detect": "run a perception source on image files",
    "viz": "draw a tree file (unicode, ascii, dot, svg, png, html) or a recorded tick",
    "plugins": "list installed perception plugins",
    "tree": "the ROS 2 node (also installed as lib/mission/tree for `ros2 run mission tree`)",
    "sim-robot": "the pybullet world as a ROS 2 robot (camera, odom, scan, map, TF, /clock; navigate_to_pose)",
    "task": "send Nav2's dock_robot, undock_robot or follow_object goal and watch it (nav2_simple_commander's calls)",
    "replay": "run the tree on a recorded bag (ROS 1 or rosbag2)",
    "sweep": "scenarios × seeds × --set values on Dask (local or a cluster): results table + summary",
    "bench": "run the benchmarks and write their figures",
    "nodes-model": "write the Groot2 palette (TreeNodesModel) of every registered behaviour, installed ones too",
}
FORWARDING = {"bench"}  # verbs that hand every argument to another program (`python -m bench`)


def _number(convert: Callable[[str], float], ok: Callable[[float], bool], expected: str) -> Callable[[str], Any]:
    """An argparse type: `convert` the text and accept it when `ok`, else say what was `expected`."""

    def parse(text: str) -> float:
        try:
            value = convert(text)
        except ValueError:
            value = None
        if value is None or not ok(value):
            raise argparse.ArgumentTypeError(f"expected {expected}, got {text!r}")
        return value

    return parse


positive_seconds = _number(float, lambda v: math.isfinite(v) and v > 0, "seconds (a finite number > 0)")
non_negative_seconds = _number(float, lambda v: math.isfinite(v) and v >= 0, "seconds (a finite number ≥ 0)")
finite = _number(float, math.isfinite, "a finite number")
non_negative_int = _number(int, lambda v: v >= 0, "a whole number ≥ 0")
positive_int = _number(int, lambda v: v >= 1, "a whole number ≥ 1")
rate = _number(float, lambda v: math.isfinite(v) and v >= 0, "a finite number ≥ 0 (0 = as fast as possible)")
port = _number(int, lambda v: 0 <= v <= 65535, "a TCP port, a whole number 0–65535 (0 = any free port)")
port_pair = _number(int, lambda v: 0 <= v <= 65534, "a TCP port 0–65534 (PORT and PORT+1 are used; 0 = any free pair)")


def _add_run(p: argparse.ArgumentParser) -> None:
    p.add_argument("--scenario", default=None, help="scenario name under sim/scenarios/ or a YAML path")
    p.add_argument(
        "--config", default=None, help="mission config YAML (default: the scenario's `config`, else built in)"
    )
    p.add_argument("--tree", default=None, help="tree XML file (overrides the config's `tree`)")
    p.add_argument("--seed", type=non_negative_int, default=0, help="randomisation seed (default 0)")
    p.add_argument("--report", default=None, metavar="DIR", help="write report.json and pictures to DIR")
    p.add_argument("--max-duration", type=positive_seconds, default=None, help="simulated seconds before giving up")
    p.add_argument("--record", default=None, metavar="FILE", help="record the camera + map view (.gif/.mp4)")
    p.add_argument("--record-bag", default=None, metavar="PATH", help="record sensors as a rosbag2")
    p.add_argument("--log", default=None, metavar="FILE", help="record every tick as JSON lines")
    p.add_argument("--serve", action="store_true", help="serve a live web view on localhost")
    p.add_argument(
        "--port", type=port, default=8765, help="port for --serve, 0–65535 (127.0.0.1 only; 0 picks a free one)"
    )
    p.add_argument(
        "--groot",
        type=port_pair,
        nargs="?",
        const=1667,
        default=None,
        metavar="PORT",
        help="serve Groot2's live monitor on 127.0.0.1:PORT and PORT+1 (default 1667; 0 = any free)",
    )
    p.add_argument(
        "--btlog",
        default=None,
        metavar="FILE",
        help="write a Groot2 log (.btlog, BT.CPP FileLogger2) of every node's transitions",
    )
    p.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="a tree port, config or scenario key for this run (repeatable), e.g. "
        "--set SearchSweep.angular_speed=0.8 --set run.tick_hz=10 --set camera.width=320",
    )
    p.add_argument("--quiet", action="store_true", help="no live progress, only the result line")


def _add_detect(p: argparse.ArgumentParser) -> None:
    p.add_argument("images", nargs="+", metavar="IMAGE", help="image files (PNG, JPEG, …)")
    p.add_argument("--source", default="aruco", help="perception plugin name (default aruco)")
    p.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="plugin param, YAML value (repeatable), e.g. --set marker_size_m=0.15",
    )
    p.add_argument(
        "--intrinsics",
        default=None,
        metavar="FX,FY,CX,CY",
        help="camera intrinsics; without them the fallback pinhole is used (fx=fy=0.9·W)",
    )
    p.add_argument(
        "--calibration",
        default=None,
        metavar="FILE",
        help="camera calibration file (ROS camera_info YAML or OpenCV YAML) instead of --intrinsics",
    )
    p.add_argument(
        "--depth",
        action="append",
        default=[],
        metavar="FILE",
        help="depth image for an IMAGE, in order (16-bit PNG/TIFF in mm, or .npy/float TIFF in m)",
    )
    p.add_argument("--json", action="store_true", help="one JSON object per image on stdout")


def _add_viz(p: argparse.ArgumentParser) -> None:
    p.add_argument("tree", nargs="?", default=None, metavar="TREE.xml", help="a tree file or a shipped tree name")
    p.add_argument(
        "--format",
        default="unicode",
        choices=["unicode", "ascii", "dot", "svg", "png", "html"],
        help="unicode|ascii|dot|svg|png|html (svg/html need no Graphviz; png uses `dot` when present)",
    )
    p.add_argument("-o", "--output", default=None, metavar="FILE", help="write here instead of stdout")
    p.add_argument(
        "--log",
        default=None,
        metavar="FILE",
        help="a JSON-lines tick log (`mission run --log`) or a Groot2 .btlog (`--btlog`, BT.CPP's)",
    )
    p.add_argument(
        "--tick",
        type=non_negative_int,
        default=None,
        help="with --log: the tree as it was at tick N (a .btlog: at its Nth timestamp)",
    )
    p.add_argument(
        "--nodes-model",
        action="append",
        default=[],
        metavar="FILE",
        help="a BT.CPP file whose <TreeNodesModel> describes nodes this project does not register "
        "(Nav2's nav2_tree_nodes.xml, say): they are drawn, not run; repeatable",
    )


def _add_tree(p: argparse.ArgumentParser) -> None:
    p.add_argument("--config", default=None, help="mission config YAML")
    p.add_argument("--tree", default=None, help="tree file, shipped tree name, or `none` (perception only)")
    p.add_argument(
        "--params-file",
        action="append",
        default=[],
        metavar="FILE",
        help="with --tree none: a Nav2 params file (docking_server / following_server keys); repeatable",
    )
    p.epilog = "ROS arguments follow --ros-args, e.g. `mission tree --ros-args -p image_topic:=/cam/image`"
    # `--ros-args -p name:=value …` is collected by main() (argparse cannot take options it does not know).
    p.set_defaults(ros_args=[])


def _add_sim_robot(p: argparse.ArgumentParser) -> None:
    p.add_argument("--scenario", default=None, help="scenario name under sim/scenarios/ or a YAML path")
    p.add_argument(
        "--config",
        default=None,
        help="mission config YAML (its `sim:` keys apply; default: the scenario's `config`, else built in)",
    )
    p.add_argument("--seed", type=non_negative_int, default=0, help="randomisation seed (default 0)")
    p.add_argument("--report", default=None, metavar="DIR", help="write report.json and pictures to DIR at the end")
    p.add_argument("--max-duration", type=positive_seconds, default=None, help="simulated seconds before stopping")
    p.add_argument("--rate", type=rate, default=1.0, help="sim time per wall second (1.0 = real time; 0 = flat out)")
    p.add_argument(
        "--serve",
        action="store_true",
        help="the node serves Nav2's actions (tree:=none): its trees ending do not end the run",
    )
    p.add_argument(
        "--fault",
        action="append",
        default=[],
        metavar="NAME[=VALUE]",
        help="abort_goals, no_nav_server, no_tf, tf_loop, tf_stale_at=S, clock_back_at=S, image_delay_s=D (repeatable)",
    )


def _add_task(p: argparse.ArgumentParser) -> None:
    sub = p.add_subparsers(dest="action", required=True, metavar="ACTION")
    common = argparse.ArgumentParser(add_help=False)
    common.add_argument(
        "--namespace",
        default=None,
        metavar="NS",
        help="the servers' namespace: the goal goes to /NS/ACTION (default: none)",
    )
    common.add_argument(
        "--server-timeout",
        type=positive_seconds,
        default=5.0,
        metavar="S",
        help="wait this long for the action server (exit 2 without one) and for each of its answers",
    )
    what = "dock at a dock of the server's database (--id) or at a pose (--pose): dock_robot"
    dock = sub.add_parser("dock", parents=[common], help=what, description=what)
    where = dock.add_mutually_exclusive_group(required=True)
    where.add_argument("--id", default=None, metavar="DOCK_ID", help="a dock in the server's dock database")
    where.add_argument(
        "--pose",
        type=finite,
        nargs=3,
        default=None,
        metavar=("X", "Y", "YAW"),
        help="the dock's pose (the robot's when docked), m and rad",
    )
    dock.add_argument(
        "--type",
        default=None,
        metavar="TYPE",
        help="with --pose: the dock's type (a dock_plugins name); not needed when the server has one",
    )
    dock.add_argument("--frame", default=None, metavar="FRAME", help="with --pose: the pose's frame (default map)")
    dock.add_argument(
        "--no-nav", action="store_true", help="the robot is at the staging pose already: do not navigate there first"
    )
    dock.add_argument(
        "--max-staging-time",
        type=non_negative_seconds,
        default=None,
        metavar="S",
        help="seconds to reach the staging pose (default: the goal's 1000)",
    )
    what = "undock from the dock the robot is on: undock_robot"
    undock = sub.add_parser("undock", parents=[common], help=what, description=what)
    undock.add_argument(
        "--type",
        default=None,
        metavar="TYPE",
        help="the dock's type, when the server did not dock the robot itself and knows several",
    )
    undock.add_argument(
        "--max-undocking-time",
        type=non_negative_seconds,
        default=None,
        metavar="S",
        help="seconds to undock (default: the goal's 30)",
    )
    what = "follow an object by its pose topic (--topic) or its TF frame (--frame): follow_object"
    follow = sub.add_parser("follow", parents=[common], help=what, description=what)
    target = follow.add_mutually_exclusive_group(required=True)
    target.add_argument(
        "--topic", default=None, metavar="TOPIC", help="the object's pose (geometry_msgs/PoseStamped) is published here"
    )
    target.add_argument("--frame", default=None, metavar="FRAME", help="the object is this TF frame")
    follow.add_argument(
        "--max-duration",
        type=non_negative_seconds,
        default=0.0,
        metavar="S",
        help="stop following after S seconds (succeeded); default 0: until canceled or failed",
    )
    p.epilog = (
        "Ctrl-C cancels the running goal (and waits for the server to end it); exit 0 succeeded, 1 failed, "
        "2 bad arguments or no action server"
    )


def _add_replay(p: argparse.ArgumentParser) -> None:
    p.add_argument("bag", metavar="BAG", help="a ROS 1 .bag file or a rosbag2 directory (sqlite3 or mcap)")
    p.add_argument("--config", default=None, help="mission config YAML")
    p.add_argument("--rate", type=rate, default=0.0, help="1.0 = recorded rate; 0 = as fast as possible")
    p.add_argument("--json", action="store_true", help="print detections as JSON lines")
    for name, what in (
        ("image", "camera images, raw or compressed"),
        ("camera-info", "sensor_msgs/CameraInfo"),
        ("depth", "depth images, raw or compressedDepth"),
        ("odom", "nav_msgs/Odometry"),
        ("scan", "sensor_msgs/LaserScan"),
        ("map", "nav_msgs/OccupancyGrid"),
    ):
        p.add_argument(
            f"--{name}-topic",
            default=None,
            metavar="TOPIC",
            help=f"{what} (default: the config's topics section, else the node's default)",
        )
    p.add_argument(
        "--calibration",
        default=None,
        metavar="FILE",
        help="camera calibration (ROS camera_info YAML or OpenCV YAML) for every frame",
    )


def _add_sweep(p: argparse.ArgumentParser) -> None:
    p.add_argument("--scenarios", default=None, metavar="A,B,…", help="scenario names or YAML paths, comma-separated")
    p.add_argument("--seeds", default=None, metavar="A-B", help="seeds: A-B (inclusive), N, or a comma list of them")
    p.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="KEY=V1,V2",
        help="a grid axis (repeatable): a tree port, config or scenario key and its values, "
        "e.g. --set SearchSweep.angular_speed=0.6,1.0 --set run.tick_hz=10,15",
    )
    p.add_argument(
        "--config", default=None, help="mission config YAML for every run (default: each scenario's `config`)"
    )
    p.add_argument("--tree", default=None, help="tree XML file for every run (overrides the config's `tree`)")
    p.add_argument("--max-duration", type=positive_seconds, default=None, help="simulated seconds per run at most")
    p.add_argument(
        "--out",
        default="out/sweep",
        metavar="DIR",
        help="sweep directory (default out/sweep); the same --out resumes: finished runs are skipped",
    )
    p.add_argument(
        "--scheduler",
        default=None,
        metavar="ADDR",
        help="an existing Dask scheduler (tcp://host:8786); default: a local cluster on 127.0.0.1",
    )
    p.add_argument(
        "--workers", type=positive_int, default=None, help="local cluster: worker processes (default: one per core)"
    )
    p.add_argument(
        "--dashboard",
        type=port,
        default=None,
        metavar="PORT",
        help="local cluster: the scheduler's HTTP port on 127.0.0.1 (default: any free; needs bokeh)",
    )
    p.add_argument(
        "--pictures",
        default="all",
        choices=["all", "failed", "none"],
        help="report pictures for all runs (default), failed runs only, or none (report.json always)",
    )
    p.add_argument("--quiet", action="store_true", help="no progress bar, only the result lines")
    p.add_argument(
        "--compare",
        nargs=2,
        default=None,
        metavar=("A", "B"),
        help="compare two sweep directories cell by cell, with a significance note on each rate",
    )
    p.add_argument("-o", "--output", default=None, metavar="FILE.html", help="with --compare: also write a page")


def _add_bench(p: argparse.ArgumentParser) -> None:
    """No arguments of its own: all of them (--help too) go to the checkout's runner (`python -m bench`)."""


def _add_nodes_model(p: argparse.ArgumentParser) -> None:
    out = p.add_mutually_exclusive_group()
    out.add_argument(
        "-o", "--output", default=None, metavar="FILE", help="write a models file Groot2 can import (default: stdout)"
    )
    out.add_argument(
        "--into", default=None, metavar="TREE.xml", help="replace (or add) the TreeNodesModel section of this tree file"
    )
    p.epilog = "behaviours come from the shipped set and every installed package's `mission.behaviours` entry points"


def _version() -> str:
    """The installed distribution's version (``mission --version``)."""
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("mission")
    except PackageNotFoundError:
        return "unknown (not installed)"


PATH_OPTIONS = ("config", "report", "log", "record", "record_bag", "btlog", "output", "into", "out", "calibration")


def _no_empty_paths(parser: argparse.ArgumentParser, args: argparse.Namespace) -> None:
    """An option that takes a path, given an empty one (``--report ''``), is a usage error: it was read as
    "not given" and silently ignored."""
    for name in PATH_OPTIONS:
        if getattr(args, name, None) == "":
            parser.error(f"argument --{name.replace('_', '-')}: expected a path, got an empty string")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="mission", description="Behaviour-tree missions for camera robots.")
    parser.add_argument("--version", action="version", version=f"mission {_version()}")
    sub = parser.add_subparsers(dest="verb", required=True, metavar="VERB")
    adders = {
        "run": _add_run,
        "detect": _add_detect,
        "viz": _add_viz,
        "tree": _add_tree,
        "sim-robot": _add_sim_robot,
        "task": _add_task,
        "replay": _add_replay,
        "sweep": _add_sweep,
        "bench": _add_bench,
        "plugins": lambda p: None,
        "nodes-model": _add_nodes_model,
    }
    for verb, help_text in VERBS.items():
        p = sub.add_parser(verb, help=help_text, description=help_text, add_help=verb not in FORWARDING)
        adders[verb](p)
    return parser


class Terminated(BaseException):
    """SIGTERM before a verb has its own handling (imports, set-up): stop as Ctrl-C does, with 143."""


def _terminate(_signum: int, _frame: object) -> None:
    raise Terminated


def main(argv: Sequence[str] | None = None) -> int:
    """Run one verb; its exit code."""
    if signal.getsignal(signal.SIGTERM) == signal.SIG_DFL:  # an inherited "ignore" (nohup) is kept
        signal.signal(signal.SIGTERM, _terminate)  # a run's loop installs its own and restores this one
    try:
        code = _main(argv)
        sys.stdout.flush()  # here, not in the interpreter's exit: a closed pipe is then ours to report
        return code
    except BrokenPipeError:
        return _output_closed()
    except OSError as err:
        if err.errno not in (errno.ENOSPC, errno.EIO, errno.EBADF):
            raise
        return _output_failed(err)
    except (KeyboardInterrupt, Terminated, RuntimeError) as err:
        # Ctrl-C or SIGTERM before a verb has its own handling (imports, set-up): one line, no traceback. One
        # that lands while an import runs a class body's __set_name__ comes out wrapped in a RuntimeError
        # (Python 3.11; lark's Transformer, seen under a loaded test run): a stop all the same.
        stop = _stopping_signal(err)
        if stop is None:
            raise
        print(f"mission: {'interrupted' if stop == signal.SIGINT else 'terminated'}", file=sys.stderr)
        return 128 + stop


def _stopping_signal(err: BaseException) -> int | None:
    """SIGINT or SIGTERM when `err` is, or was caused by, Ctrl-C or SIGTERM (through its chain), else None."""
    seen: set[int] = set()
    cause: BaseException | None = err
    while cause is not None and id(cause) not in seen:
        seen.add(id(cause))
        if isinstance(cause, KeyboardInterrupt):
            return signal.SIGINT
        if isinstance(cause, Terminated):
            return signal.SIGTERM
        cause = cause.__cause__ or cause.__context__
    return None


def _output_failed(err: OSError) -> int:
    """stdout cannot be written (a full disk, `> /dev/full`, a closed descriptor): one line on stderr naming it,
    exit 74 (sysexits' EX_IOERR), no traceback; what was written before stays as it was."""
    _stdout_to_devnull()
    with contextlib.suppress(OSError, ValueError):
        print(f"mission: error: cannot write the output (stdout): {err.strerror or err}", file=sys.stderr)
    return 74


def _output_closed() -> int:
    """The reader of our output went away (`mission detect --json IMG... | head -1`): stop as `cat` does.

    Nothing more is written and no traceback is printed. stdout is pointed at /dev/null first, so the
    interpreter's final flush of what is still buffered cannot fail ("Exception ignored … BrokenPipeError").
    The exit status is 141 = 128 + SIGPIPE, the status a shell reports for `cat` or `yes` in the same place
    (they die of SIGPIPE; Python ignores that signal, and dying of it here would skip cleanup), so
    `set -o pipefail` scripts see what they see for any Unix tool.
    """
    _stdout_to_devnull()
    return 128 + signal.SIGPIPE


def _stdout_to_devnull() -> None:
    """Point stdout at /dev/null, so the interpreter's final flush of what is still buffered cannot fail again."""
    with contextlib.suppress(OSError, ValueError):  # ValueError: stdout is not a real file (captured, closed)
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        os.close(devnull)


def _module(verb: str) -> str:
    """The module of a verb under mission/commands/ (``nodes-model`` → ``nodes_model``)."""
    return verb.replace("-", "_")


def _main(argv: Sequence[str] | None) -> int:
    parser = build_parser()
    args, extra = parser.parse_known_args(argv)
    _no_empty_paths(parser, args)
    if args.verb in FORWARDING:
        args.forwarded, extra = extra, []
    if extra:
        if args.verb != "tree" or "--ros-args" not in extra:
            parser.error(f"unrecognized arguments: {' '.join(extra)}")
        # Everything from --ros-args on goes to rclpy, as `ros2 run mission tree --ros-args …` does.
        args.ros_args = extra[extra.index("--ros-args") :]
    try:
        module = importlib.import_module(f"mission.commands.{_module(args.verb)}")
    except ModuleNotFoundError as err:
        if err.name == f"mission.commands.{_module(args.verb)}":
            print(f"mission: error: `mission {args.verb}` is not available in this build", file=sys.stderr)
            return 2
        raise
    try:
        if getattr(args, "config", None):  # a shipped config by name, as trees and scenarios are named
            from mission.app.shipped import resolve_config

            args.config = resolve_config(args.config)
        return int(module.main(args) or 0)
    except MissionError as err:
        for line in str(err).splitlines():  # several problems (a config file's): one line each, each prefixed
            print(f"mission: error: {line}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        return 130


if __name__ == "__main__":
    sys.exit(main())
