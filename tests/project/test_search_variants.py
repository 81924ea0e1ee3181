"""The search benchmark's baselines and the scenario keys of the search worlds.

The two baseline trees (bench/search_variants/) are real tree files a user can run with ``--tree``: they load
with the shipped factory, carry a current TreeNodesModel, keep ticking on an empty blackboard, and put
their search in place of the ladder — in mission.xml too, through the copy of the trees the benchmark makes.
"""

from __future__ import annotations

from pathlib import Path

import py_trees
import pytest
from py_trees.common import Status

from bench.search_bench import VARIANTS_DIR, variant_trees
from mission.core.errors import ConfigError
from mission.trees.factory import shipped_factory
from mission.trees.loader import load_tree
from mission.trees.tree_nodes_model import with_nodes_model

BASELINES = {"sweep": "SearchSweep", "rotate": "RotateSearch"}
LADDER = {"PursueLastSeen", "TurnToBearing", "SearchBelief", "CoverUnseen", "GiveUpSearch"}


def types(root: py_trees.behaviour.Behaviour) -> set[str]:
    return {type(n).__name__ for n in root.iterate()}


@pytest.mark.parametrize(("variant", "search"), BASELINES.items())
def test_a_baseline_tree_loads_ticks_and_searches_its_own_way(variant, search):
    path = VARIANTS_DIR / f"{variant}.xml"
    text = path.read_text()
    assert with_nodes_model(text, shipped_factory()) == text, "stale: regenerate the variant's TreeNodesModel"
    root = load_tree(path, shipped_factory())
    assert search in types(root) and not LADDER & types(root)
    tree = py_trees.trees.BehaviourTree(root)
    tree.setup(timeout=5.0)
    for _ in range(3):
        tree.tick()
        assert root.status != Status.INVALID
    tree.shutdown()


@pytest.mark.parametrize(("variant", "search"), BASELINES.items())
def test_the_benchmark_puts_the_baseline_in_place_of_the_ladder_in_the_whole_mission_too(variant, search, tmp_path):
    trees = variant_trees(variant, tmp_path)
    root = load_tree(trees / "mission.xml", shipped_factory())
    assert search in types(root) and not LADDER & types(root)
    assert {"Explore", "VisualServoDock"} <= types(root)  # the rest of the mission is the shipped one


def test_the_ladder_is_the_shipped_follow_tree():
    root = load_tree("follow.xml", shipped_factory())
    assert types(root) >= LADDER and not set(BASELINES.values()) & types(root)
    assert variant_trees("ladder", Path("unused")).name == "trees"  # the ladder runs the shipped trees as they are


def test_a_target_cannot_both_loop_and_leave_the_map():
    from mission.sim.scenario import scenario_from_dict

    with pytest.raises(ConfigError, match="leave_at_end and loop cannot both be set"):
        scenario_from_dict(
            {
                "name": "x",
                "target": {"x": 2, "y": 2, "loop": True, "leave_at_end": True, "waypoints": [{"x": 4, "y": 2}]},
            }
        )


def test_a_moving_obstacle_may_not_drive_through_a_static_one():
    from mission.sim.scenario import scenario_from_dict

    with pytest.raises(ConfigError, match=r"moving_obstacles\[0\].*passes through pillar"):
        scenario_from_dict(
            {
                "name": "x",
                "obstacles": [{"name": "pillar", "shape": "cylinder", "x": 4.0, "y": 4.0, "radius": 0.3}],
                "moving_obstacles": [
                    {
                        "name": "cart",
                        "shape": "box",
                        "x": 2.0,
                        "y": 4.0,
                        "size": [0.6, 0.4, 1.0],
                        "waypoints": [{"x": 6.0, "y": 4.0}],
                    }
                ],
            }
        )


def test_the_acceptance_run_keeps_the_finished_runs_of_the_same_code_and_drops_any_other(tmp_path):
    from bench.search_bench import _resumable
    from mission.sweep.engine import run_sweep
    from mission.sweep.plan import SweepPlan

    plan = SweepPlan(("follow_open",), (0,), max_duration=1.0, pictures="none")
    assert _resumable(tmp_path / "sweep", plan) == 0  # nothing yet
    run_sweep(plan, tmp_path / "sweep", workers=1, progress=False, summary=False)
    assert _resumable(tmp_path / "sweep", plan) == 1  # cut here (a stopped session): this run is kept
    assert _resumable(tmp_path / "sweep", SweepPlan(("follow_open",), (0, 1), max_duration=1.0, pictures="none")) == 1
    other = SweepPlan(("follow_open",), (0,), max_duration=2.0, pictures="none")  # not the same runs
    assert _resumable(tmp_path / "sweep", other) == 0 and not (tmp_path / "sweep").exists()
