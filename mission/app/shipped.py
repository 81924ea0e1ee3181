"""The configs shipped in mission/configs/, and ``--config`` values that name one (as trees and scenarios are
named): light, so every verb can resolve its ``--config`` before it imports what it runs."""

from __future__ import annotations

from importlib import resources
from pathlib import Path

from mission.core.errors import ConfigError


def shipped_config(name: str) -> Path:
    """A config file shipped in mission/configs/."""
    return Path(str(resources.files("mission") / "configs" / name))


def shipped_configs() -> list[str]:
    """The names of the configs shipped in mission/configs/."""
    return sorted(p.name for p in Path(str(resources.files("mission") / "configs")).glob("*.yaml"))


def shipped_config_named(name: str) -> Path | None:
    """The shipped config a bare name means (``sim_apriltag.yaml`` or ``sim_apriltag``), or None."""
    for candidate in (name, f"{name}.yaml"):
        shipped = shipped_config(candidate)
        if shipped.is_file():
            return shipped
    return None


def resolve_config(name_or_path: str) -> str:
    """A ``--config`` value as a file: a path that exists, else a shipped config's name (``sim_apriltag.yaml``
    or ``sim_apriltag``) as trees and scenarios are named. A bare name that is neither is a ConfigError listing
    the shipped configs; a path-like one is left to the loader (its "file not found" names it)."""
    p = Path(name_or_path)
    if p.exists() or "/" in name_or_path or "\\" in name_or_path:
        return name_or_path
    shipped = shipped_config_named(name_or_path)
    if shipped is not None:
        return str(shipped)
    raise ConfigError(
        f"file not found; expected a config file or a shipped config: {', '.join(shipped_configs())}",
        file=name_or_path,
    )
