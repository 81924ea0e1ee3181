"""A simulated mission, start to finish: scenario + config + tree → ticks → metrics → outcome.

`mission run` and the benchmark sweeps both call :func:`run_scenario`, so a bench figure and a CLI
run are the same code path. `mission sim-robot` calls it too, with ``robot=``: the simulated world is then
wrapped as a ROS robot (mission/ros/sim_robot_node.py) and the tree runs in another process — the ROS node —
while this one steps the world, measures it against ground truth and scores it by the same criteria.
"""

from __future__ import annotations

import signal
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import py_trees

from mission.app.metrics import DockErrors, MetricsRecorder
from mission.app.overrides import RunOverrides
from mission.app.provenance import run_provenance
from mission.app.runner import Pacer, TreeRunner, checked_tree
from mission.app.shipped import shipped_config, shipped_config_named, shipped_configs
from mission.core import blackboard as bbk
from mission.core.blackboard import MissionState
from mission.core.config import MissionConfig, check_config, load_config, merge_mappings, read_yaml, validate_model
from mission.core.errors import ConfigError
from mission.core.observers import RunObserver
from mission.perception_plugins.pipeline import source_statuses
from mission.sim.faults import fault_summary, wrap_sources
from mission.sim.scenario import Scenario, Success, load_scenario, scenario_path
from mission.sim.scenario_overrides import apply_overrides
from mission.sim.sim_adapter import SimAdapter
from mission.trees.factory import shipped_factory
from mission.trees.loader import describe_tree

DEFAULT_SIM_CONFIG = "sim_aruco.yaml"


def _source_name(source: Any) -> Any:
    return (source.get("name") or source.get("plugin")) if isinstance(source, dict) else None


def layer_config(base: dict[str, Any], user: dict[str, Any]) -> dict[str, Any]:
    """A user's config laid on the simulated world's (`base`, the shipped sim config), so what the world needs
    — its markers' dictionary and sizes, its targets — is never lost by leaving it out.

    Mappings merge key by key (``run``, ``sim``, a source's ``params``), scalars replace. Two lists have a rule:

    * ``perception.sources``: the user's list, when given, decides which sources run and in what order; a source
      with the same name (its ``name``, else its ``plugin``) as one of the sim config's gets that source's
      params under its own (the user's win key by key). A source the sim config lacks is the user's alone.
    * ``perception.targets``: each target the user names is theirs, whole; the sim config's other targets stay,
      except one that looks exactly like a user's target (the user renamed it).
    """
    out = merge_mappings(base, {k: v for k, v in user.items() if k != "perception"})
    user_perception = user.get("perception")
    if not isinstance(user_perception, dict):  # absent (the sim's), or not a mapping (validation says so)
        if "perception" in user:
            out["perception"] = user_perception
        return out
    base_perception = dict(base.get("perception") or {})
    perception = merge_mappings(
        base_perception, {k: v for k, v in user_perception.items() if k not in ("sources", "targets")}
    )
    sources = user_perception.get("sources")
    if isinstance(sources, list):
        known = {_source_name(s): s for s in base_perception.get("sources") or []}
        layered = []
        for source in sources:
            own = known.get(_source_name(source))
            if own is not None and isinstance(source.get("params", {}), dict):
                source = {**source, "params": merge_mappings(own.get("params") or {}, source.get("params") or {})}
            layered.append(source)
        perception["sources"] = layered
    elif "sources" in user_perception:
        perception["sources"] = sources
    targets = user_perception.get("targets")
    if isinstance(targets, dict):
        theirs = list(targets.values())
        kept = {n: t for n, t in (base_perception.get("targets") or {}).items() if n not in targets and t not in theirs}
        perception["targets"] = {**kept, **targets}
    elif "targets" in user_perception:
        perception["targets"] = targets
    out["perception"] = perception
    return out


def load_sim_config(config_file: str | Path | None) -> MissionConfig:
    """The config of a simulated run: the shipped sim config, with a user's file laid on it (:func:`layer_config`).

    Without a file, the shipped sim config exactly as before. Errors name the user's file."""
    default = shipped_config(DEFAULT_SIM_CONFIG)
    if config_file is None:
        return load_config(default)
    user = read_yaml(config_file)
    if user is None:
        user = {}
    if not isinstance(user, dict):  # the loader's own error: expected a mapping
        return load_config(config_file)
    base = read_yaml(default) or {}
    config = validate_model(MissionConfig, layer_config(base, user), file=str(config_file))
    check_config(config, str(config_file))
    # set: what either file names, except a tree only the user's file can name (choose_tree asks)
    config.__pydantic_fields_set__ = {k for k in (*base, *user) if k in MissionConfig.model_fields} - (
        set() if "tree" in user else {"tree"}
    )
    return config


_APRILTAG_DICTIONARIES = {
    "tag36h11": "DICT_APRILTAG_36h11",
    "tag36h10": "DICT_APRILTAG_36h10",
    "tag25h9": "DICT_APRILTAG_25h9",
    "tag16h5": "DICT_APRILTAG_16h5",
}


def sim_mismatches(config: MissionConfig, scenario: Scenario, file: str) -> list[str]:
    """Where the config and the simulated world disagree so that a fiducial source cannot read the world's
    markers (another dictionary or family) or would misjudge their distance (another size): one line each."""
    markers: dict[int, tuple[str, float, str]] = {}  # id → (dictionary, size, what carries it)
    if scenario.target is not None:
        for m in scenario.target.markers:
            markers.setdefault(m.id, (m.dictionary, m.marker_size_m, "target"))
    if scenario.dock is not None:
        markers.setdefault(scenario.dock.id, (scenario.dock.dictionary, scenario.dock.marker_size_m, "dock"))
    if not markers:
        return []
    dictionaries = sorted({d for d, _, _ in markers.values()})
    lines = []
    for i, source in enumerate(config.perception.sources):
        params = source.params
        if source.plugin == "aruco":
            dictionary = str(params.get("dictionary", "DICT_4X4_250"))
            key = "dictionary"
        elif source.plugin == "apriltag":
            family = str(params.get("family", "tag36h11"))
            dictionary, key = _APRILTAG_DICTIONARIES.get(family, family), "family"
        else:
            continue
        where = f"{file}: perception.sources[{i}] ({source.name or source.plugin})"
        if dictionary not in dictionaries:
            lines.append(
                f"{where}: {key} {params.get(key, dictionary)!r} cannot read the simulated markers "
                f"({', '.join(dictionaries)}, scenario {scenario.name}); the targets will never be seen"
            )
            continue
        for marker_id, (_, size, what) in sorted(markers.items()):
            configured = _configured_size(source.plugin, params, marker_id)
            if configured is not None and abs(configured - size) > 1e-6:
                lines.append(
                    f"{where}: marker {marker_id} ({what}) is {size:g} m in scenario {scenario.name}, the config "
                    f"says {configured:g} m; its distance will be misjudged"
                )
    return lines


def _configured_size(plugin: str, params: dict[str, Any], marker_id: int) -> float | None:
    try:
        if plugin == "aruco":
            sizes = params.get("marker_sizes") or {}
            return float(sizes.get(marker_id, params.get("marker_size_m", 0.049)))
        tags = params.get("tags") or {}
        tag = tags.get(marker_id) or {}
        if isinstance(tag, dict) and "marker_size_m" in tag:
            return float(tag["marker_size_m"])
        return float(params["marker_size_m"]) if "marker_size_m" in params else None
    except (TypeError, ValueError, AttributeError):
        return None  # the plugin's own validation says what is wrong


@dataclass
class RunOutcome:
    scenario: str
    seed: int
    success: bool
    reason: str
    tree_status: str
    final_state: str
    sim_time_s: float
    wall_time_s: float
    ticks: int
    metrics: dict[str, Any]
    perception_stats: dict[str, int] = field(default_factory=dict)
    faults: dict[str, Any] = field(default_factory=dict)  # scenario `faults:`: injected vs counted (sim/faults.py)
    # each source's status() at the end, by name: the VLM's budget, circuit breaker (and why) and model cost
    sources: dict[str, Any] = field(default_factory=dict)
    interrupted: bool = False  # SIGINT/SIGTERM ended the run early; what was measured so far is reported
    stop_signal: str | None = None  # SIGINT | SIGTERM when interrupted
    # what produced the run: resolved config, tree file, plugins and their versions, seed, package versions
    provenance: dict[str, Any] = field(default_factory=dict)

    def to_json(self) -> dict[str, Any]:
        return dict(self.__dict__)


def choose_tree(cli_tree: str | None, config: MissionConfig, scenario: Scenario) -> str:
    """--tree wins, then a tree the config file names explicitly, then the scenario's own tree."""
    if cli_tree:
        return cli_tree
    if "tree" in config.model_fields_set:
        return config.tree
    return getattr(scenario, "tree", None) or config.tree


OCCLUSION_LATENCY_S = 0.5  # design notes: detect occlusion within 0.5 s
REACQUISITION_S = 10.0  # design notes: re-acquire the target within 10 s
# issue 15: a follow run tracks the target (FOLLOW, in view) at least this fraction of the follow phase, and a
# search for a target that has gone ends this soon after it went — the scenario's success keys, their defaults
MIN_TRACKING_FRACTION: float = Success.model_fields["min_tracking_fraction"].default
GIVE_UP_WITHIN_S: float = Success.model_fields["give_up_within_s"].default


def evaluate(
    kind: str,
    status: py_trees.common.Status,
    final_state: str,
    reason: str,
    summary: dict[str, Any],
    duration: float,
    *,
    min_tracking_fraction: float = MIN_TRACKING_FRACTION,
    give_up_within_s: float = GIVE_UP_WITHIN_S,
    limit: str = "",
) -> tuple[bool, str]:
    """Did the mission succeed? The tree's verdict first, then the design notes' criteria on ground truth.

    dock: docked within 3 cm lateral / 2.5 cm distance / 10° skew. follow: every occlusion of 0.5 s or more
    called LOST within 0.5 s, every loss re-acquired within 10 s (one that began in the last 10 s of the run
    may still be open), following at the end, and the target tracked — in FOLLOW and in view — for at least
    `min_tracking_fraction` of the follow phase (a run LOST or SEARCHing most of the time did not follow).
    mission: both; a run that ends while the tree is still docking never docked (`limit` names what ended it,
    e.g. ``--max-duration 6``). give_up: the target leaves the map; the tree must fail — the search ending with its
    reason — within `give_up_within_s` of the target leaving, never searching on for ever.
    """
    if kind == "give_up":
        return _gave_up(status, final_state, reason, summary, give_up_within_s)
    if status == py_trees.common.Status.FAILURE:
        return False, reason or f"tree failed in state {final_state or '?'}"
    if summary.get("collisions", 0):
        return False, f"{summary['collisions']} collision(s)"
    dock = summary.get("dock")
    if kind in ("dock", "mission"):
        if dock is None:
            return False, "never docked"
        if not DockErrors(**dock).within() and status == py_trees.common.Status.RUNNING:
            # the tree was still at it: the run ended before docking finished, not a dock out of tolerance
            return False, (
                f"never docked: {limit or 'the run'} ended it after {duration:.0f} s, still in state "
                f"{final_state or '?'} ({dock['distance_m'] * 100:.0f} cm from the docked pose)"
            )
        if not DockErrors(**dock).within():
            return False, (
                f"docked out of tolerance: lateral {dock['lateral_m'] * 100:.1f} cm, "
                f"distance {dock['distance_m'] * 100:.1f} cm, skew {dock['skew_deg']:.1f}°"
            )
        if kind == "dock":
            return True, "docked within tolerance"
    if kind in ("follow", "mission"):
        transitions = summary.get("state_transitions", [])
        if summary.get("occlusions_missed", 0):
            return False, f"{summary['occlusions_missed']} occlusion(s) of 0.5 s or more never called LOST"
        latency = summary.get("occlusion_detection_latency_s") or {}
        if latency.get("max", 0.0) > OCCLUSION_LATENCY_S:
            return False, f"occlusion detected after {latency['max']:.2f} s (> {OCCLUSION_LATENCY_S} s)"
        reacq = summary.get("reacquisition_time_s") or {}
        if reacq.get("max", 0.0) > REACQUISITION_S:
            return False, f"target re-acquired after {reacq['max']:.1f} s (> {REACQUISITION_S:g} s)"
        unrecovered = summary["loss_events"] - summary["loss_events_recovered"]
        # A loss that began in the last 10 s of the run may still be recovered: only older ones count.
        last_loss_t = max((t["t"] for t in transitions if t["state"] in ("LOST", "SEARCH")), default=None)
        recent = last_loss_t is not None and duration - last_loss_t < REACQUISITION_S
        if unrecovered > (1 if recent else 0):
            return False, f"{unrecovered} loss event(s) never recovered"
        if final_state not in (MissionState.FOLLOW, MissionState.LOST, MissionState.SEARCH) or (
            final_state != MissionState.FOLLOW and not recent
        ):
            return False, f"not following at the end (state {final_state or '?'})"
        tracked = summary.get("tracking_fraction")
        if tracked is not None and tracked < min_tracking_fraction:
            held, phase = summary.get("tracking_s", 0), summary.get("follow_phase_s", 0)
            return False, (
                f"target tracked {100 * tracked:.0f} % of the follow phase (< {100 * min_tracking_fraction:.0f} %): "
                f"in FOLLOW with it in view {held:.0f} s of {phase:.0f} s"
            )
        in_view = "" if tracked is None else f", in view {100 * tracked:.0f} % of the follow phase"
        if final_state != MissionState.FOLLOW:  # a loss in the last 10 s: not counted, but not hidden either
            lost_for = duration - last_loss_t if last_loss_t is not None else 0.0
            return True, (
                f"followed the target{in_view}; ended {final_state}, {lost_for:.0f} s after losing it "
                f"(a loss in the last {REACQUISITION_S:g} s is not counted)"
            )
        return True, f"followed the target to the end{in_view}"
    if status == py_trees.common.Status.SUCCESS:
        return True, "tree succeeded"
    return False, f"time out after {duration:.0f} s in state {final_state or '?'}"


def _gave_up(
    status: py_trees.common.Status, final_state: str, reason: str, summary: dict[str, Any], within_s: float
) -> tuple[bool, str]:
    """give_up: the target left the map, and the tree failed soon after with the search's reason."""
    if summary.get("collisions", 0):
        return False, f"{summary['collisions']} collision(s)"
    gone = summary.get("target_gone_at_s")
    if gone is None:
        return False, "the target never left the map (scenario: target.leave_at_end)"
    if status != py_trees.common.Status.FAILURE:
        return False, f"still searching {summary.get('duration_s', 0) - gone:.0f} s after the target left the map"
    after = summary.get("give_up_after_gone_s")
    if after is None or after < 0:
        return False, f"the tree failed before the target left the map: {reason or final_state}"
    if after > within_s:
        return False, f"gave up {after:.0f} s after the target left the map (> {within_s:g} s)"
    if not reason:
        return False, "gave up without a reason"
    return True, f"gave up {after:.0f} s after the target left the map: {reason}"


@dataclass
class PreparedRun:
    """What one run is made of, read and checked: the config and scenario with every override applied."""

    config: MissionConfig
    config_path: Path
    scenario: Scenario
    tree: str  # as choose_tree picked it (a name or path; resolved by the runner)
    overrides: RunOverrides
    warnings: list[str] = field(default_factory=list)  # where a user's config and the simulated world disagree


def prepare_run(
    scenario_name: str,
    *,
    config_file: str | Path | None = None,
    tree: str | None = None,
    overrides: RunOverrides | None = None,
) -> PreparedRun:
    """Read the scenario and config and lay the overrides on them: the config file's ``sim:`` over the
    scenario, then ``--set`` config keys over the config and scenario keys over the scenario. Without
    `config_file`, the config the scenario names (its ``config`` key), else the shipped sim config. Raises
    ConfigError naming the file (or ``--set``) and key."""
    overrides = overrides or RunOverrides()
    scenario = load_scenario(scenario_name)
    if not config_file and scenario.config:
        config_file = scenario_config(scenario_name, scenario.config)
    config_path = Path(config_file) if config_file else shipped_config(DEFAULT_SIM_CONFIG)
    config = overrides.apply_to_config(load_sim_config(config_file))
    scenario = apply_overrides(scenario, config.sim, file=str(config_path))
    scenario = overrides.apply_to_scenario(scenario)
    warnings = sim_mismatches(config, scenario, str(config_path)) if config_file else []
    return PreparedRun(config, config_path, scenario, choose_tree(tree, config, scenario), overrides, warnings)


def scenario_config(scenario_name: str, name: str) -> Path:
    """The config a scenario's ``config`` key names: a file of that name beside the scenario file, else a
    shipped config (``sim_vlm.yaml`` or ``sim_vlm``, as ``--config`` takes). A scenario that only works with
    its own perception (vlm_discovery: the VLM) says so where it is defined, so ``mission run --scenario``
    and every sweep and bench run it right without being told."""
    home = scenario_path(scenario_name)
    beside = home.parent / name
    if beside.is_file():
        return beside
    shipped = shipped_config_named(name)
    if shipped is not None:
        return shipped
    raise ConfigError(
        f"{name!r} is neither a file beside the scenario nor a shipped config: {', '.join(shipped_configs())}",
        file=str(home),
        key="config",
    )


def check_prepared(run: PreparedRun) -> set[str]:
    """Every check the run's set-up makes on its tree, with the port overrides applied (nothing is built);
    returns the node types the tree uses (for :func:`unused_ports`)."""
    factory = shipped_factory()
    run.overrides.apply_to_factory(factory)
    path = checked_tree(run.config, run.tree, factory, run.config_path)
    return {node.tag for node in describe_tree(path, factory).walk()}


def unused_ports(overrides: RunOverrides, tags: set[str], trees: str) -> None:
    """A ``Tag.port`` override whose node type none of the run's trees uses would change nothing: a
    ConfigError naming it (a misread tree, or a sweep axis that measures nothing)."""
    for s in overrides.settings:
        tag = s.key.split(".", 1)[0]
        if s.kind == "port" and tag not in tags:
            raise ConfigError(f"no {tag} node in {trees}; the setting would change nothing", file="--set", key=s.key)


def run_scenario(
    scenario_name: str,
    *,
    config_file: str | Path | None = None,
    tree: str | None = None,
    seed: int = 0,
    max_duration: float | None = None,
    observers: list[RunObserver] | None = None,
    pacer: Pacer | None = None,
    robot: Callable[[SimAdapter], Any] | None = None,
    overrides: RunOverrides | None = None,
) -> tuple[RunOutcome, MetricsRecorder, SimAdapter]:
    """Run one scenario headless and measure it. Raises MissionError on config/tree problems.

    With `robot`, the world is ``robot(sim_adapter)`` — the simulation behind ROS topics — and no tree runs
    here: the remote tree's state, reason and status come back through that world (``tree_status()``,
    ``finished``), and the run ends at the scenario's duration or when the remote tree finishes.
    `overrides` are ``--set`` keys (mission/app/overrides.py): tree ports, config and scenario keys.

    SIGINT/SIGTERM end the run early: the outcome covers what ran, with ``interrupted`` set."""
    prepared = prepare_run(scenario_name, config_file=config_file, tree=tree, overrides=overrides)
    config, config_path, scenario = prepared.config, prepared.config_path, prepared.scenario
    for line in prepared.warnings:
        print(f"mission: warning: {line}", file=sys.stderr, flush=True)
    adapter = SimAdapter(scenario, seed=seed)
    success_spec = getattr(scenario, "success", None)
    kind = str(getattr(success_spec, "kind", "tree"))
    criteria = {
        k: float(getattr(success_spec, k))
        for k in ("min_tracking_fraction", "give_up_within_s")
        if hasattr(success_spec, k)
    }
    recorder = MetricsRecorder(dock_standoff_m=float(getattr(success_spec, "standoff_m", 0.30) or 0.30))
    world = adapter if robot is None else robot(adapter)
    runner = TreeRunner(
        config,
        world,
        prepared.tree if robot is None else None,
        config_file=config_path,
        observers=[recorder, *(observers or [])],
        perception_only=robot is not None,
        sources=[] if robot is not None else None,
    )
    prepared.overrides.apply_to_factory(runner.factory)
    duration = float(max_duration or scenario.duration_s)
    until: Any = duration
    if robot is not None:
        until = lambda r: r.elapsed() >= duration or bool(getattr(world, "finished", False))  # noqa: E731
    wall0 = time.perf_counter()
    try:
        runner.setup()
        wrap_sources(runner.sources, scenario.faults, adapter.faults.injected)  # perception-side faults, if any
        provenance = run_provenance(
            config, tree_file=runner.tree_path or "", seed=seed, config_file=config_path, scenario=scenario.name
        )
        provenance["set"] = prepared.overrides.as_dict()  # the --set keys that made this run (empty: none)
        status = runner.run(until=until, pacer=pacer)
        if robot is not None:
            status = world.tree_status()
        limit = f"--max-duration {max_duration:g}" if max_duration else ""
        outcome = _outcome(runner, adapter, recorder, kind, status, scenario.name, seed, wall0, criteria, limit)
        outcome.provenance = provenance
        runner.finish(outcome)
        return outcome, recorder, adapter
    finally:
        runner.close()


def _outcome(
    runner: TreeRunner,
    adapter: SimAdapter,
    recorder: MetricsRecorder,
    kind: str,
    status: py_trees.common.Status,
    scenario: str,
    seed: int,
    wall0: float,
    criteria: dict[str, float],
    limit: str = "",
) -> RunOutcome:
    final_state = runner.get(bbk.STATE, "")
    sim_time = runner.elapsed()
    recorder.finish(recorder.last_ground_truth, final_state, tree_failed=status == py_trees.common.Status.FAILURE)
    summary = recorder.summary(sim_time)
    ok, reason = evaluate(
        kind, status, final_state, runner.get(bbk.REASON, ""), summary, sim_time, **criteria, limit=limit
    )
    if not ok and runner.failure and reason == f"tree failed in state {final_state or '?'}":
        reason = f"{reason}: {runner.failure}"  # the tree gave no reason: which leaf failed and what it said
    stats = dict(runner.get(bbk.PERCEPTION_STATS, {}) or {})
    signum = runner.stop_signal
    if signum is not None:
        ok, reason = False, f"interrupted by {signal.Signals(signum).name} after {sim_time:.1f} s ({reason})"
    return RunOutcome(
        scenario=scenario,
        seed=seed,
        success=ok,
        reason=reason,
        tree_status=status.name,
        final_state=final_state,
        sim_time_s=round(sim_time, 3),
        wall_time_s=round(time.perf_counter() - wall0, 3),
        ticks=runner.ticks,
        metrics=summary,
        perception_stats=stats,
        faults=fault_summary(adapter.faults, stats, runner.sources),
        sources=source_statuses(runner.sources),
        interrupted=signum is not None,
        stop_signal=signal.Signals(signum).name if signum is not None else None,
    )
