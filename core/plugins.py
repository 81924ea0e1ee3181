"""One way to register a plugin: an entry point of the installed package, found by name at run time.

As Nav2's pluginlib loads a controller by the class name a parameter gives, a config names a plugin and the
registry loads it from the installed entry points; a package adds a plugin just by being installed, and
nothing lists the shipped ones by hand (they are entry points of this package's pyproject.toml too).

There are three kinds, each an entry-point group with a small interface:

========================== ================================================================================
group                      the entry point names
========================== ================================================================================
mission.perception_plugins a :class:`~mission.core.perception.PerceptionSource` class, built as
                           ``cls(params: dict, name=...)`` from a config's ``perception.sources`` row
mission.behaviours         a py_trees ``Behaviour`` class declaring its ports (registered under the entry
                           point's name as its XML tag), or a function ``register(factory) -> None``
mission.vlm_clients        a factory ``(params, budget) -> VlmClient`` for the VLM source's ``client``
                           param (perception_plugins/vlm/client.py has the protocol)
========================== ================================================================================

Loading is lazy: nothing is imported until a name is asked for, so a client's HTTP library loads only for
the configs that use it. A plugin that fails to load is a :class:`~mission.core.errors.PluginError` naming
the entry point; listing (``mission plugins``) shows it as broken without hiding the others.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from importlib.metadata import EntryPoint, entry_points
from typing import Any

from mission.core.errors import PluginError


@dataclass(frozen=True)
class PluginKind:
    """One entry-point group and how messages name its members."""

    group: str  # the entry-point group a package declares its plugins under
    noun: str  # "perception plugin": what an error calls one of them
    known: str  # "known plugins": how an error introduces the installed names
    interface: str  # one line: what the entry point must name


PERCEPTION_SOURCES = PluginKind(
    group="mission.perception_plugins",
    noun="perception plugin",
    known="known plugins",
    interface="a PerceptionSource class (mission.core.perception)",
)
BEHAVIOURS = PluginKind(
    group="mission.behaviours",
    noun="behaviour plugin",
    known="known behaviour plugins",
    interface="a Behaviour class declaring its ports, or register(factory)",
)
VLM_CLIENTS = PluginKind(
    group="mission.vlm_clients",
    noun="VLM client",
    known="known clients",
    interface="a factory (params, budget) -> VlmClient",
)
KINDS = (PERCEPTION_SOURCES, BEHAVIOURS, VLM_CLIENTS)


def installed(kind: PluginKind) -> dict[str, EntryPoint]:
    """The installed entry points of `kind`, by name, sorted."""
    return {ep.name: ep for ep in sorted(entry_points(group=kind.group), key=lambda ep: ep.name)}


def provider(ep: EntryPoint) -> str:
    """Who provides `ep`, for messages: ``" from <distribution> <version>"``, or "" when unknown."""
    dist = getattr(ep, "dist", None)
    return f" from {dist.name} {dist.version}" if dist is not None else ""


def load(kind: PluginKind, name: str, available: Mapping[str, EntryPoint] | None = None) -> Any:
    """What the entry point `name` of `kind` names. Unknown names fail listing the known ones; a plugin that
    cannot be imported fails naming its target. `available` defaults to :func:`installed`."""
    eps = installed(kind) if available is None else available
    if name not in eps:
        known = ", ".join(sorted(eps)) or "(none installed)"
        raise PluginError(f"unknown {kind.noun} {name!r}; {kind.known}: {known}")
    try:
        return eps[name].load()
    except Exception as err:  # a broken third-party package: one line, not its traceback
        why = " ".join(str(err).split())
        raise PluginError(f"{kind.noun} {name!r} ({eps[name].value}) failed to load: {why}") from err


@dataclass(frozen=True)
class PluginInfo:
    """One installed plugin as `mission plugins` lists it."""

    kind: PluginKind
    name: str
    target: str  # "module:attr"
    description: str
    error: str | None = None  # why it could not be loaded, if it could not


def describe(kind: PluginKind, available: Mapping[str, EntryPoint] | None = None) -> list[PluginInfo]:
    """Every installed plugin of `kind` with its one-line description (its ``description`` attribute or the
    first line of its docstring), or the reason it fails to load."""
    eps = installed(kind) if available is None else available
    out = []
    for name, ep in sorted(eps.items()):
        try:
            target = ep.load()
            doc = (getattr(target, "__doc__", None) or "").strip().splitlines()
            desc = getattr(target, "description", "") or (doc[0] if doc else "")
            out.append(PluginInfo(kind, name, ep.value, desc))
        except Exception as err:  # a broken third-party plugin must not hide the others
            out.append(PluginInfo(kind, name, ep.value, "", error=f"{type(err).__name__}: {err}"))
    return out
