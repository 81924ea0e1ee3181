"""The tree factory: which node types a tree file may use, and what each is built from.

Modelled on BehaviorTree.CPP's ``BehaviorTreeFactory``: a factory starts with the BT.CPP built-ins
(trees/builtins.py) and behaviours are registered on it explicitly, each under an XML tag and with the
extra constructor arguments it needs (its dependencies) given at registration, as
``registerNodeType<T>(ID, args...)`` does::

    factory = shipped_factory()                       # the shipped behaviours (FollowTarget, …)
    factory.register(Beacon, radio=radio)             # every <Beacon .../> is built with radio=radio
    root = load_tree("patrol.xml", factory)

Nothing is discovered: no import side effects fill it, no constructor signature is inspected. A node's
ports come from its class's declaration (behaviours/ports.py); the factory turns a class into a
:class:`~mission.trees.manifest.NodeManifest`, which is all the loader, the Groot2 TreeNodesModel and the
the docs' behaviour table read. :func:`shipped_factory` is the one list of the behaviours that ship.

Scripting enums (BT.CPP's ``registerScriptingEnum``) are registered here too: names a script may use for
numbers. The shipped factory registers the mission states, so ``_skipIf="mission_state == DONE"`` reads.
"""

from __future__ import annotations

import dataclasses
import difflib
from collections.abc import Mapping
from types import MappingProxyType
from typing import Any

from py_trees.behaviour import Behaviour

from mission.behaviours.dock import VisualServoDock
from mission.behaviours.drive_to_pose import DriveToPose
from mission.behaviours.explore import Explore
from mission.behaviours.follow import FollowTarget
from mission.behaviours.go_to_pose import GoToPose
from mission.behaviours.line_of_sight import IsLineOfSightBlocked
from mission.behaviours.lost import HoldLastGoal
from mission.behaviours.mission_state import STATES, SetMissionState
from mission.behaviours.perceive import PerceiveTargets
from mission.behaviours.ports import Port, PortsDeclared, unknown_port, wrong_type
from mission.behaviours.pursue import PursueLastSeen
from mission.behaviours.search import SearchSweep
from mission.behaviours.search_give_up import GiveUpSearch
from mission.behaviours.search_turn import RotateSearch, TurnToBearing
from mission.behaviours.search_views import CoverUnseen, SearchBelief
from mission.behaviours.staging import GoToStaging
from mission.behaviours.visibility import IsTargetVisible
from mission.behaviours.wait_for_target import WaitForTarget
from mission.core.errors import TreeError
from mission.trees.builtins import BUILTINS, RESERVED_TAGS
from mission.trees.execution import POSTCONDITIONS, PRECONDITIONS
from mission.trees.manifest import BuildContext, Builder, Check, NodeKind, NodeManifest

#: attribute names a port cannot have (BT.CPP's IsReservedAttribute: the instance name, the type and the
#: conditions)
RESERVED_PORT_NAMES = frozenset({"name", "ID", "_autoremap", *PRECONDITIONS, *POSTCONDITIONS})

#: keywords the factory itself passes to constructors (the instance name and, for decorators and
#: controls, the children), so they cannot be registration arguments
STRUCTURAL_ARGUMENTS = frozenset({"name", "child", "children"})


class BehaviourFactory:
    """XML tag → :class:`NodeManifest`: the BT.CPP built-ins, then every behaviour registered on it."""

    def __init__(self) -> None:
        self._manifests: dict[str, NodeManifest] = dict(BUILTINS)
        self._registered: dict[str, NodeManifest] = {}  # as registered, before any set_port
        self._port_values: dict[str, dict[str, Any]] = {}  # tag → port → value (set_port)
        self._enums: dict[str, int] = {}

    def register_enum(self, name: str, value: int) -> None:
        """A name scripts may use for the integer `value` (BT.CPP's registerScriptingEnum)."""
        if not (name.isidentifier() and isinstance(value, int)):
            raise ValueError(f"scripting enum {name!r}={value!r}: expected an identifier and an int")
        if self._enums.get(name, value) != value:
            raise ValueError(f"scripting enum {name} is already {self._enums[name]}")
        self._enums[name] = value

    @property
    def enums(self) -> dict[str, int]:
        """The scripting enums (a copy)."""
        return dict(self._enums)

    def register(self, cls: type[PortsDeclared], tag: str | None = None, /, **args: Any) -> NodeManifest:
        """Make `cls` available in tree files as ``<tag>`` (default: the class name).

        `args` are passed to the constructor of every instance, with the ports written in the tree file
        (an argument the constructor refuses is a TreeError at the node when the tree is loaded). A tag
        already taken (by a built-in or an earlier registration) or reserved by the file format is a
        ValueError, as is an argument that is one of the class's ports (those come from the tree file).
        """
        if not (isinstance(cls, type) and issubclass(cls, PortsDeclared) and issubclass(cls, Behaviour)):
            raise TypeError(f"{cls!r}: expected a py_trees Behaviour class declaring its ports (PortsDeclared)")
        tag = cls.__name__ if tag is None else tag
        if tag in RESERVED_TAGS:
            raise ValueError(f"tag {tag!r} is part of the tree file format; register {cls.__name__} under another tag")
        if tag in self._manifests:
            taken = "a BT.CPP built-in" if tag in BUILTINS else "already registered"
            raise ValueError(f"tag {tag!r} is {taken}; each tag names one node type")
        reserved = sorted(RESERVED_PORT_NAMES & set(cls.PORTS))
        if reserved:  # the tree file's own attributes: a port of that name could never be written
            raise ValueError(
                f"{tag}: port {reserved[0]!r} is reserved by the tree file format; expected another name "
                f"(reserved: {', '.join(sorted(RESERVED_PORT_NAMES))})"
            )
        for arg in args:
            if arg in cls.PORTS:
                raise ValueError(f"{tag}: {arg} cannot be a registration argument: it is a port, set in tree files")
            if arg in STRUCTURAL_ARGUMENTS:
                raise ValueError(f"{tag}: {arg} cannot be a registration argument: the loader passes it")
        manifest = NodeManifest(
            tag,
            cls.NODE_TYPE,
            _summary(cls),
            _builder(cls, cls.NODE_TYPE, args),
            cls.PORTS,
            _params_check(cls),
            deprecated=bool(getattr(cls, "DEPRECATED", False)),
        )
        self._manifests[tag] = self._registered[tag] = manifest
        return manifest

    def model(self, tag: str, kind: NodeKind, ports: Mapping[str, Port], doc: str) -> NodeManifest:
        """Know ``<tag>`` from a model only (a TreeNodesModel, trees/node_models.py): checked and drawn like any
        node, never built — building it is a TreeError naming it. For drawing another team's trees."""
        if tag in self._manifests or tag in RESERVED_TAGS:
            raise ValueError(f"tag {tag!r} is already known; a model describes a node type nothing registers")

        def refuse(name: str, children: list[Behaviour], values: dict[str, Any], ctx: BuildContext) -> Behaviour:
            raise TreeError(f"{tag} ({name}) is {doc}; register a behaviour for it to run this tree")

        manifest = NodeManifest(tag, kind, doc, refuse, dict(ports), untyped=frozenset(ports), runnable=False)
        self._manifests[tag] = manifest
        return manifest

    def set_port(self, tag: str, port: str, value: Any) -> None:
        """Every ``<tag>`` node of the trees this factory builds gets ``port=value``, whatever the file writes.

        A run's parameter (``mission run --set SearchSweep.angular_speed=0.8``, a sweep's grid): the tree
        file stays as written, and the node is checked and built with this value, as if the port's default
        were `value` and the file wrote nothing for it. Only this factory is changed. A tag that names no
        registered behaviour, an unknown port or a value of the wrong type is a ValueError that says what
        was expected; a value out of the port's range is the tree's error at the node when it is loaded.
        """
        base = self._registered.get(tag)
        if base is None:
            hint = difflib.get_close_matches(tag, list(self._registered), n=1)
            raise ValueError(
                f"no behaviour {tag!r}{f' (did you mean {hint[0]}?)' if hint else ''}; "
                f"registered: {', '.join(sorted(self._registered)) or 'none'}"
            )
        declared = base.ports.get(port)
        if declared is None:
            raise ValueError(unknown_port(port, tag, base.ports))
        if not declared.accepts(value):
            raise ValueError(wrong_type(port, declared.type.__name__, value))
        values = {**self._port_values.get(tag, {}), port: declared.type(value)}
        self._port_values[tag] = values
        self._manifests[tag] = _with_port_values(base, values)

    def port_values(self) -> dict[str, dict[str, Any]]:
        """What :meth:`set_port` changed: tag → port → value (a copy)."""
        return {tag: dict(values) for tag, values in self._port_values.items()}

    def manifest(self, tag: str) -> NodeManifest | None:
        """The node type a tree file means by ``<tag>`` (None when nothing is registered under it)."""
        return self._manifests.get(tag)

    def builtins(self) -> list[NodeManifest]:
        """The BT.CPP built-ins, in the order their documentation lists them."""
        return [m for tag, m in self._manifests.items() if tag in BUILTINS]

    def behaviours(self, *, deprecated: bool = False) -> list[NodeManifest]:
        """The registered behaviours, sorted by tag (as Groot2 and the docs list them); the deprecated ones
        (which still load and run) only when asked for."""
        return sorted(
            (m for tag, m in self._manifests.items() if tag not in BUILTINS and (deprecated or not m.deprecated)),
            key=lambda m: m.tag,
        )


def shipped_factory() -> BehaviourFactory:
    """A factory with every shipped behaviour registered: the one list of the tags the shipped trees use.

    PerceiveTargets is registered so trees written before perception became a stage still load (it is a
    no-op); a user's own behaviours are registered on the returned factory before the tree is loaded.
    """
    factory = BehaviourFactory()
    for cls in (
        PerceiveTargets,
        IsTargetVisible,
        IsLineOfSightBlocked,
        FollowTarget,
        HoldLastGoal,
        PursueLastSeen,
        TurnToBearing,
        SearchBelief,
        CoverUnseen,
        GiveUpSearch,
        SearchSweep,
        RotateSearch,
        Explore,
        GoToStaging,
        GoToPose,
        DriveToPose,
        WaitForTarget,
        VisualServoDock,
        SetMissionState,
    ):
        factory.register(cls)
    for value, state in enumerate(STATES):  # EXPLORE = 0 … FAILED = 6
        factory.register_enum(state, value)
    return factory


def _summary(cls: type) -> str:
    """The first paragraph of the class docstring, on one line: what the node does."""
    return " ".join((cls.__doc__ or "").strip().split("\n\n")[0].split())


def _builder(cls: type, kind: NodeKind, args: dict[str, Any]) -> Builder:
    def build(name: str, children: list[Behaviour], ports: dict[str, Any], _context: BuildContext) -> Behaviour:
        structure: dict[str, Any] = {}
        if kind == "Decorator":
            structure["child"] = children[0]
        elif kind == "Control":
            structure["children"] = children
        return cls(name=name, **ports, **args, **structure)  # type: ignore[no-any-return]

    return build


def _with_port_values(base: NodeManifest, values: dict[str, Any]) -> NodeManifest:
    """`base` with `values` as its ports' defaults, and imposed on what a tree file writes when the loader
    checks and builds a node (the loader itself is unchanged: it reads the manifest it is given)."""
    ports = MappingProxyType(
        {name: dataclasses.replace(p, default=values[name]) if name in values else p for name, p in base.ports.items()}
    )
    check = base.check

    def build(name: str, children: list[Behaviour], written: dict[str, Any], context: BuildContext) -> Behaviour:
        return base.build(name, children, {**written, **values}, context)

    def checked(written: dict[str, Any], n: int) -> str | None:
        return None if check is None else check({**written, **values}, n)

    return dataclasses.replace(base, ports=ports, build=build, check=checked)


def _params_check(cls: type[PortsDeclared]) -> Check:
    """The declaration's own checks (``Params.__post_init__``), run by the loader before anything is built."""

    def check(values: dict[str, Any], _n: int) -> str | None:
        try:
            cls.bind_params(values)
        except (TypeError, ValueError) as exc:
            return str(exc)
        return None

    return check
