"""Building ROS messages for two worlds: live rclpy messages and ``rosbags`` messages for bag files.

The conversions in :mod:`mission.ros.conversions` read messages by field name only, which both kinds
share. To *build* a message they ask a factory, so the same code fills a message for a publisher and
for a bag writer. Numeric arrays are always given as numpy arrays; each factory stores them the way
its message classes want (rclpy: ``array.array`` for sequences, numpy for fixed-size arrays; rosbags:
numpy everywhere).
"""

from __future__ import annotations

import array
import importlib
import math
from typing import Any, Protocol

import numpy as np

_TYPECODES = {
    np.dtype(np.uint8): "B", np.dtype(np.int8): "b", np.dtype(np.uint16): "H", np.dtype(np.int16): "h",
    np.dtype(np.uint32): "I", np.dtype(np.int32): "i", np.dtype(np.uint64): "Q", np.dtype(np.int64): "q",
    np.dtype(np.float32): "f", np.dtype(np.float64): "d",
}  # fmt: skip


class MessageFactory(Protocol):
    """Makes a message of ROS type `msgtype` ("pkg/msg/Name") from field values."""

    def new(self, msgtype: str, **fields: Any) -> Any: ...


class RclpyMessages:
    """Factory for rclpy message classes (imported lazily from their ``<pkg>.msg`` module)."""

    def __init__(self) -> None:
        self._classes: dict[str, type] = {}

    def cls(self, msgtype: str) -> type:
        c = self._classes.get(msgtype)
        if c is None:
            pkg, _, name = msgtype.split("/")
            c = getattr(importlib.import_module(f"{pkg}.msg"), name)
            self._classes[msgtype] = c
        return c

    def new(self, msgtype: str, **fields: Any) -> Any:
        msg = self.cls(msgtype)()
        for key, value in fields.items():
            if isinstance(value, np.ndarray):
                current = getattr(msg, key)
                if isinstance(current, array.array):
                    # Unbounded sequences are array.array in rclpy: one memcpy, not a per-element check.
                    a = array.array(current.typecode)
                    a.frombytes(np.ascontiguousarray(value, dtype=np.dtype(current.typecode)).tobytes())
                    value = a
                elif isinstance(current, np.ndarray):
                    value = np.ascontiguousarray(value, dtype=current.dtype).reshape(current.shape)
                else:
                    value = value.tolist()
            setattr(msg, key, value)
        return msg


class BagMessages:
    """Factory for ``rosbags`` message dataclasses of a typestore (every field must be given)."""

    def __init__(self, typestore: Any) -> None:
        self.typestore = typestore

    def new(self, msgtype: str, **fields: Any) -> Any:
        return self.typestore.types[msgtype](**fields)


def stamp_to_sec(stamp: Any) -> float:
    """builtin_interfaces/Time (sec, nanosec) → float seconds."""
    return float(stamp.sec) + float(stamp.nanosec) * 1e-9


def time_msg(factory: MessageFactory, t: float) -> Any:
    """Float seconds → builtin_interfaces/Time (nanoseconds rounded, never negative)."""
    ns = max(0, round(t * 1e9))
    return factory.new("builtin_interfaces/msg/Time", sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)


def header_msg(factory: MessageFactory, t: float, frame_id: str) -> Any:
    return factory.new("std_msgs/msg/Header", stamp=time_msg(factory, t), frame_id=frame_id)


def finite(*values: float) -> bool:
    return all(math.isfinite(v) for v in values)
