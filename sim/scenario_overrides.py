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

from mission.core.config import merge_mappings
from mission.core.errors import ConfigError
from mission.sim.scenario import Scenario, scenario_from_dict


def apply_overrides(
    scenario: Scenario, overrides: dict[str, Any] | None, *, file: str | None = None, within: str = "sim"
) -> Scenario:
    """The scenario with the config's `sim:` keys merged over it (the scenario itself when there are none).

    Problems name the keys under `within` (``sim.camera.widht``), as the config file spells them; ``""``
    names them as scenario keys (``mission run --set camera.widht=…``)."""
    if not overrides:
        return scenario
    if not isinstance(overrides, dict):
        raise ConfigError(f"expected a mapping, got {type(overrides).__name__}", file=file, key=within or None)
    # exclude_unset: what the scenario did not set stays unset, so a realism profile (sim/realism.py) still
    # fills it; the scenario validates the same either way (tests/sim/test_realism.py)
    data = merge_mappings(scenario.model_dump(mode="python", exclude_unset=True), overrides)
    try:
        merged = scenario_from_dict(data, file=file)
    except ConfigError as err:
        if not within:
            raise
        raise err.within(within, file=file) from None
    return merged
