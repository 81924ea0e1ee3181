"""What the lidar sees move (mission.core.movers), and a search that keeps out of a moving cart's way.

A cart crossing the room is tracked with its velocity from the scans alone; a box standing still and the
map's own walls are not movers; and LOST, choosing where to look from, does not choose the place a
crossing cart is about to drive over (moving_occluder: the robot drove along in front of the cart, the
way the cart went, while the target walked on behind it), but a place the cart uncovers as it drives on."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mission.behaviours.pursue import PursueLastSeen
from mission.behaviours.search_grid import search_grid
from mission.core import blackboard as bbk
from mission.core.movers import MoverTracker
from mission.core.types import LaserScan, OccupancyGrid, Pose2D, TargetTrack
from tests.helpers.behaviour_world import Scene, board, grid_with_boxes, marker_facing, read

BEAMS = 720
HZ = 15.0


def scan_of_boxes(robot: Pose2D, boxes: list[tuple[float, float, float, float]], stamp: float) -> LaserScan:
    """A 360° scan from `robot` of axis-aligned boxes (x0, y0, x1, y1) in the map: the slab method per beam."""
    angles = np.linspace(-math.pi, math.pi, BEAMS, endpoint=False)
    ranges = np.full(BEAMS, np.inf)
    dx, dy = np.cos(angles + robot.yaw), np.sin(angles + robot.yaw)
    with np.errstate(divide="ignore", invalid="ignore"):
        for x0, y0, x1, y1 in boxes:
            tx0, tx1 = (x0 - robot.x) / dx, (x1 - robot.x) / dx
            ty0, ty1 = (y0 - robot.y) / dy, (y1 - robot.y) / dy
            near = np.maximum(np.minimum(tx0, tx1), np.minimum(ty0, ty1))
            far = np.minimum(np.maximum(tx0, tx1), np.maximum(ty0, ty1))
            hit = (near <= far) & (far > 0) & (near > 0)
            ranges = np.where(hit, np.minimum(ranges, near), ranges)
    return LaserScan(
        angle_min=-math.pi,
        angle_increment=2 * math.pi / BEAMS,
        ranges=ranges.astype(np.float32),
        range_min=0.1,
        range_max=10.0,
        stamp=stamp,
    )


def cart_at(t: float, x0: float = -1.6, y: float = 0.0, speed: float = 0.35) -> tuple[float, float, float, float]:
    """A 1.2 m × 0.6 m cart driving east at `speed` along y, its west end at x0 when t = 0."""
    x = x0 + speed * t
    return (x, y - 0.3, x + 1.2, y + 0.3)


def track(grid: OccupancyGrid | None, robot: Pose2D, boxes_at, seconds: float) -> MoverTracker:
    tracker = MoverTracker()
    for i in range(int(seconds * HZ) + 1):
        t = i / HZ
        movers = tracker.update(scan_of_boxes(robot, boxes_at(t), t), robot, grid, t)
    assert isinstance(movers, tuple)
    return tracker


def test_a_cart_crossing_in_front_of_the_robot_is_tracked_with_its_velocity_and_width():
    robot = Pose2D(0.0, -1.5, math.pi / 2)
    tracker = track(None, robot, lambda t: [cart_at(t)], 2.0)
    (cart,) = tracker.movers()
    assert cart.velocity[0] == pytest.approx(0.35, abs=0.05) and abs(cart.velocity[1]) < 0.05
    assert 1.0 < cart.width_m < 1.4  # its long side, seen from the robot
    ahead = cart.swept(3.0)
    assert ahead[:, 0].max() > cart.points[:, 0].max() + 0.8  # 3 s on, it is about a metre further east


def test_a_box_standing_still_and_the_maps_own_walls_are_not_movers():
    walls = [(-5.0, -5.0, 5.0, -4.8), (-5.0, 4.8, 5.0, 5.0), (-5.0, -5.0, -4.8, 5.0), (4.8, -5.0, 5.0, 5.0)]
    room = grid_with_boxes(walls)
    crate = (1.0, 1.0, 1.6, 1.6)
    tracker = MoverTracker()
    for i in range(45):  # the robot drives past both for 3 s: every return moves in its own frame
        t = i / HZ
        robot = Pose2D(-2.0 + 0.4 * t, -1.0, 0.0)
        tracker.update(scan_of_boxes(robot, [*walls, crate], t), robot, room, t)
    assert tracker.movers() == ()


def _crosses(a: tuple[float, float], b: tuple[float, float], box: tuple[float, float, float, float]) -> bool:
    """Whether the segment a→b passes through the axis-aligned box (x0, y0, x1, y1)."""
    ts = np.linspace(0.0, 1.0, 200)
    xs, ys = a[0] + ts * (b[0] - a[0]), a[1] + ts * (b[1] - a[1])
    return bool(((xs > box[0]) & (xs < box[2]) & (ys > box[1]) & (ys < box[3])).any())


def test_lost_looks_from_off_a_crossing_carts_way_where_the_view_opens_first():
    # The robot is south of a cart driving east across its view; the target was last seen just north of the
    # cart's east end, walking north. The nearest place that sees where it went is beside the cart's east
    # end — where the cart will be in a second or two. LOST takes a place off the cart's way, from which
    # the cart, driving on, uncovers the walk sooner than the drive round behind its west end would
    # (≥ 1.5 m at the pursuit's 0.35 m/s: over 4 s).
    grid = grid_with_boxes([])
    robot = Pose2D(0.2, -1.6, math.pi / 2)
    plans = {}

    def lost_view(with_movers: bool) -> tuple[float, float]:
        scene = Scene(robot=robot, grid=grid, clock=1.5)
        tracker = track(grid, robot, lambda t: [cart_at(t)], 1.5)
        scene.scan = scan_of_boxes(robot, [cart_at(1.5)], 1.5)
        last = TargetTrack("target", last_seen=1.2, misses=9, pose_map=marker_facing(0.3, 0.6, -math.pi / 2))
        last.history = [(0.2 + 0.1 * i, 0.3, 0.6 - 0.3 * (1.0 - 0.1 * i)) for i in range(11)]
        bbk.set_(board(), bbk.TRACKS, {"target": last})
        bbk.set_(board(), bbk.MOVERS, tracker.movers() if with_movers else ())
        node = PursueLastSeen()
        scene.cycle(node)
        assert read(bbk.STATE) == "LOST"
        plans[with_movers] = node.pursuit
        view = node.pursuit.view
        return view.x, view.y

    sg = search_grid(grid)
    xs, ys = sg.centres()
    west, east = cart_at(1.5)[0], cart_at(1.5)[2]
    driven_over = (xs > west) & (xs < east + 0.35 * 3.0 + 0.35) & (np.abs(ys) < 0.3 + 0.35)
    before = lost_view(with_movers=False)
    assert driven_over[sg.cell(*before)], "the scene no longer shows the fault: LOST chose a place off the cart's way"
    after = lost_view(with_movers=True)
    assert not driven_over[sg.cell(*after)]
    plan = plans[True]
    opens = plan.opens_at if plan.opens_at is not None else 1.5 + plan.path_m / 0.35
    assert opens - 1.5 < 4.0, "no sooner than driving round behind the cart"
    assert _crosses(after, plan.aim, cart_at(1.5)), "the scene no longer shows the cart in the way now"
    assert not _crosses(after, plan.aim, cart_at(opens)), "the cart, where it really is then, hides the walk"
