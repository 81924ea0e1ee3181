"""ROS 2 type hashes (REP 2011, ``RIHS01_…``) computed from interface definition text, independently of rosidl.

Two ROS programs talk only if their type hashes agree, so "our nav2_msgs is Jazzy's" means: the hash of
every type equals the one a real Jazzy install computes. The hash covers the structure only — field names,
field types, array kinds and bounds, nested type names, recursively — never comments, constants or
default values. This module parses ``.msg`` text, builds that structure (``type_description``: the type
plus every type it references, sorted by name) and hashes its JSON the way REP 2011 specifies (sha256 of
``json.dumps`` with ``", "`` / ``": "`` separators and the keys in declaration order).

The tests check it first on messages of the ros-jazzy-* wheels against the hashes the ROS build farm put
in their ``share/<pkg>/msg/<Name>.json``; then it is an independent witness for the types we build.
"""

from __future__ import annotations

import hashlib
import json
import re
from collections.abc import Callable
from dataclasses import dataclass

# type_description_interfaces/msg/FieldType ids
_PRIMITIVES = {
    "int8": 2, "uint8": 3, "int16": 4, "uint16": 5, "int32": 6, "uint32": 7, "int64": 8, "uint64": 9,
    "float32": 10, "float64": 11, "char": 13, "wchar": 14, "bool": 15, "byte": 16, "string": 17, "wstring": 18,
}  # fmt: skip
NESTED = 1
BOUNDED_STRING, BOUNDED_WSTRING = 21, 22
ARRAY, BOUNDED_SEQUENCE, UNBOUNDED_SEQUENCE = 48, 96, 144

_FIELD = re.compile(
    r"^(?P<type>[A-Za-z0-9_/]+(?:<=\d+)?)(?P<array>\[(?:<=)?\d*\])?\s+(?P<name>[a-z][a-z0-9_]*)(?:\s+.*)?$"
)


@dataclass(frozen=True)
class Field:
    name: str
    type_id: int
    capacity: int = 0
    string_capacity: int = 0
    nested_type_name: str = ""

    def to_json(self) -> dict:
        return {
            "name": self.name,
            "type": {
                "type_id": self.type_id,
                "capacity": self.capacity,
                "string_capacity": self.string_capacity,
                "nested_type_name": self.nested_type_name,
            },
        }


def parse_fields(text: str, package: str) -> list[Field]:
    """The fields of a .msg (or one section of a .action): constants and comments are not part of a type."""
    fields = []
    for raw in text.splitlines():
        line = raw.split("#", 1)[0].strip()
        if not line:
            continue
        m = _FIELD.match(line)
        if m is None or "=" in line.split()[1]:  # `uint16 NONE=0`: a constant
            continue
        base, array, name = m["type"], m["array"], m["name"]
        string_capacity = 0
        if "<=" in base:
            base, bound = base.split("<=")
            string_capacity = int(bound)
        nested = ""
        if base in _PRIMITIVES:
            type_id = _PRIMITIVES[base]
            if string_capacity:
                type_id = BOUNDED_STRING if base == "string" else BOUNDED_WSTRING
        else:
            pkg, _, msg = base.rpartition("/")
            nested, type_id = f"{pkg or package}/msg/{msg}", NESTED
        capacity = 0
        if array:
            inner = array[1:-1]
            if inner == "":
                type_id += UNBOUNDED_SEQUENCE
            elif inner.startswith("<="):
                type_id, capacity = type_id + BOUNDED_SEQUENCE, int(inner[2:])
            else:
                type_id, capacity = type_id + ARRAY, int(inner)
        fields.append(Field(name, type_id, capacity, string_capacity, nested))
    # rosidl gives a structure with no field (UndockRobot's feedback) one placeholder member, and hashes it
    return fields or [Field("structure_needs_at_least_one_member", _PRIMITIVES["uint8"])]


def type_hash(type_name: str, definitions: Callable[[str], list[Field]]) -> str:
    """RIHS01 hash of `type_name`; `definitions(name)` gives the fields of any type it (indirectly) uses."""
    own = definitions(type_name)
    referenced: dict[str, list[Field]] = {}
    todo = [f.nested_type_name for f in own if f.nested_type_name]
    while todo:
        name = todo.pop()
        if name in referenced:
            continue
        referenced[name] = definitions(name)
        todo += [f.nested_type_name for f in referenced[name] if f.nested_type_name]
    desc = {
        "type_description": {"type_name": type_name, "fields": [f.to_json() for f in own]},
        "referenced_type_descriptions": [
            {"type_name": name, "fields": [f.to_json() for f in referenced[name]]} for name in sorted(referenced)
        ],
    }
    text = json.dumps(desc, ensure_ascii=True, allow_nan=False, separators=(", ", ": "), sort_keys=False)
    return "RIHS01_" + hashlib.sha256(text.encode("utf-8")).hexdigest()
