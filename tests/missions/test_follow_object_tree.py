"""Nav2's FollowObject as a tree (trees/follow_object.xml, issue 32), in the simulation: the object is what an
external detector reports (a scenario's ``external_detector``: line of sight, noise, dropouts), turned into
detections by the ``external_pose`` source, and the FOLLOW / LOST / SEARCH ladder runs on them unchanged."""

from __future__ import annotations

import textwrap
from pathlib import Path

import pytest
import yaml

from mission.app.sim_run import run_scenario

SCENARIOS = Path(__file__).resolve().parents[2] / "sim" / "scenarios"


def tracked(tmp: Path, base: str, **detector: object) -> str:
    data = yaml.safe_load((SCENARIOS / f"{base}.yaml").read_text())
    data["external_detector"] = {"topic": "/target_pose", **detector}
    path = tmp / f"{base}_tracked.yaml"
    path.write_text(yaml.safe_dump(data))
    return str(path)


def external_config(tmp: Path) -> str:
    """The sim's config, plus what the follow_object server adds: the external_pose source, and `target` as
    whatever it reports (the camera's own marker detections of the box no longer count as the target)."""
    path = tmp / "config.yaml"
    path.write_text(
        textwrap.dedent("""\
        perception:
          sources:
            - plugin: aruco
              params: {dictionary: DICT_APRILTAG_36h11, marker_size_m: 0.20, marker_sizes: {0: 0.15, 7: 0.20}}
            - plugin: external_pose
          targets:
            target: {source: external_pose}
            dock: {marker_id: 0}
    """)
    )
    return str(path)


def goal_tree(tmp: Path, desired_distance: float = 1.0) -> str:
    """The inputs the follow_object server writes, then the shipped FollowObject tree."""
    path = tmp / "goal.xml"
    path.write_text(
        textwrap.dedent(f"""\
        <root BTCPP_format="4" main_tree_to_execute="Goal">
          <include path="follow_object.xml"/>
          <BehaviorTree ID="Goal">
            <Sequence>
              <Script code="detection_timeout := 2.0; desired_distance := {desired_distance}"/>
              <SubTree ID="FollowObject" _autoremap="true"/>
            </Sequence>
          </BehaviorTree>
        </root>
    """)
    )
    return str(path)


@pytest.mark.slow  # the closed loop over DDS (tests/ros/test_nav2_actions.py) runs the same in the fast suite
def test_following_what_a_tracker_reports_through_an_occlusion_recovers_every_loss(tmp_path):
    scenario = tracked(tmp_path, "follow_occlusion")
    outcome, _metrics, _sim = run_scenario(
        scenario, config_file=external_config(tmp_path), tree=goal_tree(tmp_path), max_duration=40.0
    )
    m = outcome.metrics
    assert outcome.success, outcome.reason
    assert m["loss_events"] >= 1, m  # the pillars hide the target from the tracker too
    assert m["loss_events_recovered"] == m["loss_events"], m
    assert m["tracking_fraction"] >= 0.8, m


@pytest.mark.slow
def test_a_tracker_that_goes_silent_is_searched_for_then_given_up(tmp_path):
    scenario = tracked(tmp_path, "follow_open", silent_after_s=10.0)
    outcome, _metrics, _sim = run_scenario(
        scenario, config_file=external_config(tmp_path), tree=goal_tree(tmp_path), max_duration=150.0
    )
    assert not outcome.success
    assert outcome.final_state == "FAILED"
    assert "gave up" in outcome.reason
