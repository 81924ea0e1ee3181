"""Properties of the config and scenario loaders over generated input: any valid config written out and
read back is the same config; any junk — bytes, YAML of the wrong shape, wrong values under real keys —
is a ConfigError with one line per problem, each naming the file, never another exception."""

from __future__ import annotations

import math
import string
from pathlib import Path

import yaml
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from mission.core.config import MissionConfig, PerceptionConfig, RunConfig, SourceConfig, TargetSpec, load_config
from mission.core.errors import ConfigError
from mission.sim.scenario import Scenario, scenario_from_dict

SETTINGS = settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])

names = st.text(string.ascii_letters + string.digits + "_-. ", min_size=1, max_size=12)
scalars = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(-(2**40), 2**40),
    st.floats(allow_nan=False, allow_infinity=False, width=32),
    st.text(max_size=12),
)
json_like = st.recursive(
    scalars,
    lambda inner: st.one_of(st.lists(inner, max_size=4), st.dictionaries(names, inner, max_size=4)),
    max_leaves=12,
)


@st.composite
def configs(draw: st.DrawFn) -> MissionConfig:
    plugins = draw(st.lists(st.sampled_from(["aruco", "apriltag", "vlm", "vlm_stub"]), min_size=1, max_size=3))
    sources = [
        SourceConfig(
            plugin=p,
            name=f"{p}_{i}" if draw(st.booleans()) or plugins.count(p) > 1 else None,
            params=draw(st.dictionaries(names, json_like, max_size=3)),
        )
        for i, p in enumerate(plugins)
    ]
    source_names = [s.name or s.plugin for s in sources]
    targets = draw(
        st.dictionaries(
            names,
            st.builds(
                TargetSpec,
                marker_id=st.none() | st.integers(0, 1000),
                label=st.none() | st.text(max_size=10),
                source=st.none() | st.sampled_from(source_names),
            ),
            max_size=3,
        )
    )
    specs = [tuple(t.model_dump().values()) for t in targets.values()]
    assume(len(set(specs)) == len(specs))  # two targets that look alike are an error (test_bad_input_config)
    return MissionConfig(
        tree=draw(st.sampled_from(["mission.xml", "follow", "my/own tree.xml"])),
        perception=PerceptionConfig(sources=sources, policy=draw(st.sampled_from(["all", "hybrid"])), targets=targets),
        run=RunConfig(tick_hz=draw(st.floats(0.001, 200.0))),
        sim=draw(st.dictionaries(names, json_like, max_size=3)),
    )


def write(directory: Path, data: object) -> Path:
    path = directory / "config.yaml"
    path.write_text(yaml.safe_dump(data))  # non-ASCII escaped: PyYAML reads a raw U+0085 as a line break
    return path


@SETTINGS
@given(cfg=configs())
def test_a_valid_config_written_as_yaml_reads_back_as_the_same_config(tmp_path, cfg):
    path = write(tmp_path, cfg.model_dump(mode="json"))
    assert load_config(path) == cfg


def _only_config_errors(load, path: Path) -> None:
    try:
        load(path)
    except ConfigError as err:
        _a_line_per_problem_naming(err, str(path))


def _a_line_per_problem_naming(err: ConfigError, file: str) -> None:
    lines = str(err).splitlines()
    assert len(lines) == len(err.problems) and all(line.startswith(f"{file}: ") for line in lines), str(err)


@SETTINGS
@given(data=st.binary(max_size=200))
def test_random_bytes_are_a_config_error_or_a_config(tmp_path, data):
    path = tmp_path / "config.yaml"
    path.write_bytes(data)
    _only_config_errors(load_config, path)


@SETTINGS
@given(data=json_like)
def test_yaml_of_any_shape_is_a_config_error_or_a_config(tmp_path, data):
    _only_config_errors(load_config, write(tmp_path, data))


@SETTINGS
@given(
    section=st.sampled_from(["tree", "perception", "run", "sim"]),
    sub=st.sampled_from(["sources", "policy", "targets", "tick_hz", None]),
    junk=json_like,
)
def test_junk_under_real_keys_is_a_config_error_naming_a_key(tmp_path, section, sub, junk):
    data = {section: {sub: junk} if sub else junk}
    path = write(tmp_path, data)
    try:
        load_config(path)
    except ConfigError as err:
        assert err.file == str(path) and (err.key or "").split(".")[0].split("[")[0] in (section, "")


# -- scenarios -----------------------------------------------------------------------------------------------

SCENARIO_KEYS = sorted(Scenario.model_fields)


@SETTINGS
@given(key=st.sampled_from(SCENARIO_KEYS), junk=json_like)
def test_junk_under_any_scenario_key_is_a_config_error_or_a_scenario(key, junk):
    try:
        scenario_from_dict({"name": "x", key: junk}, file="s.yaml")
    except ConfigError as err:
        _a_line_per_problem_naming(err, "s.yaml")


finite = st.floats(-20, 20, allow_nan=False)


@SETTINGS
@given(
    robot=st.fixed_dictionaries({"x": finite, "y": finite, "yaw_deg": finite}),
    target=st.fixed_dictionaries(
        {"x": finite, "y": finite, "waypoints": st.lists(st.fixed_dictionaries({"x": finite, "y": finite}), max_size=3)}
    ),
    dock=st.none() | st.fixed_dictionaries({"x": finite, "y": finite, "yaw_deg": st.floats(-720, 720)}),
    obstacles=st.lists(
        st.fixed_dictionaries(
            {
                "shape": st.sampled_from(["box", "cylinder"]),
                "x": finite,
                "y": finite,
                "yaw_deg": finite,
                "size": st.tuples(*[st.floats(0, 3)] * 3),
                "radius": st.floats(0.01, 2),
            }
        ),
        max_size=3,
    ),
)
def test_any_geometry_is_accepted_with_everything_clear_or_rejected_in_one_line(robot, target, dock, obstacles):
    data = {"name": "x", "robot": robot, "target": target, "obstacles": obstacles}
    if dock is not None:
        data["dock"] = dock
    try:
        sc = scenario_from_dict(data, file="s.yaml")
    except ConfigError as err:
        assert str(err).startswith("s.yaml: ") and "\n" not in str(err)
        return
    sx, sy = sc.room.size
    r = sc.robot.radius
    assert r <= sc.robot.x <= sx - r and r <= sc.robot.y <= sy - r  # an accepted start is inside the room
    assert all(math.isfinite(v) for v in (sc.robot.x, sc.robot.y, sc.target.x, sc.target.y))
