"""Blackboard entries as JSON values, the way BT.CPP's ``ExportBlackboardToJSON`` gives them to Groot2.

Numbers, strings, booleans and lists of them are themselves; a dataclass (a track, a pose, a goal)
is an object of its fields with ``"__type"`` naming the class, as BT.CPP's JSON converters write
custom types; an enum is its name. Large arrays (a camera image) are summarised (``"ndarray
480×640×3 uint8"``), never sent: the monitor must stay cheap while the robot runs.
"""

from __future__ import annotations

import dataclasses
import enum
import math
from collections.abc import Mapping
from typing import Any

import py_trees

MAX_ARRAY = 16  # an array with more elements than this is summarised
MAX_DEPTH = 6
MAX_TEXT = 500


def json_value(value: Any, depth: int = 0) -> Any:
    """`value` as plain JSON data (dict, list, str, int, float, bool, None)."""
    if value is None or isinstance(value, bool | int | str):
        return value[:MAX_TEXT] if isinstance(value, str) else value
    if isinstance(value, float):
        return value if math.isfinite(value) else str(value)
    if isinstance(value, enum.Enum):
        return value.name
    if depth >= MAX_DEPTH:
        return _text(value)
    shape = getattr(value, "shape", None)
    if shape is not None and hasattr(value, "tolist"):  # numpy arrays and scalars
        size = int(getattr(value, "size", 0))
        if size > MAX_ARRAY:
            return f"ndarray {'×'.join(str(s) for s in shape)} {getattr(value, 'dtype', '')}".strip()
        return json_value(value.tolist(), depth + 1)
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        out: dict[str, Any] = {"__type": type(value).__name__}
        for f in dataclasses.fields(value):
            out[f.name] = json_value(getattr(value, f.name, None), depth + 1)
        return out
    if isinstance(value, Mapping):
        return {str(k): json_value(v, depth + 1) for k, v in list(value.items())}
    if isinstance(value, list | tuple | set | frozenset):
        items = list(value)
        if len(items) > MAX_ARRAY * 4:
            return f"{type(value).__name__} of {len(items)}"
        return [json_value(v, depth + 1) for v in items]
    return _text(value)


def _text(value: Any) -> str:
    text = str(value)
    return text if len(text) <= MAX_TEXT else text[: MAX_TEXT - 1] + "…"


def blackboard_entries() -> dict[str, Any]:
    """Every entry of the py_trees blackboard (the one store the mission's keys live in), as JSON values.

    Called from the monitor's thread while the tree may be ticking: the store is copied first, and an
    entry whose value changes shape while it is read is sent as its text."""
    storage = dict(py_trees.blackboard.Blackboard.storage)
    out: dict[str, Any] = {}
    for key in sorted(storage):
        try:
            out[key] = json_value(storage[key])
        except RuntimeError:  # "dictionary changed size during iteration": written by the tick meanwhile
            out[key] = _text(storage[key])
    return out
