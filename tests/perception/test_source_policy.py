"""Swapping and combining perception sources in config: one plugin line changes the source; the hybrid
policy hands a target over from the coarse VLM to the precise tag source when both see it."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest
import yaml

from mission import cli
from mission.app.sim_run import run_scenario, shipped_config
from mission.core.config import load_config
from mission.perception_plugins import registry
from mission.perception_plugins.target_matching import SourcedDetection, assign
from mission.sim.scenario import load_scenario, scenario_path
from mission.sim.sim_adapter import SimAdapter

CONFIGS = ("sim_aruco.yaml", "sim_apriltag.yaml", "sim_vlm.yaml")


@pytest.mark.parametrize("name", CONFIGS)
def test_each_shipped_sim_config_builds_its_sources(name):
    config = load_config(shipped_config(name))
    sources = registry.create_all(config.perception.sources)
    try:
        assert [s.name for s in sources] == [c.plugin for c in config.perception.sources]
        assert set(config.perception.targets) == {"target", "dock"}
    finally:
        for s in sources:
            s.close()


def test_swapping_aruco_for_apriltag_changes_only_the_source():
    aruco, apriltag = (load_config(shipped_config(n)) for n in ("sim_aruco.yaml", "sim_apriltag.yaml"))
    assert [s.plugin for s in apriltag.perception.sources] == ["apriltag"]
    assert apriltag.perception.targets == aruco.perception.targets
    assert apriltag.tree == aruco.tree and apriltag.run == aruco.run


def test_the_vlm_config_is_the_hybrid_of_a_coarse_vlm_and_a_precise_tag_source():
    cfg = load_config(shipped_config("sim_vlm.yaml"))
    assert cfg.perception.policy == "hybrid"
    assert [s.plugin for s in cfg.perception.sources] == ["vlm", "apriltag"]
    label = cfg.perception.sources[0].params["label"]
    assert cfg.perception.targets["target"].label == label  # one spec matches both sources…
    assert cfg.perception.sources[1].params["tags"][7]["name"] == label  # …because tag 7 is attributed to it


@pytest.fixture(scope="module")
def sim_views():
    """RGB-D frames of the red box (tag 7 on its back) from the start of follow_open, before it drives."""
    scenario = load_scenario("follow_open")
    scenario.camera.depth = True
    adapter = SimAdapter(scenario, seed=0)
    adapter.setup()
    try:
        frames = []
        for _ in range(12):
            frames.append(adapter.capture())
            adapter.advance(0.2)
    finally:
        adapter.close()
    return frames


def _run(sources, frames):
    out = []
    for f in frames:
        dets = []
        for s in sources:
            dets += [SourcedDetection(s.name, d) for d in s.process(f)]
            if hasattr(s, "wait_idle"):
                s.wait_idle(timeout=10.0)
        out.append(dets)
    return out


def test_hybrid_hands_the_target_from_the_vlm_to_the_tag_source(sim_views):
    cfg = load_config(shipped_config("sim_vlm.yaml"))
    params = dict(cfg.perception.sources[0].params, latency_s=0.0, publish_rate_limit_hz=10.0, miss_rate=0.0)
    vlm = registry.create(cfg.perception.sources[0].model_copy(update={"params": params}))
    tags = registry.create(cfg.perception.sources[1])
    targets = dict(cfg.perception.targets)
    try:
        per_frame = _run([vlm, tags], sim_views)
        assert vlm.latch.latched, vlm.status()
        both = per_frame[-1]
        assert {d.source for d in both} == {"vlm", "apriltag"}  # both see the red box
        hybrid = assign(both, targets, "hybrid")
        assert hybrid.best["target"].source == "apriltag" and hybrid.coarse_dropped == 1
        everything = assign(both, targets, "all")
        assert everything.coarse_dropped == 0 and len(everything.kept) == len(both)
        # The tag hidden (painted box-red): only the VLM sees the target, and it is used.
        last = sim_views[-1]
        tag_px = next(d.det.corners for d in both if d.source == "apriltag")
        hidden = last.image.copy()
        lo, hi = np.floor(tag_px.min(axis=0)).astype(int) - 6, np.ceil(tag_px.max(axis=0)).astype(int) + 6
        hidden[lo[1] : hi[1], lo[0] : hi[0]] = last.image[hi[1] + 4, (lo[0] + hi[0]) // 2]
        frame = dataclasses.replace(last, image=hidden, stamp=last.stamp + 0.1)
        only_vlm = _run([vlm, tags], [frame])[0]
        assert [d.source for d in only_vlm] == ["vlm"]
        best = assign(only_vlm, targets, "hybrid").best["target"]
        assert best.source == "vlm" and best.det.extra["precision"] == "coarse"
        # and the coarse pose is where the tag said the box is (the face centre vs the tag centre)
        tag_det = next(d.det for d in both if d.source == "apriltag")
        assert np.linalg.norm(best.det.position - tag_det.position) < 0.15
    finally:
        vlm.close()
        tags.close()


# -- closed loop: the same mission with another source ------------------------------------------------


@pytest.mark.slow
def test_follow_occlusion_completes_with_the_apriltag_config():
    assert (
        cli.main(
            ["run", "--scenario", "follow_occlusion", "--config", str(shipped_config("sim_apriltag.yaml")), "--quiet"]
        )
        == 0
    )


@pytest.mark.slow
def test_follow_occlusion_completes_with_the_vlm_config():
    assert (
        cli.main(["run", "--scenario", "follow_occlusion", "--config", str(shipped_config("sim_vlm.yaml")), "--quiet"])
        == 0
    )


@pytest.mark.slow
def test_with_depth_the_vlm_discovers_the_target_and_hands_over_to_the_tags(tmp_path: Path):
    """The hybrid at work in the loop: the VLM's coarse detections of the target were dropped for the
    tag source's while both saw it (needs the camera's depth, which this scenario copy turns on)."""
    data = yaml.safe_load(scenario_path("follow_occlusion").read_text())
    data.setdefault("camera", {})["depth"] = True
    path = tmp_path / "follow_occlusion_depth.yaml"
    path.write_text(yaml.safe_dump(data))
    outcome, _, _ = run_scenario(str(path), config_file=shipped_config("sim_vlm.yaml"), seed=0)
    assert outcome.success, outcome.reason
    assert outcome.perception_stats.get("coarse_dropped", 0) > 0
