"""Perception sources by name: the config's ``perception.sources`` rows made into running sources.

Sources are plugins of the entry-point group ``mission.perception_plugins`` (core/plugins.py, the one way every
kind of plugin registers), so a third-party package adds a source just by being installed.
"""

from __future__ import annotations

from importlib.metadata import EntryPoint

from mission.core import plugins
from mission.core.config import SourceConfig
from mission.core.errors import ConfigError, PluginError
from mission.core.perception import PerceptionSource


def _entry_points() -> dict[str, EntryPoint]:
    return plugins.installed(plugins.PERCEPTION_SOURCES)


def entry_point(name: str) -> EntryPoint | None:
    """The installed entry point registered as `name` (its ``dist`` is the distribution providing it), or None."""
    return _entry_points().get(name)


def known_names() -> list[str]:
    """Names of every installed source, sorted."""
    return sorted(_entry_points())


def describe() -> list[plugins.PluginInfo]:
    """Every installed source with its one-line description (or the reason it fails to load)."""
    return plugins.describe(plugins.PERCEPTION_SOURCES, _entry_points())


def load_class(name: str) -> type:
    """The source class registered as `name`; unknown names fail with the list of known ones."""
    return plugins.load(plugins.PERCEPTION_SOURCES, name, _entry_points())


def create(cfg: SourceConfig, *, key_prefix: str = "perception.sources", file: str | None = None) -> PerceptionSource:
    """Instantiate one configured source; unknown plugins and param errors name the config file (when
    given) and key."""
    try:
        cls = load_class(cfg.plugin)
    except PluginError as err:
        where = ": ".join(p for p in (file, f"{key_prefix}.plugin") if p)
        raise PluginError(f"{where}: {err}") from None
    name = cfg.name or cfg.plugin
    try:
        return cls(dict(cfg.params), name=name)
    except ConfigError as err:
        raise err.within(f"{key_prefix}.params", file=file) from None
    except Exception as err:  # a third-party constructor failing its own way: still one line, not a traceback
        where = ": ".join(p for p in (file, f"{key_prefix}.plugin") if p)
        why = " ".join(str(err).split())
        raise PluginError(
            f"{where}: perception plugin {cfg.plugin!r} could not be created: {type(err).__name__}: {why}"
        ) from err


def create_all(cfgs: list[SourceConfig], *, file: str | None = None) -> list[PerceptionSource]:
    """Instantiate every configured source, closing the ones already made if a later one fails."""
    names = [c.name or c.plugin for c in cfgs]
    dup = {n for n in names if names.count(n) > 1}
    if dup:
        raise ConfigError(
            f"duplicate source name(s) {sorted(dup)}; give each a distinct `name`", file=file, key="perception.sources"
        )
    made: list[PerceptionSource] = []
    try:
        for i, c in enumerate(cfgs):
            made.append(create(c, key_prefix=f"perception.sources[{i}]", file=file))
    except Exception:
        for s in made:
            s.close()
        raise
    return made
