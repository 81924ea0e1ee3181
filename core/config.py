"""Config schema and loading: one validated object, or a line per problem saying which file and key is wrong.

Models are pydantic with ``extra="forbid"``, so a typo in a key is an error, not a silent default.
Other floors reuse :func:`load_model` / :func:`validate_model` for their own files (scenarios, plugin params).
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Mapping, Sequence
from difflib import get_close_matches
from pathlib import Path
from types import UnionType
from typing import Annotated, Any, ClassVar, Literal, TypeVar, Union, get_args, get_origin

import yaml
from pydantic import BaseModel, BeforeValidator, ConfigDict, Field, ValidationError, model_validator

from mission.core.errors import ConfigError

M = TypeVar("M", bound=BaseModel)

log = logging.getLogger(__name__)

#: A renamed key: its new name, or the new name and how an old value becomes a new one.
Renamed = str | tuple[str, Callable[[Any], Any]]
_warned: set[tuple[str, str]] = set()


class StrictModel(BaseModel):
    """Base for every config section: unknown keys are errors, and so are .nan / .inf where a number is
    expected (NaN slips through every range check: ``nan > 0`` and ``nan <= 200`` are both False).

    A section whose keys were renamed lists the old spellings in :attr:`renamed_keys`: they are read for one
    release, each with one deprecation warning (per process) naming the new key, and giving both is an error.
    """

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)
    renamed_keys: ClassVar[Mapping[str, Renamed]] = {}

    @model_validator(mode="before")
    @classmethod
    def _read_renamed_keys(cls, data: Any) -> Any:
        if not cls.renamed_keys or not isinstance(data, Mapping):
            return data
        out = dict(data)
        for old, spec in cls.renamed_keys.items():
            if old not in out:
                continue
            new, convert = (spec, None) if isinstance(spec, str) else spec
            if new in out:
                raise ValueError(f"{old!r} is the old spelling of {new!r}; give only {new!r}")
            value = out.pop(old)
            out[new] = convert(value) if convert is not None else value
            if (cls.__name__, old) not in _warned:
                _warned.add((cls.__name__, old))
                log.warning(
                    "config key %r is deprecated: use %r (%s; the old key is read until the next release)",
                    old,
                    new,
                    cls.__name__,
                )
        return out


def _dotted(loc: tuple[Any, ...], prefix: str = "") -> str:
    out = prefix
    for part in loc:
        if isinstance(part, int):
            out += f"[{part}]"
        else:
            text = str(part)  # a key with a line break or a control character stays on its one line
            out += ("." if out else "") + (text if text.isprintable() else repr(text))
    return out or "(top level)"


def _expand(annotation: Any) -> list[Any]:
    """`annotation` without its Annotated / Optional / Union wrapping: the types a value may have."""
    if get_origin(annotation) is Annotated:
        return _expand(get_args(annotation)[0])
    if get_origin(annotation) in (Union, UnionType):
        return [t for arg in get_args(annotation) for t in _expand(arg)]
    return [annotation]


def _is_model(annotation: Any) -> bool:
    return isinstance(annotation, type) and issubclass(annotation, BaseModel)


def _step(annotation: Any, part: Any) -> list[Any]:
    """The types found one `loc` step below a value of type `annotation` (a field, an item, a union member)."""
    out: list[Any] = []
    for t in _expand(annotation):
        origin = get_origin(t)
        if _is_model(t) and isinstance(part, str):
            field = t.model_fields.get(part) or next((f for f in t.model_fields.values() if f.alias == part), None)
            if field is not None:
                out.append(field.annotation)
            elif part == t.__name__:  # pydantic names the union member it tried
                out.append(t)
        elif origin in (list, tuple, set, frozenset, Sequence) and isinstance(part, int):
            args = [a for a in get_args(t) if a is not Ellipsis]
            out.extend(args[part : part + 1] if origin is tuple and len(args) > 1 else args[:1])
        elif origin in (dict, Mapping) and len(get_args(t)) == 2:
            out.append(get_args(t)[1])
    return out


def known_keys(model: type[BaseModel], loc: Sequence[Any]) -> list[str]:
    """The keys `model` accepts in the mapping at `loc` (``("run",)`` → RunConfig's), walking fields, list
    items, dict values and union members; empty when `loc` leads to no model."""
    types: list[Any] = [model]
    for part in loc:
        types = [t for annotation in types for t in _step(annotation, part)]
    names: list[str] = []
    for t in (t for annotation in types for t in _expand(annotation)):
        if _is_model(t):
            names += [f.alias or name for name, f in t.model_fields.items() if (f.alias or name) not in names]
    return names


def _problem(error: Any, model: type[BaseModel] | None) -> str:
    """One pydantic error as the words after the key: what is wrong and what was expected."""
    kind = error["type"]
    if kind == "extra_forbidden":
        loc = tuple(error["loc"])
        near = get_close_matches(str(loc[-1]), known_keys(model, loc[:-1]), n=1) if model and loc else []
        return f"unknown key (did you mean {near[0]}?)" if near else "unknown key"
    if kind == "missing":
        return "required key is missing"
    got = error.get("input")
    text = error["msg"].removeprefix("Value error, ")  # a validator's own sentence, not pydantic's prefix
    text = text[:1].lower() + text[1:]  # keep names as written (TargetSpec, DICT_4X4_50)
    return f"{text}, got {got!r}" if not isinstance(got, dict) else text


def format_validation_error(
    err: ValidationError, *, file: str | None, prefix: str = "", model: type[BaseModel] | None = None
) -> ConfigError:
    """Every problem of a pydantic error, one line each naming file and dotted key; an unknown key suggests
    the nearest key `model` accepts there (``run.tick_hzz: unknown key (did you mean tick_hz?)``)."""
    problems = [(_dotted(tuple(e["loc"]), prefix), _problem(e, model)) for e in err.errors()]
    return ConfigError.several(problems, file=file)


def validate_model(model: type[M], data: Any, *, file: str | None = None, prefix: str = "") -> M:
    """Validate a mapping into `model`, raising a ConfigError listing every problem, one line each."""
    if data is None:
        data = {}
    if not isinstance(data, dict):
        raise ConfigError(f"expected a mapping, got {type(data).__name__}", file=file, key=prefix or None)
    try:
        return model.model_validate(data)
    except ValidationError as err:
        raise format_validation_error(err, file=file, prefix=prefix, model=model) from None


class _UniqueKeyLoader(yaml.SafeLoader):
    """SafeLoader that rejects a key given twice in one mapping (PyYAML silently keeps the last one,
    so a second ``run:`` section would quietly replace the first)."""

    def construct_mapping(self, node: yaml.MappingNode, deep: bool = False) -> dict[Any, Any]:
        seen: dict[Any, int] = {}
        for key_node, _ in node.value:
            key = self.construct_object(key_node, deep=deep)  # type: ignore[no-untyped-call]
            try:
                first = seen.get(key)
            except TypeError:  # an unhashable key: let the base class report it
                break
            if first is not None:
                raise yaml.constructor.ConstructorError(
                    None, None, f"duplicate key {key!r} (first given at line {first + 1})", key_node.start_mark
                )
            seen[key] = key_node.start_mark.line
        return super().construct_mapping(node, deep=deep)


def read_yaml(path: str | Path) -> Any:
    """Parse a YAML file; a missing file, bad syntax or a duplicate key is a ConfigError naming the file
    (and line)."""
    p = Path(path)
    if not p.is_file():
        raise ConfigError("file not found" if not p.exists() else "not a file", file=str(path))
    try:
        with p.open(encoding="utf-8") as fh:
            return yaml.load(fh, Loader=_UniqueKeyLoader)  # a SafeLoader subclass: safe
    except yaml.YAMLError as err:
        mark = getattr(err, "problem_mark", None)
        where = f"line {mark.line + 1}: " if mark is not None else ""
        problem = getattr(err, "problem", None) or str(err).splitlines()[0]
        raise ConfigError(f"{where}invalid YAML: {problem}", file=str(path)) from None
    except (OSError, UnicodeDecodeError) as err:
        raise ConfigError(f"cannot read: {err}", file=str(path)) from None
    except RecursionError:  # the YAML parser recurses once per level: [[[[… or {a: {a: {… thousands deep
        raise ConfigError(
            "nests too deeply to read (thousands of levels of [ or {); expected a file a few levels deep",
            file=str(path),
        ) from None


def merge_mappings(base: Mapping[str, Any], over: Mapping[str, Any]) -> dict[str, Any]:
    """`over` laid on `base` key by key: mappings merge, everything else (lists too) replaces.

    How an override reads (a config's ``sim:`` over a scenario, ``--set`` keys over a config): the keys it
    names change and the rest of each section stays as it was."""
    out = dict(base)
    for key, value in over.items():
        if isinstance(value, Mapping) and isinstance(out.get(key), Mapping):
            out[key] = merge_mappings(out[key], value)
        else:
            out[key] = value
    return out


def load_model(model: type[M], path: str | Path) -> M:
    """Read and validate a YAML file into `model`."""
    return validate_model(model, read_yaml(path), file=str(path))


# --------------------------------------------------------------------------------------------------
# The mission config file (`--config FILE`)
# --------------------------------------------------------------------------------------------------


class SourceConfig(StrictModel):
    """One perception source: which plugin, its instance name, and its own params (validated by the plugin)."""

    plugin: str  # entry-point name (`mission plugins` lists them)
    name: str | None = None  # defaults to the plugin name; must be unique when a plugin is used twice
    params: dict[str, Any] = Field(default_factory=dict)  # the plugin's own params (see Perception plugins)


class TargetSpec(StrictModel):
    """What a named target looks like to perception; unset fields match anything."""

    marker_id: int | None = Field(None, ge=0)  # fiducial id (aruco / apriltag detections)
    label: str | None = None  # detection label (an AprilTag's entity name, the VLM source's label)
    source: str | None = None  # instance name of the source that must have produced the detection
    # A lost target's walk is fitted from its centre, which does not swing round as it turns (about 0.15 m
    # for a tag on a person's back). Not set in the sim configs: at 0.2 m it made hide_and_wait seed 9 slower
    # under `ideal` (6.7 → 11.4 s), the target turning a corner just as it was lost.
    body_depth_m: float = Field(0.0, ge=0, le=2.0)  # m from the marker (or the VLM's point) back to the centre


class PerceptionConfig(StrictModel):
    """Which sources run on every frame, how their detections combine, and what the named targets look like."""

    sources: list[SourceConfig] = Field(  # the plugins run on every frame, in order
        default_factory=lambda: [SourceConfig(plugin="aruco")]  # with the aruco source's own defaults
    )
    # "all": every source's detections are used; "hybrid": when a precise source (aruco/apriltag) sees a
    # target, detections of the same target from coarse sources (vlm) are dropped (long-range discovery
    # by the VLM, close-range precision from the fiducial).
    policy: Literal["all", "hybrid"] = "hybrid"  # hybrid: a fiducial's detection of a target beats a VLM's
    targets: dict[str, TargetSpec] = Field(  # target name (as the tree's `target` ports use it) → what it looks like
        default_factory=lambda: {"target": TargetSpec(marker_id=7), "dock": TargetSpec(marker_id=0)}
    )


def _not_a_bool(value: Any) -> Any:
    """YAML's true/false where a number is expected: pydantic would read them as 1 and 0."""
    if isinstance(value, bool):
        raise ValueError("expected a number")
    return value


Number = Annotated[float, BeforeValidator(_not_a_bool)]  # a float that YAML's true/false is not


class RunConfig(StrictModel):
    """How the tree is ticked."""

    tick_hz: Number = Field(15.0, gt=0, le=200)  # one perception pass per tick: match the camera rate


class TopicsConfig(StrictModel):
    """Topic names in a recording, for `mission replay` (its `--…-topic` flags override them).

    The ROS node takes the same names as its `-p` parameters. Unset: the node's defaults, and for the
    camera the bag's only image topic when the default is not there."""

    image_topic: str | None = None  # camera images, raw or compressed (default /camera/image_raw)
    camera_info_topic: str | None = None  # sensor_msgs/CameraInfo (default /camera/camera_info)
    depth_topic: str | None = None  # depth images, raw or compressedDepth (default /camera/depth/image_raw)
    odom_topic: str | None = None  # nav_msgs/Odometry (default /odom)
    scan_topic: str | None = None  # sensor_msgs/LaserScan (default /scan)
    map_topic: str | None = None  # nav_msgs/OccupancyGrid (default /map)


class MissionConfig(StrictModel):
    """Top-level config; every section has defaults, so an empty file is a valid config."""

    tree: str = "mission.xml"  # a path, or a file name under trees/
    perception: PerceptionConfig = Field(default_factory=PerceptionConfig)
    run: RunConfig = Field(default_factory=RunConfig)
    topics: TopicsConfig = Field(default_factory=TopicsConfig)
    sim: dict[str, Any] = Field(default_factory=dict)  # scenario keys overridden for this config (see Scenario keys)


def check_config(cfg: MissionConfig, file: str | None = None) -> None:
    """Cross-key checks the schema cannot express, every problem a line. Each would otherwise load and fail
    silently at run time: two targets that look alike (one detection is both), or a target naming a source
    that is not configured (no detection can ever match it)."""
    names = [s.name or s.plugin for s in cfg.perception.sources]
    plugins = {s.plugin for s in cfg.perception.sources}  # matching accepts a plugin name too
    targets = list(cfg.perception.targets.items())
    problems: list[tuple[str | None, str]] = []
    for i, (target, spec) in enumerate(targets):
        twin = next((name for name, other in targets[:i] if other == spec), None)
        if twin is not None:  # one detection would be both targets: the tree could not tell them apart
            problems.append(
                (
                    f"perception.targets.{target}",
                    f"looks exactly like target {twin!r}; expected a marker_id, label or source that tells them apart",
                )
            )
        if spec.source is not None and spec.source not in names and spec.source not in plugins:
            problems.append(
                (
                    f"perception.targets.{target}.source",
                    f"no perception source named {spec.source!r}; configured sources: {', '.join(names) or 'none'}",
                )
            )
    if problems:
        raise ConfigError.several(problems, file=file)


def load_config(path: str | Path | None) -> MissionConfig:
    """The mission config from `path`, or the defaults when no file is given."""
    if path is None:
        return MissionConfig()
    cfg = load_model(MissionConfig, path)
    check_config(cfg, str(path))
    return cfg
