"""Behaviours from other packages: the entry-point group ``mission.behaviours`` (core/plugins.py, the one way every
kind of plugin registers), registered on a factory explicitly.

A package that ships behaviours declares them in its ``pyproject.toml``; the name is the XML tag::

    [project.entry-points."mission.behaviours"]
    Beacon = "acme_bt.beacon:Beacon"          # a behaviour class: registered as <Beacon/>
    acme = "acme_bt.nodes:register"           # or a function register(factory) -> None, which registers
                                              # several, or ones that need dependencies (factory.register(
                                              # Radio, radio=make_radio()))

Nothing happens on import: :func:`register_installed` loads the entry points when the application asks
(the runner when it builds its factory, ``mission nodes-model`` for the palette), so the factory a run uses
is the one Groot2's palette shows. A plugin that fails to load, or whose tag is taken, is a problem line
naming the entry point; the caller decides whether that stops it.
"""

from __future__ import annotations

import logging

from py_trees.behaviour import Behaviour

from mission.behaviours.ports import PortsDeclared
from mission.core import plugins
from mission.trees.factory import BehaviourFactory, shipped_factory

log = logging.getLogger(__name__)


def register_installed(factory: BehaviourFactory) -> list[str]:
    """Register every installed ``mission.behaviours`` entry point on `factory`; the problems, one line each."""
    problems: list[str] = []
    for ep in plugins.installed(plugins.BEHAVIOURS).values():
        where = f"entry point {ep.name} = {ep.value!r} ({plugins.BEHAVIOURS.group}{plugins.provider(ep)})"
        try:
            target = ep.load()
        except Exception as err:  # a broken package must not hide the others
            problems.append(f"{where}: failed to load: {type(err).__name__}: {' '.join(str(err).split())}")
            continue
        try:
            if isinstance(target, type):
                if not (issubclass(target, PortsDeclared) and issubclass(target, Behaviour)):
                    raise TypeError(
                        "expected a py_trees Behaviour class declaring its ports (a Params dataclass), "
                        f"got the class {target.__name__}"
                    )
                factory.register(target, ep.name)
            elif callable(target):
                target(factory)
            else:
                raise TypeError(f"expected a behaviour class or a function register(factory), got {target!r}")
        except (TypeError, ValueError) as err:
            problems.append(f"{where}: {err}")
    return problems


def mission_factory() -> BehaviourFactory:
    """The shipped behaviours and every installed one: what a run's tree may use. Problems are logged."""
    factory = shipped_factory()
    for problem in register_installed(factory):
        log.warning("%s", problem)
    return factory
