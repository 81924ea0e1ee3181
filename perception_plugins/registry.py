"""One registry maps plugin names to PerceptionSource classes, through entry points.

Entry points (group ``mission.perception_plugins``) mean a third-party package adds a source just by
being installed; nothing here lists the shipped plugins by hand.
"""

from __future__ import annotations

from dataclasses import dataclass
from importlib.metadata import EntryPoint, entry_points

from mission.core.config import SourceConfig
from mission.core.errors import ConfigError, PluginError
from mission.core.perception import ENTRY_POINT_GROUP, PerceptionSource


def _entry_points() -> dict[str, EntryPoint]:
    return {ep.name: ep for ep in entry_points(group=ENTRY_POINT_GROUP)}


def entry_point(name: str) -> EntryPoint | None:
    """The installed entry point registered as `name` (its ``dist`` is the distribution providing it), or None."""
    return _entry_points().get(name)


def known_names() -> list[str]:
    """Names of every installed plugin, sorted."""
    return sorted(_entry_points())


@dataclass(frozen=True)
class PluginInfo:
    name: str
    target: str  # "module:Class"
    description: str
    error: str | None = None  # why it could not be loaded, if it could not


def describe() -> list[PluginInfo]:
    """Every installed plugin with its one-line description (or the reason it fails to load)."""
    out = []
    for name, ep in sorted(_entry_points().items()):
        try:
            cls = ep.load()
            desc = getattr(cls, "description", "") or (cls.__doc__ or "").strip().splitlines()[0]
            out.append(PluginInfo(name, ep.value, desc))
        except Exception as err:  # a broken third-party plugin must not hide the others
            out.append(PluginInfo(name, ep.value, "", error=f"{type(err).__name__}: {err}"))
    return out


def load_class(name: str) -> type:
    """The source class registered as `name`; unknown names fail with the list of known ones."""
    eps = _entry_points()
    if name not in eps:
        known = ", ".join(sorted(eps)) or "(none installed)"
        raise PluginError(f"unknown perception plugin {name!r}; known plugins: {known}")
    try:
        return eps[name].load()
    except Exception as err:
        raise PluginError(f"perception plugin {name!r} ({eps[name].value}) failed to load: {err}") from err


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
        raise PluginError(f"{where}: perception plugin {cfg.plugin!r} could not be created: "
                          f"{type(err).__name__}: {why}") from err


def create_all(cfgs: list[SourceConfig], *, file: str | None = None) -> list[PerceptionSource]:
    """Instantiate every configured source, closing the ones already made if a later one fails."""
    names = [c.name or c.plugin for c in cfgs]
    dup = {n for n in names if names.count(n) > 1}
    if dup:
        raise ConfigError(f"duplicate source name(s) {sorted(dup)}; give each a distinct `name`",
                          file=file, key="perception.sources")
    made: list[PerceptionSource] = []
    try:
        for i, c in enumerate(cfgs):
            made.append(create(c, key_prefix=f"perception.sources[{i}]", file=file))
    except Exception:
        for s in made:
            s.close()
        raise
    return made
