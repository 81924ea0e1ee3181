"""Ground truth: line of sight and field of view of the target marker, the dock pose, the static map, seeds."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mission.core import blackboard as bbk
from mission.core import se3
from mission.core.types import OccupancyGrid
from mission.sim.scenario import Scenario, load_scenario, scenario_from_dict
from mission.sim.sim_adapter import SimAdapter

TICK = 1 / 15


def scenario(**extra: object) -> Scenario:
    data: dict = {
        "name": "truth_test",
        "robot": {"x": 1.0, "y": 4.0, "yaw_deg": 0.0},
        "random": {"start_xy_m": 0, "start_yaw_deg": 0},
        "camera": {"width": 160, "height": 120},
    }
    data.update(extra)
    return scenario_from_dict(data)


def test_line_of_sight_breaks_while_the_target_passes_behind_a_pillar_and_comes_back() -> None:
    pillar = {"name": "pillar", "shape": "cylinder", "x": 3.5, "y": 4.0, "radius": 0.3, "height": 1.5}
    target = {
        "x": 6.0,
        "y": 2.0,
        "yaw_deg": 90.0,
        "speed_mps": 0.5,
        "start_delay_s": 0.0,
        "waypoints": [{"x": 6.0, "y": 6.0}],
    }
    adapter = SimAdapter(
        scenario(obstacles=[pillar], target=target, random={"start_xy_m": 0, "start_yaw_deg": 0, "timing_frac": 0})
    )
    adapter.setup()
    samples = []
    try:
        while adapter.t < 8.0:
            truth = adapter.ground_truth()
            samples.append((truth.stamp, truth.target.y, truth.target_in_los, truth.target_in_fov))
            adapter.advance(TICK)
    finally:
        adapter.close()
    los = [s[2] for s in samples]
    flips = [i for i in range(1, len(los)) if los[i] != los[i - 1]]
    assert los[0] and los[-1] and len(flips) == 2  # visible → hidden → visible
    hidden_from, hidden_to = samples[flips[0]], samples[flips[1]]
    # The pillar (r 0.3 m, 2.3 m from the camera) shades ±0.6 m of the target's lane 4.6 m away.
    assert hidden_from[1] == pytest.approx(3.4, abs=0.1) and hidden_to[1] == pytest.approx(4.6, abs=0.1)
    assert hidden_to[0] - hidden_from[0] == pytest.approx(2.4, abs=0.25)
    assert all(s[3] for s in samples)  # in the field of view all along: only line of sight changed


def test_the_target_is_out_of_view_behind_the_camera_and_the_reported_marker_faces_the_camera() -> None:
    target = {"x": 3.0, "y": 4.0, "yaw_deg": 180.0}  # its back (marked) face towards the robot's back
    adapter = SimAdapter(scenario(target=target, robot={"x": 5.0, "y": 4.0, "yaw_deg": 0.0}))
    adapter.setup()
    try:
        behind = adapter.ground_truth()
    finally:
        adapter.close()
    assert behind.target_in_los and not behind.target_in_fov
    assert len(behind.T_map_target_markers) == 3  # back, left, right (the default markers)
    normal = behind.T_map_target_marker[:3, 2]
    to_camera = behind.T_map_optical[:3, 3] - behind.T_map_target_marker[:3, 3]
    assert normal @ to_camera / np.linalg.norm(to_camera) > 0.99  # the back face, squarely towards the robot


def test_the_dock_pose_has_z_out_of_the_tag_towards_the_room() -> None:
    adapter = SimAdapter(load_scenario("explore_dock"))
    adapter.setup()
    try:
        truth = adapter.ground_truth()
    finally:
        adapter.close()
    T = truth.T_map_dock
    assert T is not None
    np.testing.assert_allclose(T[:3, 2], [1.0, 0.0, 0.0], atol=1e-9)  # the tag on the west wall faces east
    np.testing.assert_allclose(T[:3, 1], [0.0, 0.0, 1.0], atol=1e-9)  # y up, as seen facing the tag
    assert T[0, 3] == pytest.approx(0.015) and T[1, 3] == pytest.approx(4.0) and T[2, 3] == pytest.approx(0.35)
    assert truth.dock_in_los and not truth.dock_in_fov  # the robot starts facing away from it
    assert adapter.dock_xy == (0.0, 4.0)


def test_the_map_holds_walls_and_static_obstacles_but_not_unknown_obstacles_or_the_target() -> None:
    adapter = SimAdapter(load_scenario("follow_occlusion"))
    adapter.setup()
    try:
        bb = bbk.writer("test")
        adapter.sense(bb)
        grid = bbk.get(bb, bbk.MAP)
    finally:
        adapter.close()
    assert isinstance(grid, OccupancyGrid) and grid is adapter.occupancy_grid
    assert grid.resolution == 0.05 and grid.frame_id == "map"

    def cell(x: float, y: float) -> int:
        return int(grid.data[grid.world_to_cell(x, y)])

    assert cell(2.95, 4.0) == 100  # pillar B
    assert cell(-0.05, 3.0) == 100  # the west wall
    assert cell(5.8, 3.0) == 0  # the crate: an unknown obstacle
    assert cell(2.5, 2.2) == 0  # where the target starts
    assert cell(4.0, 6.0) == 0  # open floor
    assert cell(-0.2, -0.2) == -1  # beyond the walls: unknown


def test_a_seed_repeats_exactly_and_another_seed_varies_start_pose_and_target_timing() -> None:
    def run(seed: int) -> tuple[tuple[float, float, float], tuple[float, float], np.ndarray]:
        adapter = SimAdapter(load_scenario("follow_open"), seed=seed)
        adapter.setup()
        try:
            start = adapter.start_pose
            while adapter.t < 6.0:
                adapter.advance(0.5)
            truth = adapter.ground_truth()
            marker = truth.T_map_target_marker
        finally:
            adapter.close()
        return start, (truth.target.x, truth.target.y), marker

    a, b, c = run(3), run(3), run(4)
    assert a[0] == b[0] and a[1] == b[1]
    np.testing.assert_array_equal(a[2], b[2])
    assert a[0] != c[0]  # start pose jitter
    assert a[1] != c[1]  # target timing
    nominal = load_scenario("follow_open").robot
    for start in (a[0], c[0]):
        assert math.hypot(start[0] - nominal.x, start[1] - nominal.y) <= 0.10
        assert abs(math.degrees(start[2]) - nominal.yaw_deg) <= 5.0


def test_marker_mounting_jitter_moves_the_marker_in_its_face_plane_only() -> None:
    adapter = SimAdapter(scenario(target={"x": 3.0, "y": 4.0, "yaw_deg": 0.0}), seed=11)
    adapter.setup()
    try:
        truth = adapter.ground_truth()
    finally:
        adapter.close()
    back = max(truth.T_map_target_markers, key=lambda T: -T[0, 2])  # the one facing −x
    assert back[0, 3] == pytest.approx(3.0 - 0.205)  # still 5 mm off the back face
    assert abs(back[1, 3] - 4.0) <= 0.005 and abs(back[2, 3] - 0.35) <= 0.005
    assert math.degrees(se3.rotation_angle(back[:3, :3], np.array([[0, 0, -1], [-1, 0, 0], [0, 1, 0]]))) <= 1.0


def test_the_target_waits_for_a_robot_standing_in_its_way_instead_of_driving_through_it() -> None:
    target = {"x": 2.0, "y": 4.0, "speed_mps": 0.5, "start_delay_s": 0.0, "waypoints": [{"x": 7.0, "y": 4.0}]}
    adapter = SimAdapter(
        scenario(
            robot={"x": 4.5, "y": 4.0, "yaw_deg": 180.0},
            target=target,
            random={"start_xy_m": 0, "start_yaw_deg": 0, "timing_frac": 0},
        )
    )
    adapter.setup()
    try:
        while adapter.t < 8.0:
            adapter.advance(TICK)
        truth = adapter.ground_truth()
    finally:
        adapter.close()
    assert truth.target_blocked and not truth.target_moving
    assert 4.5 - 0.22 - 0.2 - 0.06 <= truth.target.x <= 4.5 - 0.22 - 0.2  # a few cm short of the robot
    assert truth.collisions == 0
