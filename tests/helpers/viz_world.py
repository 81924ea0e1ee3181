"""A small world for the viewer tests: a camera that sees a real ArUco marker for a while, then loses it.

The robot stands still; the target (marker id 7, 20 cm) stands 1 m in front of the camera for the first
`visible_ticks` ticks and is gone afterwards. Frames are rendered pixels (tools.synthetic_views)
read by the real ArUco source, and the real tree loader builds `WATCH_TREE`, so the viewers watch a real
run: FOLLOW while the marker is seen, then SEARCH, then the tree fails when the short sweep times out.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import py_trees

from mission.app.runner import TreeRunner
from mission.core import blackboard as bbk
from mission.core import se3
from mission.core.config import MissionConfig
from mission.core.types import Frame, NavStatus, OccupancyGrid, Pose2D, RobotState, Twist
from tools.synthetic_views import default_intrinsics, render_marker_view

WATCH_TREE = """<root BTCPP_format="4" main_tree_to_execute="Watch">
  <BehaviorTree ID="Watch">
    <ReactiveFallback name="coordinator">
      <ReactiveSequence name="FOLLOW">
        <IsTargetVisible max_misses="0"/>
        <FollowTarget/>
      </ReactiveSequence>
      <SearchSweep duration_s="0.35"/>
    </ReactiveFallback>
  </BehaviorTree>
</root>
"""
# The same watch with the FOLLOW branch as a SubTree (Groot2's UIDs count the SubTree node too).
SUBTREE_WATCH = """<root BTCPP_format="4" main_tree_to_execute="Watch">
  <BehaviorTree ID="Watch">
    <ReactiveFallback name="coordinator">
      <SubTree ID="FollowWhileSeen" name="follow"/>
      <SearchSweep duration_s="0.35"/>
    </ReactiveFallback>
  </BehaviorTree>
  <BehaviorTree ID="FollowWhileSeen">
    <ReactiveSequence name="FOLLOW">
      <IsTargetVisible max_misses="0"/>
      <FollowTarget/>
    </ReactiveSequence>
  </BehaviorTree>
</root>
"""
WATCH_NODES = [  # the root is named after its tree ID by the loader
    "Watch",
    "FOLLOW",
    "IsTargetVisible",
    "FollowTarget",
    "SearchSweep",
]
CAMERA_EXTRINSICS = se3.transform(se3.R_BODY_OPTICAL, (0.0, 0.0, 0.3))
T_CAM_MARKER = se3.transform(se3.rot_y(np.pi), (0.0, 0.0, 1.0))  # 1 m ahead, facing the camera
WIDTH, HEIGHT = 320, 240


@dataclass
class Truth:
    """What ground_truth() gives viewers (the fields they read from the simulator's GroundTruth)."""

    stamp: float
    robot: Pose2D
    target: Pose2D | None
    target_in_los: bool


class MarkerWorld:
    """A WorldAdapter (mission.core.world) with one camera, one marker and a 4 m × 4 m free map."""

    def __init__(self, visible_ticks: int = 3, dt: float = 0.1) -> None:
        self.visible_ticks = visible_ticks
        self.dt = dt
        self.t = 0.0
        self.seq = 0
        self.robot = Pose2D(0.0, 0.0, 0.0)
        self.intrinsics = default_intrinsics(WIDTH, HEIGHT)
        self.occupancy_grid = OccupancyGrid(np.zeros((80, 80), np.int8), 0.05, Pose2D(-2.0, -2.0, 0.0))
        self.occupancy_grid.data[30:40, 50:60] = 100  # a box, so the map has something on it
        self._rng = np.random.default_rng(0)

    @property
    def marker_visible(self) -> bool:
        return self.seq < self.visible_ticks

    def setup(self) -> None:
        pass

    def sense(self, bb: py_trees.blackboard.Client) -> None:
        if self.marker_visible:
            image = render_marker_view(T_CAM_MARKER, marker_id=7, intrinsics=self.intrinsics, rng=self._rng).image
        else:
            image = np.full((HEIGHT, WIDTH, 3), 128, np.uint8)
        self.seq += 1
        bbk.set_(bb, bbk.CLOCK, self.t)
        bbk.set_(bb, bbk.ROBOT_STATE, RobotState(self.robot, Twist(0.0, 0.0), self.t))
        bbk.set_(bb, bbk.CAMERA_EXTRINSICS, CAMERA_EXTRINSICS)
        bbk.set_(bb, bbk.MAP, self.occupancy_grid)
        bbk.set_(bb, bbk.NAV_STATUS, NavStatus.RUNNING)
        bbk.set_(bb, bbk.FRAME, Frame(image=image, stamp=self.t, intrinsics=self.intrinsics))
        bbk.set_(bb, bbk.FRAME_SEQ, self.seq)

    def act(self, bb: py_trees.blackboard.Client) -> None:  # the robot stands still
        pass

    def advance(self, dt: float) -> None:
        self.t += dt

    def now(self) -> float:
        return self.t

    def close(self) -> None:
        pass

    def ground_truth(self) -> Truth:
        target = Pose2D(1.0, 0.0, np.pi) if self.marker_visible or self.seq <= self.visible_ticks else None
        return Truth(stamp=self.t, robot=self.robot, target=target, target_in_los=target is not None)


def watch_runner(tmp_path: Path, visible_ticks: int = 3) -> tuple[TreeRunner, MarkerWorld]:
    """A set-up TreeRunner on WATCH_TREE in a MarkerWorld (call runner.close() at the end)."""
    tree = tmp_path / "watch.xml"
    tree.write_text(WATCH_TREE)
    world = MarkerWorld(visible_ticks=visible_ticks)
    runner = TreeRunner(MissionConfig(), world, str(tree))
    runner.setup()
    return runner, world


def step(runner: TreeRunner, world: MarkerWorld, n: int = 1) -> None:
    """`n` steps of the runner's loop (sense → perceive → tick → act, observers), each followed by `dt`."""
    for _ in range(n):
        runner.step()
        world.advance(world.dt)
