"""One registry maps XML tags to behaviour classes (BehaviorTree.CPP's factory).

Leaf behaviours register themselves with :func:`register`; the tree loader adds the built-in
control nodes (Sequence, Fallback, …) on its side.
"""

from __future__ import annotations

from typing import TypeVar

T = TypeVar("T", bound=type)

REGISTRY: dict[str, type] = {}


def register(cls: T) -> T:
    """Class decorator: make `cls` available in tree files under its class name."""
    tag = cls.__name__
    if tag in REGISTRY and REGISTRY[tag] is not cls:
        raise ValueError(f"behaviour tag {tag!r} registered twice ({REGISTRY[tag]} and {cls})")
    REGISTRY[tag] = cls
    return cls


def all_behaviours() -> dict[str, type]:
    """Every registered leaf, importing the modules that define them."""
    import mission.behaviours.catalogue  # noqa: F401  (imports every behaviour module so they register)

    return dict(REGISTRY)
