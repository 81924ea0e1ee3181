"""Injected faults in real closed-loop sim runs: the tree keeps ticking, the report counts what happened,
and the mission either completes or fails with a reason a person can read.

Each run is short (8–12 simulated seconds of follow_open at 240×180, aruco on the target's tag 7) with one
fault switched on through the config's ``sim: faults:`` override — the way a user would switch it on.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

from mission.app.sim_run import RunOutcome, run_scenario, shipped_config
from mission.core import blackboard as bbk
from mission.core.errors import ConfigError
from mission.core.observers import RunObserver, Tick
from mission.core.types import Frame
from mission.perception_plugins.pipeline import PerceptionStage
from mission.sim.scenario import load_scenario
from mission.sim.scenario_overrides import apply_overrides
from tests.helpers.behaviour_world import IMAGE, ScriptedSource, board, read

TICK_HZ = 15.0


def run_with(
    tmp_path: Path,
    faults: dict[str, Any],
    *,
    seconds: float = 8.0,
    config: str = "sim_aruco.yaml",
    scenario: str = "follow_open",
    observers: list | None = None,
    size: int = 240,
) -> RunOutcome:
    """follow_open with `faults` set in the mission config's sim overrides, like a user's config file."""
    cfg = yaml.safe_load(shipped_config(config).read_text())
    sim = dict(cfg.get("sim") or {})
    sim["camera"] = {**sim.get("camera", {}), "width": size, "height": size * 3 // 4}
    sim["faults"] = faults
    cfg["sim"] = sim
    path = tmp_path / "faults.yaml"
    path.write_text(yaml.safe_dump(cfg))
    outcome, _, _ = run_scenario(scenario, config_file=path, max_duration=seconds, observers=observers)
    return outcome


def assert_kept_ticking_and_readable(outcome: RunOutcome, seconds: float) -> None:
    assert outcome.ticks >= int(seconds * TICK_HZ), f"only {outcome.ticks} ticks in {seconds} s: the tree stopped"
    assert outcome.success or (outcome.reason and len(outcome.reason) > 5), f"failed without a reason: {outcome}"


def test_a_camera_blackout_is_ridden_out_and_the_gap_is_in_the_report(tmp_path: Path) -> None:
    outcome = run_with(tmp_path, {"camera_blackout": [{"at_s": 3.0, "frames": 20}]})
    assert_kept_ticking_and_readable(outcome, 8.0)
    injected = outcome.faults["injected"]
    assert injected["camera_blackout_frames"] == 20
    assert injected["max_frame_gap_s"] >= 20 / TICK_HZ  # no frame at all for the 1.3 s blackout
    assert outcome.faults["counted"]["frames_processed"] < outcome.ticks


def test_dropped_frames_are_counted_as_missing_and_the_mission_goes_on(tmp_path: Path) -> None:
    outcome = run_with(tmp_path, {"frame_drop_prob": 0.3})
    assert_kept_ticking_and_readable(outcome, 8.0)
    dropped = outcome.faults["injected"]["frames_dropped"]
    assert dropped > 10
    assert outcome.faults["counted"]["frames_processed"] <= outcome.ticks - dropped


def test_a_duplicated_frame_is_recognised_and_not_processed_twice(tmp_path: Path) -> None:
    outcome = run_with(tmp_path, {"frame_duplicate_prob": 0.2})
    assert_kept_ticking_and_readable(outcome, 8.0)
    assert outcome.faults["injected"]["frames_duplicated"] > 5
    injected, counted = outcome.faults["injected"]["frames_duplicated"], outcome.faults["counted"]["frames_duplicate"]
    # a duplicate right behind another one's is the newest frame the tree has seen, so it is processed once
    assert 0.75 * injected <= counted <= injected


class StaleWatch(RunObserver):
    """Records, per tick, the stamp of the delivered frame and the target track it left behind."""

    def __init__(self) -> None:
        self.rows: list[tuple[float | None, float | None, np.ndarray | None, int]] = []
        self._seq = -1

    def on_tick(self, runner: Any, tick: Tick) -> None:
        seq = runner.get(bbk.FRAME_SEQ)
        frame = runner.get(bbk.FRAME)
        stamp = float(frame.stamp) if frame is not None and seq != self._seq else None
        self._seq = seq
        track = (runner.get(bbk.TRACKS) or {}).get("target")
        pose = None if track is None or track.pose_map is None else track.pose_map.copy()
        stale = int((runner.get(bbk.PERCEPTION_STATS) or {}).get("frames_stale", 0))
        self.rows.append((stamp, None if track is None else track.last_seen, pose, stale))


def test_late_out_of_order_frames_never_move_the_target_back(tmp_path: Path) -> None:
    watch = StaleWatch()
    outcome = run_with(tmp_path, {"late_frame_prob": 0.25, "late_by_s": 0.4}, seconds=10.0, observers=[watch])
    assert_kept_ticking_and_readable(outcome, 10.0)
    late = outcome.faults["injected"]["frames_late"]
    assert late > 10
    assert outcome.faults["counted"]["frames_stale"] >= late - 2  # a late frame after a gap may still be newest
    last_seen = [r[1] for r in watch.rows if r[1] is not None]
    assert last_seen == sorted(last_seen), "a late frame moved the track back in time"
    stale_ticks = 0
    for prev, row in zip(watch.rows, watch.rows[1:], strict=False):
        if row[3] > prev[3]:  # this tick's frame was dropped as stale: the track (and so the goal) did not move
            stale_ticks += 1
            assert row[1] == prev[1]
            assert (row[2] is None and prev[2] is None) or np.array_equal(row[2], prev[2])
    assert stale_ticks >= late - 2


def test_lidar_dropout_leaves_the_navigator_on_its_last_scan(tmp_path: Path) -> None:
    outcome = run_with(tmp_path, {"lidar_dropout": [{"at_s": 2.0, "duration_s": 4.0}]})
    assert_kept_ticking_and_readable(outcome, 8.0)
    injected = outcome.faults["injected"]
    assert injected["scans_dropped"] >= 35  # 4 s at 10 Hz
    assert injected["max_scan_gap_s"] >= 3.9
    assert outcome.metrics["collisions"] == 0


def test_a_teleporting_target_is_found_again_or_reported_lost(tmp_path: Path) -> None:
    outcome = run_with(tmp_path, {"target_teleport": [{"at_s": 4.0, "skip_s": 5.0}]}, seconds=12.0)
    assert_kept_ticking_and_readable(outcome, 12.0)
    assert outcome.faults["injected"]["target_teleports"] == 1
    assert outcome.faults["counted"]["frames_processed"] > 100


def test_a_robot_kicked_off_its_path_recovers_without_collision(tmp_path: Path) -> None:
    outcome = run_with(tmp_path, {"robot_kick": [{"at_s": 4.0, "dx": 0.3, "dy": 0.2, "dyaw_deg": 60}]}, seconds=12.0)
    assert_kept_ticking_and_readable(outcome, 12.0)
    assert outcome.faults["injected"]["robot_kicks"] == 1
    assert outcome.metrics["collisions"] == 0


def test_a_plugin_raising_on_every_third_frame_is_isolated_and_counted(tmp_path: Path, caplog) -> None:
    outcome = run_with(tmp_path, {"plugin_raise_every": 3})
    assert_kept_ticking_and_readable(outcome, 8.0)
    raised = outcome.faults["injected"]["plugin_raises:aruco"]
    assert raised >= 30
    assert outcome.faults["counted"]["source_errors:aruco"] == raised
    logged = [r for r in caplog.records if "InjectedFault" in r.getMessage()]
    assert len(logged) == 1, "a failing plugin is logged once, then counted"
    assert outcome.success, outcome.reason  # two frames in three are enough to follow


@pytest.mark.slow
@pytest.mark.parametrize("mode", ["timeout", "garbage"])
def test_a_vlm_that_times_out_or_answers_garbage_does_not_stop_the_mission(tmp_path: Path, mode: str) -> None:
    outcome = run_with(tmp_path, {"vlm": {"mode": mode, "every": 2}}, config="sim_vlm.yaml", seconds=12.0, size=320)
    assert_kept_ticking_and_readable(outcome, 12.0)
    injected = outcome.faults["injected"]
    assert injected[f"vlm_{'timeouts' if mode == 'timeout' else 'garbage'}"] >= 1
    counted = outcome.faults["counted"]
    noticed = sum(counted.get(f"vlm:{k}", 0) for k in ("client_errors", "misses", "answers_without_depth"))
    assert noticed >= 1, counted


def test_a_fault_setting_out_of_range_is_one_line_naming_the_key() -> None:
    sc = load_scenario("follow_open")
    with pytest.raises(ConfigError) as err:
        apply_overrides(sc, {"faults": {"frame_drop_prob": 1.5}}, file="my.yaml")
    assert str(err.value).startswith("my.yaml: sim.faults.frame_drop_prob:")
    with pytest.raises(ConfigError, match=r"sim\.faults\.robot_kick\[0\]\.at_s"):
        apply_overrides(sc, {"faults": {"robot_kick": [{"dx": 1.0}]}}, file="my.yaml")


def test_without_faults_the_report_has_no_fault_section(tmp_path: Path) -> None:
    outcome = run_with(tmp_path, {}, seconds=2.0)
    assert outcome.faults == {}


def test_a_frame_older_than_max_frame_age_is_dropped_when_the_age_limit_is_set() -> None:
    src = ScriptedSource("scripted", lambda frame: [])
    stage = PerceptionStage([src], {}, max_frame_age_s=0.5)
    bb = board()
    bbk.set_(bb, bbk.CLOCK, 10.0)
    bbk.set_(bb, bbk.FRAME, Frame(image=IMAGE, stamp=9.0))  # 1 s old on the clock
    bbk.set_(bb, bbk.FRAME_SEQ, 1)
    perceived = stage.update(bb)
    assert src.calls == 0 and read(bbk.PERCEPTION_STATS)["frames_stale"] == 1
    assert perceived is not None and "max_frame_age_s" in perceived.summary
    bbk.set_(bb, bbk.FRAME, Frame(image=IMAGE, stamp=9.8))
    bbk.set_(bb, bbk.FRAME_SEQ, 2)
    stage.update(bb)
    assert src.calls == 1 and read(bbk.PERCEPTION_STATS)["frames_processed"] == 1
