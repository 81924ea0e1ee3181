"""Nav2's docking and following servers configured by Nav2's own names: a drop-in for opennav_docking's and
opennav_following's parameter files.

A Nav2 user's params file has a ``docking_server:`` (or ``following_server:``, or ``/**:``) section with
``ros__parameters:``. This module reads those parameters — flattened the way rcl flattens them
(``home_dock.pose``) — into :class:`DockingParams` and :class:`FollowingParams`, with Nav2's defaults
(ros-navigation/navigation2, branch jazzy: docking_server.cpp, simple_charging_dock.cpp, utils.hpp's
parseDockFile / parseDockParams; opennav_following's parameter_handler.cpp).

The dock database is what Nav2 makes of it:

* dock instances from the ``docks`` parameter (each ``NAME.type``, ``NAME.pose`` [x, y, yaw], ``NAME.frame``
  default ``map``, ``NAME.id``) or from the YAML file ``dock_database`` (``docks: {NAME: {type, pose, …}}``);
* dock types from ``dock_plugins`` (each ``TYPE.plugin`` and the plugin's own keys: ``staging_x_offset``,
  ``staging_yaw_offset``, ``docking_threshold``, ``use_external_detection_pose``, the
  ``external_detection_*`` offsets);
* a goal's ``dock_id`` names an instance (the database key, as Nav2's ``findDock``); a dock's ``type`` may be
  empty when there is one type only.

A dock's ``pose`` is where the robot's base is when docked, facing the dock; the staging pose lies
``staging_x_offset`` (negative: behind) along that heading, turned by ``staging_yaw_offset``.

Nav2 ignores keys it does not know; so does this, except that a key a letter or two away from a known one is
a warning with a did-you-mean (``max_retry`` → ``max_retries``), since a silent typo there is a lost setting.
A missing or malformed value Nav2 requires (a dock without ``type`` or a 3-number ``pose``, a type that is not
in ``dock_plugins``) is a ConfigError naming the file and the key.
"""

from __future__ import annotations

import difflib
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any

import yaml

from mission.core.errors import ConfigError

Warn = Callable[[str], None]


@dataclass(frozen=True)
class DockType:
    """One entry of ``dock_plugins``: a model of dock (SimpleChargingDock's keys and defaults)."""

    name: str
    plugin: str = ""
    staging_x_offset: float = -0.7  # m along the dock pose's heading (negative: the robot stages behind it)
    staging_yaw_offset: float = 0.0  # rad, added to the dock pose's yaw
    docking_threshold: float = 0.05  # m from the dock pose at which the robot counts as docked
    use_external_detection_pose: bool = False  # the dock is detected (our perception) rather than taken as given
    external_detection_timeout: float = 1.0  # s without a detection before the approach fails
    external_detection_translation_x: float = -0.20  # detected pose → docked pose offsets (Nav2's defaults
    external_detection_translation_y: float = 0.0  # are set up for AprilTag detectors)
    external_detection_rotation_yaw: float = 0.0
    external_detection_rotation_pitch: float = 1.57
    external_detection_rotation_roll: float = -1.57


@dataclass(frozen=True)
class Dock:
    """One dock instance of the database: where the robot's base is when docked, facing the dock."""

    name: str
    type: str
    x: float
    y: float
    yaw: float
    frame: str = "map"
    id: str = ""  # e.g. the tag on it

    def staging_pose(self, dock_type: DockType) -> tuple[float, float, float]:
        """Where docking starts: `staging_x_offset` along the dock pose's heading, turned by the yaw offset."""
        x = self.x + dock_type.staging_x_offset * math.cos(self.yaw)
        y = self.y + dock_type.staging_x_offset * math.sin(self.yaw)
        return x, y, _wrap(self.yaw + dock_type.staging_yaw_offset)


@dataclass(frozen=True)
class DockingParams:
    """The docking server's parameters (docking_server.cpp's names and defaults) and its dock database."""

    controller_frequency: float = 50.0
    initial_perception_timeout: float = 5.0  # s to first see the dock from the staging pose
    wait_charge_timeout: float = 5.0
    dock_approach_timeout: float = 30.0  # s for one approach from staging to docked
    undock_linear_tolerance: float = 0.05
    undock_angular_tolerance: float = 0.05
    max_retries: int = 3
    base_frame: str = "base_link"
    fixed_frame: str = "odom"
    dock_backwards: bool = False
    dock_prestaging_tolerance: float = 0.5  # closer than this to the staging pose (x, y, yaw L2): no navigation
    dock_types: Mapping[str, DockType] = field(default_factory=dict)
    docks: Mapping[str, Dock] = field(default_factory=dict)

    def find_dock(self, dock_id: str) -> Dock | None:
        """The instance a goal's ``dock_id`` names (the database key, as Nav2's findDock), or None."""
        return self.docks.get(dock_id)

    def find_type(self, name: str) -> DockType | None:
        """The dock type `name`, or the only one when `name` is empty (Nav2's findDockPlugin), or None."""
        if not name and len(self.dock_types) == 1:
            return next(iter(self.dock_types.values()))
        return self.dock_types.get(name)


@dataclass(frozen=True)
class FollowingParams:
    """The following server's parameters (opennav_following's parameter_handler.cpp names and defaults)."""

    controller_frequency: float = 50.0
    detection_timeout: float = 2.0  # s without a pose before the object counts as lost
    rotate_to_object_timeout: float = 10.0
    static_object_timeout: float = -1.0  # s the object may stand still before the goal ends (-1: never)
    linear_tolerance: float = 0.15
    angular_tolerance: float = 0.15
    max_retries: int = 3
    base_frame: str = "base_link"
    fixed_frame: str = "odom"
    desired_distance: float = 1.0  # m to keep from the object
    skip_orientation: bool = True
    search_by_rotating: bool = False  # Nav2's search: turn ±search_angle in place (ours is the search ladder)
    search_angle: float = math.pi / 2
    transform_tolerance: float = 0.1
    odom_topic: str = "odom"
    odom_duration: float = 0.3
    filter_coef: float = 0.1


_DOCK_TYPE_KEYS = {f.name for f in fields(DockType)} - {"name"}
_SERVER_KEYS = {f.name for f in fields(DockingParams)} - {"dock_types", "docks"}
_OTHER_DOCKING_KEYS = {"dock_plugins", "docks", "dock_database", "navigator_bt_xml", "action_server_result_timeout"}
_FOLLOWING_KEYS = {f.name for f in fields(FollowingParams)}


def _wrap(angle: float) -> float:
    return math.atan2(math.sin(angle), math.cos(angle))


# --- the params file ------------------------------------------------------------------------------------


PARAMS_DIR = Path(__file__).resolve().parent / "params"  # the params files shipped with the node


def resolve_params_file(name_or_path: str) -> str:
    """A ``--params-file`` value as a file: a path that exists (or looks like a path), else the name of a params
    file shipped in mission/ros/params/ (``explore_dock`` or ``explore_dock.yaml``), so the docs' examples
    work from any directory after ``pip install``. Anything else is left to :func:`read_params_file`, whose
    error names it."""
    if Path(name_or_path).exists() or "/" in name_or_path or "\\" in name_or_path:
        return name_or_path
    for candidate in (name_or_path, f"{name_or_path}.yaml"):
        shipped = PARAMS_DIR / candidate
        if shipped.is_file():
            return str(shipped)
    return name_or_path


def read_params_file(path: str | Path, *node_names: str) -> dict[str, Any]:
    """The parameters a node gets from a ROS 2 params file, flattened as rcl does (``home_dock: {pose: […]}``
    → ``home_dock.pose``): the ``/**`` section, then each of `node_names` in order, a later one winning.
    Several names: our node serves what Nav2 splits between ``docking_server`` and ``following_server``."""
    path = Path(path)
    try:
        data = yaml.safe_load(path.read_text(encoding="utf-8"))
    except OSError as err:
        raise ConfigError(f"cannot read the params file ({err.strerror or err})", file=str(path)) from None
    except yaml.YAMLError as err:
        where = getattr(err, "problem_mark", None)
        line = f"line {where.line + 1}: " if where is not None else ""
        raise ConfigError(f"{line}not YAML: {getattr(err, 'problem', err)}", file=str(path)) from None
    if not isinstance(data, dict):
        raise ConfigError("expected node names mapping to {ros__parameters: …}", file=str(path))
    out: dict[str, Any] = {}
    wanted = ["/**"] + [k for name in node_names for k in (name, f"/{name}")]
    sections = [k for k in wanted if k in data]
    if not sections:
        expected = " or ".join(repr(k) for k in ["/**", *node_names])
        raise ConfigError(
            f"no section for this node: expected {expected}, found {', '.join(repr(k) for k in data) or 'nothing'}",
            file=str(path),
        )
    for key in sections:
        body = data[key]
        if not isinstance(body, dict) or not isinstance(body.get("ros__parameters"), dict):
            raise ConfigError("expected 'ros__parameters:' with the parameters under it", file=str(path), key=key)
        _flatten(body["ros__parameters"], "", out)
    return out


def _flatten(tree: Mapping[str, Any], prefix: str, out: dict[str, Any]) -> None:
    for key, value in tree.items():
        name = f"{prefix}{key}"
        if isinstance(value, dict):
            _flatten(value, f"{name}.", out)
        else:
            out[name] = value


# --- values ---------------------------------------------------------------------------------------------


def _typed(value: Any, like: Any, key: str, file: str | None) -> Any:
    """`value` as the type of the default `like` (ROS parameters are typed by their default)."""
    if isinstance(like, bool):
        if isinstance(value, bool):
            return value
        raise ConfigError(f"expected true or false, got {value!r}", file=file, key=key)
    if isinstance(like, int):
        if isinstance(value, int) and not isinstance(value, bool):
            return value
        raise ConfigError(f"expected a whole number, got {value!r}", file=file, key=key)
    if isinstance(like, float):
        if isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value):
            return float(value)
        raise ConfigError(f"expected a number, got {value!r}", file=file, key=key)
    if isinstance(value, str):
        return value
    raise ConfigError(f"expected a string, got {value!r}", file=file, key=key)


def _settings(cls: type, params: Mapping[str, Any], prefix: str, keys: set[str], file: str | None) -> dict[str, Any]:
    defaults = cls()  # type: ignore[call-arg]
    return {k: _typed(params[prefix + k], getattr(defaults, k), prefix + k, file) for k in keys if prefix + k in params}


def _dock_settings(params: Mapping[str, Any], name: str, file: str | None) -> dict[str, Any]:
    defaults = DockType(name)
    return {
        k: _typed(params[f"{name}.{k}"], getattr(defaults, k), f"{name}.{k}", file)
        for k in _DOCK_TYPE_KEYS
        if f"{name}.{k}" in params
    }


def _names(value: Any, key: str, file: str | None) -> list[str]:
    if not isinstance(value, list) or not all(isinstance(v, str) and v for v in value):
        raise ConfigError(f"expected a list of names, got {value!r}", file=file, key=key)
    return list(value)


def _dock(name: str, attrs: Mapping[str, Any], key: str, file: str | None) -> Dock:
    """One dock instance from its attributes (parseDockFile / parseDockParams: type and pose required)."""
    if "type" not in attrs or not isinstance(attrs["type"], str):
        raise ConfigError(
            "expected the dock's 'type' (a dock_plugins name; '' when there is one type)", file=file, key=f"{key}.type"
        )
    pose = attrs.get("pose")
    if not (isinstance(pose, list) and len(pose) == 3 and all(_is_number(v) for v in pose)):
        raise ConfigError(f"expected [x, y, yaw], got {pose!r}", file=file, key=f"{key}.pose")
    frame = attrs.get("frame", "map")
    dock_id = attrs.get("id", "")
    if not isinstance(frame, str) or not frame:
        raise ConfigError(f"expected a frame name, got {frame!r}", file=file, key=f"{key}.frame")
    return Dock(name, attrs["type"], float(pose[0]), float(pose[1]), float(pose[2]), frame, str(dock_id))


def _is_number(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def _near_misses(params: Mapping[str, Any], known: set[str], prefixes: set[str], warn: Warn | None) -> None:
    if warn is None:
        return
    for key in params:
        head = key.split(".", 1)[0]
        if key in known or head in prefixes:
            continue
        close = difflib.get_close_matches(key, sorted(known), n=1, cutoff=0.85)
        if close:
            warn(f"parameter {key!r} is not one Nav2's server reads (did you mean {close[0]!r}?); ignored")


# --- the two servers ------------------------------------------------------------------------------------


def docking_params(params: Mapping[str, Any], *, file: str | None = None, warn: Warn | None = None) -> DockingParams:
    """The docking server's configuration from flattened parameters (:func:`read_params_file`)."""
    server = _settings(DockingParams, params, "", _SERVER_KEYS, file)
    types: dict[str, DockType] = {}
    if "dock_plugins" in params:
        for name in _names(params["dock_plugins"], "dock_plugins", file):
            types[name] = DockType(name, **_dock_settings(params, name, file))
    docks: dict[str, Dock] = {}
    if params.get("dock_database"):
        docks.update(_database_file(params["dock_database"], file))
    if "docks" in params:
        for name in _names(params["docks"], "docks", file):
            attrs = {k.split(".", 1)[1]: v for k, v in params.items() if k.startswith(f"{name}.")}
            docks[name] = _dock(name, attrs, name, file)
    for dock in docks.values():
        if not dock.type and len(types) == 1:
            continue
        if dock.type not in types:
            known = ", ".join(types) or "none (dock_plugins is empty)"
            raise ConfigError(
                f"dock type {dock.type!r} is not in dock_plugins; known: {known}", file=file, key=f"{dock.name}.type"
            )
    _near_misses(params, _SERVER_KEYS | _OTHER_DOCKING_KEYS, set(types) | set(docks), warn)
    return DockingParams(**server, dock_types=types, docks=docks)


def _database_file(path_value: Any, file: str | None) -> dict[str, Dock]:
    """The ``dock_database`` YAML file (parseDockFile): ``docks: {NAME: {type, pose, frame, id}}``."""
    if not isinstance(path_value, str):
        raise ConfigError(f"expected a file path, got {path_value!r}", file=file, key="dock_database")
    path = Path(path_value)
    if not path.is_absolute() and file is not None:
        path = Path(file).parent / path  # relative to the params file that names it
    try:
        data = yaml.safe_load(path.read_text(encoding="utf-8"))
    except OSError as err:
        raise ConfigError(f"cannot read {path} ({err.strerror or err})", file=file, key="dock_database") from None
    except yaml.YAMLError as err:
        raise ConfigError(f"not YAML: {err}", file=str(path)) from None
    if not isinstance(data, dict) or not isinstance(data.get("docks"), dict):
        raise ConfigError("expected 'docks:' with one entry per dock", file=str(path))
    docks = {}
    for name, attrs in data["docks"].items():
        if not isinstance(attrs, dict):
            raise ConfigError(f"expected the dock's attributes, got {attrs!r}", file=str(path), key=f"docks.{name}")
        docks[str(name)] = _dock(str(name), attrs, f"docks.{name}", str(path))
    return docks


def following_params(
    params: Mapping[str, Any], *, file: str | None = None, warn: Warn | None = None
) -> FollowingParams:
    """The following server's configuration from flattened parameters (:func:`read_params_file`)."""
    settings = _settings(FollowingParams, params, "", _FOLLOWING_KEYS, file)
    _near_misses(params, _FOLLOWING_KEYS, {"controller"}, warn)
    return FollowingParams(**settings)
