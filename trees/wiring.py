"""How a built node's ports reach the blackboard: constants, entries read before a tick, entries written.

The loader makes one :class:`Wiring` per node from what the tree file wrote (and the port declarations'
defaults), with every ``{key}`` already resolved to an entry of py_trees' blackboard (trees/scopes.py).
Built-in nodes read their ports through it when they tick, as BT.CPP's ``getInput`` does; a behaviour
declaring its ports (behaviours/ports.py) gets ``self.params`` re-read from it before every tick when a
port is connected to an entry, and its ``set_output`` writes through it.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from py_trees.behaviour import Behaviour

from mission.behaviours.ports import REQUIRED, BlackboardRef, Port, PortsDeclared
from mission.trees import scopes
from mission.trees.execution import PortError


@dataclass(eq=False)
class Wiring:
    """One node's ports: `constants` (converted, defaults included), `inputs` and `outputs` connected to entries."""

    ports: Mapping[str, Port]
    constants: dict[str, Any] = field(default_factory=dict)
    written: dict[str, str] = field(default_factory=dict)  # every attribute as the file wrote it
    inputs: dict[str, BlackboardRef] = field(default_factory=dict)
    outputs: dict[str, BlackboardRef] = field(default_factory=dict)

    def get(self, name: str, default: Any = REQUIRED) -> Any:
        """The port's value now (BT.CPP's getInput): the constant, or the entry converted to the port's type."""
        ref = self.inputs.get(name)
        if ref is not None:
            return self.read(name, ref)
        if name in self.constants:
            return self.constants[name]
        if default is not REQUIRED:
            return default
        raise PortError(f"port {name} is not set")

    def read(self, name: str, ref: BlackboardRef) -> Any:
        try:
            value = scopes.read(ref.path)
        except KeyError:
            raise PortError(f"port {name}: blackboard entry {ref} was never written") from None
        declared = self.ports.get(name)
        if declared is None:
            return value
        try:
            return declared.coerce(value)
        except ValueError as err:
            raise PortError(f"port {name}: blackboard entry {ref} holds {value!r}; expected {err}") from None

    def write(self, name: str, value: Any) -> bool:
        """Write an output port's entry; False when the tree file did not connect it."""
        ref = self.outputs.get(name)
        if ref is None:
            return False
        scopes.write(ref.path, value)
        return True

    def refresh_params(self, node: Behaviour) -> None:
        """Re-read the connected inputs of a behaviour declaring its ports, into ``node.params`` (checked)."""
        cls = type(node)
        assert issubclass(cls, PortsDeclared)
        values = {n: v for n, v in self.constants.items() if n in self.written}
        values.update({name: self.read(name, ref) for name, ref in self.inputs.items()})
        try:
            node.params = cls.bind_params(values)  # type: ignore[attr-defined]
        except (TypeError, ValueError) as err:
            raise PortError(str(err)) from None
