"""The `sim:` section of a mission config: scenario settings overridden per run.

Any scenario key can be overridden, e.g. a config that renders with EGL at 320×240 without noise::

    sim:
      camera: {renderer: egl, width: 320, height: 240}
      lighting: {image_noise_sigma: 0}

The override is merged key by key over the scenario (mappings merge, everything else replaces) and
the result is validated like a scenario file, so a typo is one line naming the config file and the
dotted key (``config.yaml: sim.camera.widht: unknown key``).
"""

from __future__ import annotations

from typing import Any

from mission.core.errors import ConfigError
from mission.sim.scenario import Scenario, scenario_from_dict


def _merge(base: dict[str, Any], over: dict[str, Any]) -> dict[str, Any]:
    out = dict(base)
    for key, value in over.items():
        if isinstance(value, dict) and isinstance(out.get(key), dict):
            out[key] = _merge(out[key], value)
        else:
            out[key] = value
    return out


def apply_overrides(scenario: Scenario, overrides: dict[str, Any] | None, *, file: str | None = None) -> Scenario:
    """The scenario with the config's `sim:` keys merged over it (the scenario itself when there are none)."""
    if not overrides:
        return scenario
    if not isinstance(overrides, dict):
        raise ConfigError(f"expected a mapping, got {type(overrides).__name__}", file=file, key="sim")
    data = _merge(scenario.model_dump(mode="python"), overrides)
    try:
        merged = scenario_from_dict(data, file=file)
    except ConfigError as err:
        raise err.within("sim", file=file) from None
    return merged
