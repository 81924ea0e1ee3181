"""Config schema and loading: one validated object, or one line saying which file and key is wrong.

Models are pydantic with ``extra="forbid"``, so a typo in a key is an error, not a silent default.
Other floors reuse :func:`load_model` / :func:`validate_model` for their own files (scenarios, plugin params).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Literal, TypeVar

import yaml
from pydantic import BaseModel, ConfigDict, Field, ValidationError

from mission.core.errors import ConfigError

M = TypeVar("M", bound=BaseModel)


class StrictModel(BaseModel):
    """Base for every config section: unknown keys are errors, and so are .nan / .inf where a number is
    expected (NaN slips through every range check: ``nan > 0`` and ``nan <= 200`` are both False)."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)


def _dotted(loc: tuple[Any, ...], prefix: str = "") -> str:
    out = prefix
    for part in loc:
        if isinstance(part, int):
            out += f"[{part}]"
        else:
            out += ("." if out else "") + str(part)
    return out or "(top level)"


def format_validation_error(err: ValidationError, *, file: str | None, prefix: str = "") -> ConfigError:
    """The first problem of a pydantic error as a one-line ConfigError naming file and dotted key."""
    first = err.errors()[0]
    key = _dotted(tuple(first["loc"]), prefix)
    kind = first["type"]
    if kind == "extra_forbidden":
        msg = "unknown key"
    elif kind == "missing":
        msg = "required key is missing"
    else:
        got = first.get("input")
        text = first["msg"].removeprefix("Value error, ")  # a validator's own sentence, not pydantic's prefix
        text = text[:1].lower() + text[1:]  # keep names as written (TargetSpec, DICT_4X4_50)
        msg = f"{text}, got {got!r}" if not isinstance(got, dict) else text
    more = len(err.errors()) - 1
    if more:
        msg += f" (and {more} more problem{'s' if more > 1 else ''})"
    return ConfigError(msg, file=file, key=key)


def validate_model(model: type[M], data: Any, *, file: str | None = None, prefix: str = "") -> M:
    """Validate a mapping into `model`, raising a one-line ConfigError on the first problem."""
    if data is None:
        data = {}
    if not isinstance(data, dict):
        raise ConfigError(f"expected a mapping, got {type(data).__name__}", file=file, key=prefix or None)
    try:
        return model.model_validate(data)
    except ValidationError as err:
        raise format_validation_error(err, file=file, prefix=prefix) from None


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
    params: dict[str, Any] = Field(default_factory=dict)  # the plugin's own params (Perception plugins below)


class TargetSpec(StrictModel):
    """What a named target looks like to perception; unset fields match anything."""

    marker_id: int | None = Field(None, ge=0)  # fiducial id (aruco / apriltag detections)
    label: str | None = None  # detection label (an AprilTag's entity name, the VLM's target_label)
    source: str | None = None  # instance name of the source that must have produced the detection


class PerceptionConfig(StrictModel):
    """Which sources run on every frame, how their detections combine, and what the named targets look like."""

    sources: list[SourceConfig] = Field(  # the plugins run on every frame, in order
        default_factory=lambda: [SourceConfig(plugin="aruco", params={"dictionary": "DICT_4X4_250"})]
    )
    # "all": every source's detections are used; "hybrid": when a precise source (aruco/apriltag) sees a
    # target, detections of the same target from coarse sources (vlm) are dropped (long-range discovery
    # by the VLM, close-range precision from the fiducial).
    policy: Literal["all", "hybrid"] = "hybrid"  # hybrid: a fiducial's detection of a target beats a VLM's
    targets: dict[str, TargetSpec] = Field(  # target name (as the tree's `target` ports use it) → what it looks like
        default_factory=lambda: {"target": TargetSpec(marker_id=7), "dock": TargetSpec(marker_id=0)}
    )


class RunConfig(StrictModel):
    """How the tree is ticked."""

    tick_hz: float = Field(15.0, gt=0, le=200)  # one perception pass per tick: match the camera rate


class MissionConfig(StrictModel):
    """Top-level config; every section has defaults, so an empty file is a valid config."""

    tree: str = "mission.xml"  # a path, or a file name under trees/
    perception: PerceptionConfig = Field(default_factory=PerceptionConfig)
    run: RunConfig = Field(default_factory=RunConfig)
    sim: dict[str, Any] = Field(default_factory=dict)  # scenario keys overridden for this config (see Scenario keys)


def check_config(cfg: MissionConfig, file: str | None = None) -> None:
    """Cross-key checks the schema cannot express. Each would otherwise load and fail silently at run time:
    two targets that look alike (one detection is both), or a target naming a source that is not configured
    (no detection can ever match it)."""
    names = [s.name or s.plugin for s in cfg.perception.sources]
    plugins = {s.plugin for s in cfg.perception.sources}  # matching accepts a plugin name too
    targets = list(cfg.perception.targets.items())
    for i, (target, spec) in enumerate(targets):
        twin = next((name for name, other in targets[:i] if other == spec), None)
        if twin is not None:  # one detection would be both targets: the tree could not tell them apart
            raise ConfigError(
                f"looks exactly like target {twin!r}; expected a marker_id, label or source that tells them apart",
                file=file,
                key=f"perception.targets.{target}",
            )
        if spec.source is not None and spec.source not in names and spec.source not in plugins:
            raise ConfigError(
                f"no perception source named {spec.source!r}; configured sources: {', '.join(names) or 'none'}",
                file=file,
                key=f"perception.targets.{target}.source",
            )


def load_config(path: str | Path | None) -> MissionConfig:
    """The mission config from `path`, or the defaults when no file is given."""
    if path is None:
        return MissionConfig()
    cfg = load_model(MissionConfig, path)
    check_config(cfg, str(path))
    return cfg
