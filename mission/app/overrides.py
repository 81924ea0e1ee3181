"""``--set KEY=VALUE``: one run's changes to tree ports, config keys and scenario keys.

`mission run --set` gives one value per key; `mission sweep --set` a comma-separated list, one grid axis
per key. The first part of a key says what it changes:

* ``Tag.port`` (``SearchSweep.angular_speed``), a shipped behaviour's port: every node of that type in
  the run's tree gets the value, whatever the tree file writes (trees/factory.py
  ``BehaviourFactory.set_port``; the file itself is not touched);
* a config key (``run.tick_hz``, ``perception.policy``, ``tree``, ``sim.camera.width``): laid over the
  config file's data and validated as the file is;
* a scenario key (``duration_s``, ``target.speed_mps``, ``camera.width``): the same as ``sim.<key>`` in
  the config (sim/scenario_overrides.py), laid over the scenario after the config's own ``sim:``.

Values are YAML (``0.6``, ``true``, ``follow.xml``, ``{width: 320, height: 240}``); mappings merge into the
section they name and everything else replaces. A key that names nothing is one line naming it, with
the nearest valid key; a value the schema refuses is one line naming the key and what was expected —
both before anything runs.
"""

from __future__ import annotations

import difflib
import json
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from typing import Any, Literal

import yaml

from mission.core.config import MissionConfig, check_config, known_keys, merge_mappings, validate_model
from mission.core.errors import ConfigError
from mission.sim.scenario import Scenario
from mission.sim.scenario_overrides import apply_overrides
from mission.trees.factory import BehaviourFactory, shipped_factory

Kind = Literal["port", "config", "scenario"]
WHERE = "--set"  # what the messages name as the "file" a problem is in


@dataclass(frozen=True)
class Setting:
    """One key and its value for a run; `kind` says which part of the run it changes."""

    key: str  # as the user wrote it: "SearchSweep.angular_speed", "run.tick_hz", "camera.width"
    value: Any  # parsed YAML
    kind: Kind

    @property
    def text(self) -> str:
        """``key=value`` as it would be typed again (``mission run --set …`` reproduces the run)."""
        return f"{self.key}={format_value(self.value)}"


@dataclass(frozen=True)
class RunOverrides:
    """Every ``--set`` of one run, in the order given. Empty: the run as its files describe it."""

    settings: tuple[Setting, ...] = ()

    def __bool__(self) -> bool:
        return bool(self.settings)

    def as_dict(self) -> dict[str, Any]:
        """key → value, in order (a results table's parameter columns)."""
        return {s.key: s.value for s in self.settings}

    @property
    def label(self) -> str:
        """``SearchSweep.angular_speed=0.6 run.tick_hz=10`` (empty without settings)."""
        return " ".join(s.text for s in self.settings)

    def config_overlay(self) -> dict[str, Any]:
        """The config keys as a nested mapping to lay over the config file's data."""
        return _nested((s.key, s.value) for s in self.settings if s.kind == "config")

    def scenario_overlay(self) -> dict[str, Any]:
        """The scenario keys (``sim.`` spellings included) as a nested mapping to lay over the scenario."""
        return _nested((s.key.removeprefix("sim."), s.value) for s in self.settings if s.kind == "scenario")

    def apply_to_config(self, config: MissionConfig) -> MissionConfig:
        """`config` with the config keys laid over it; a refused value is a ConfigError in ``--set``."""
        overlay = self.config_overlay()
        if not overlay:
            return config
        # exclude_unset: what the file did not set stays unset (`tree` chosen by the scenario stays so)
        data = merge_mappings(config.model_dump(mode="python", exclude_unset=True), overlay)
        merged = validate_model(MissionConfig, data, file=WHERE)
        check_config(merged, WHERE)
        return merged

    def apply_to_scenario(self, scenario: Scenario) -> Scenario:
        """`scenario` with the scenario keys laid over it (after the config's ``sim:``)."""
        return apply_overrides(scenario, self.scenario_overlay(), file=WHERE, within="")

    def apply_to_factory(self, factory: BehaviourFactory) -> None:
        """Every ``Tag.port`` setting on `factory` (the run's), before its tree is loaded."""
        for s in self.settings:
            if s.kind == "port":
                tag, port = s.key.split(".", 1)
                try:
                    factory.set_port(tag, port, s.value)
                except ValueError as err:
                    raise ConfigError(str(err), file=WHERE, key=s.key) from None


def format_value(value: Any) -> str:
    """A value as YAML reads it back: ``0.6``, ``true``, ``follow.xml``, ``{"width": 320}``."""
    if isinstance(value, str):
        return value
    return json.dumps(value, sort_keys=False)


def _nested(pairs: Iterable[tuple[str, Any]]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for key, value in pairs:
        *parents, last = key.split(".")
        node = out
        for part in parents:
            node = node.setdefault(part, {})
        both = isinstance(node.get(last), dict) and isinstance(value, dict)
        node[last] = merge_mappings(node[last], value) if both else value
    return out


# ------------------------------------------------------------------------------------ parsing
def split_values(text: str) -> list[str]:
    """``0.6,1.0`` → ``["0.6", "1.0"]``; commas inside ``[]``, ``{}`` or quotes belong to the value."""
    parts, depth, quote, start = [], 0, "", 0
    for i, ch in enumerate(text):
        if quote:
            quote = "" if ch == quote else quote
        elif ch in "'\"":
            quote = ch
        elif ch in "[{":
            depth += 1
        elif ch in "]}":
            depth -= 1
        elif ch == "," and depth == 0:
            parts.append(text[start:i])
            start = i + 1
    parts.append(text[start:])
    return [p.strip() for p in parts]


def parse_value(text: str, key: str) -> Any:
    try:
        return yaml.safe_load(text) if text.strip() else ""
    except yaml.YAMLError as err:
        problem = getattr(err, "problem", None) or str(err).splitlines()[0]
        raise ConfigError(f"value {text!r} is not YAML: {problem}", file=WHERE, key=key) from None


def parse_setting(text: str, *, many: bool) -> tuple[str, list[Setting]]:
    """``KEY=VALUE`` (``KEY=V1,V2,…`` when `many`) → the key and one Setting per value, the key checked."""
    key, sep, rest = text.partition("=")
    key = key.strip()
    form = "KEY=VALUE[,VALUE…]" if many else "KEY=VALUE"
    if not sep or not key:
        raise ConfigError(f"expected {form}, got {text!r}", file=WHERE)
    kind = classify(key)
    texts = split_values(rest) if many else [rest.strip()]
    if many and any(t == "" for t in texts) and len(texts) > 1:
        raise ConfigError(f"empty value in {rest!r}; expected {form}", file=WHERE, key=key)
    return key, [Setting(key, parse_value(t, key), kind) for t in texts]


def parse_settings(texts: Iterable[str], *, many: bool) -> list[tuple[str, list[Setting]]]:
    """Every ``--set``, in order; a key given twice is an error (which value would it be?)."""
    out: list[tuple[str, list[Setting]]] = []
    for text in texts:
        key, settings = parse_setting(text, many=many)
        if any(k == key or k.removeprefix("sim.") == key.removeprefix("sim.") for k, _ in out):
            raise ConfigError(
                "given twice; expected each key once" + (" (values comma-separated)" if many else ""),
                file=WHERE,
                key=key,
            )
        out.append((key, settings))
    return out


def run_overrides(texts: Iterable[str]) -> RunOverrides:
    """`mission run --set KEY=VALUE …` as one run's overrides."""
    return RunOverrides(tuple(s for _, settings in parse_settings(texts, many=False) for s in settings))


# ------------------------------------------------------------------------------------ keys
def _port_keys(factory: BehaviourFactory) -> dict[str, list[str]]:
    return {m.tag: list(m.ports) for m in factory.behaviours()}


def classify(key: str, factory: BehaviourFactory | None = None) -> Kind:
    """Which part of a run `key` changes; a key that names nothing is a ConfigError with the nearest key.

    Keys below the first part are checked here as far as the names go (a port's name, a config or
    scenario key's sections); values, and keys inside free mappings, when the run's files are checked."""
    head, _, rest = key.partition(".")
    ports = _port_keys(factory or shipped_factory())
    if head in ports:
        if not rest or "." in rest or rest not in ports[head]:
            hint = difflib.get_close_matches(rest, ports[head], n=1)
            raise ConfigError(
                f"{head} has no port {rest!r}{f' (did you mean {head}.{hint[0]}?)' if hint else ''}; "
                f"its ports: {', '.join(ports[head]) or 'none'}",
                file=WHERE,
                key=key,
            )
        return "port"
    if head == "sim" and rest:
        _check_path(Scenario, rest.split("."), key, prefix="sim.")
        return "scenario"
    if head in known_keys(MissionConfig, ()):
        _check_path(MissionConfig, key.split("."), key)
        return "config"
    if head in known_keys(Scenario, ()):
        _check_path(Scenario, key.split("."), key)
        return "scenario"
    hint = difflib.get_close_matches(key, list(valid_keys(factory)), n=1, cutoff=0.5)
    raise ConfigError(
        f"unknown key{f' (did you mean {hint[0]}?)' if hint else ''}; expected Behaviour.port "
        "(e.g. SearchSweep.angular_speed), a config key (e.g. run.tick_hz) or a scenario key (e.g. camera.width)",
        file=WHERE,
        key=key,
    )


def _check_path(model: type, parts: list[str], key: str, prefix: str = "") -> None:
    """Each part names a key of the section before it, as far as sections are models (a free mapping's
    keys and list items are the schema's to check when the value is validated)."""
    for i, part in enumerate(parts):
        names = known_keys(model, parts[:i])
        if not names:
            return
        if part not in names:
            hint = difflib.get_close_matches(part, names, n=1)
            near = f" (did you mean {prefix}{'.'.join([*parts[:i], hint[0]])}?)" if hint else ""
            raise ConfigError(f"unknown key{near}", file=WHERE, key=key)


def valid_keys(factory: BehaviourFactory | None = None) -> Iterator[str]:
    """Every key ``--set`` accepts (free mappings' keys aside): ports, then config keys, then scenario keys."""
    for tag, ports in _port_keys(factory or shipped_factory()).items():
        for port in ports:
            yield f"{tag}.{port}"
    yield from _dotted(MissionConfig, ())
    yield from _dotted(Scenario, ())


def _dotted(model: type, loc: tuple[str, ...], depth: int = 4) -> Iterator[str]:
    for name in known_keys(model, loc):
        yield ".".join((*loc, name))
        if depth > 1:
            yield from _dotted(model, (*loc, name), depth - 1)
