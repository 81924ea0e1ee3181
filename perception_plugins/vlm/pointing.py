"""Reading a Gemini-style answer to the pointing question (families.py GEMINI_PROMPT): text in, points out.
The other families' readers (families.py) share its JSON finding and :func:`make_point`.

Asked for ``[{"point": [y, x], "label": …}]`` with y and x in 0–1000 (or ``box_2d`` [ymin, xmin, ymax,
xmax]: the point is its centre), models answer in many wrappings:
the JSON in a code fence, prose before and after it, an object holding the list (``{"points": […]}``),
one object instead of a list, numbers as strings, a point a little past the edge, an answer cut off at
the token limit. :func:`read_points` takes the points out of all of these and says what it set aside, so
the source can tell "the model saw nothing" (``[]``) from "the model said something we could not read".

A point a little outside 0–1000 (within :data:`EDGE_SLACK`) is put on the edge; one farther out, or not
a finite number, is not in the image and is dropped — as are items without a point at all.
"""

from __future__ import annotations

import json
import math
import re
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

from mission.perception_plugins.vlm.client import VlmPoint

EDGE_SLACK = 50.0  # normalised units (of 1000): a point this far past the edge is clipped onto it
MAX_TEXT = 100_000  # characters of an answer that are read (a runaway answer is cut, not scanned forever)
_FENCE = re.compile(r"```[ \t]*[\w+-]*[ \t]*\n?(.*?)(?:```|\Z)", re.S)
NUMBER = r"-?\d+(?:\.\d+)?(?:[eE][-+]?\d+)?"
# a "point": [y, x] pair anywhere in the text: what can still be read of JSON that is not JSON (cut off
# mid-way, or written with Python's single quotes)
_POINT_PAIR = re.compile(r'["\']point["\']\s*:\s*\[\s*"?(' + NUMBER + r')"?\s*,\s*"?(' + NUMBER + r')"?\s*\]')
_LIST_KEYS = ("points", "objects", "detections", "items", "results", "answer", "answers", "predictions")
_CONFIDENCE_KEYS = ("confidence", "score", "probability", "conf")


def prompt_for(template: str, label: str) -> str:
    """The prompt with the target's label in it (``{label}``; other braces are left as written, so a
    prompt may show the JSON it wants)."""
    return template.replace("{label}", label)


@dataclass(frozen=True)
class ReadAnswer:
    """What one answer held: its points (best first, as the model ordered them), whether any JSON was
    found at all (False: prose only), and how many items were set aside as unusable."""

    points: list[VlmPoint]
    found_json: bool
    dropped: int = 0
    salvaged: bool = False  # not valid JSON (cut off, single quotes): the points were read from its "point" pairs
    hint: str = ""  # the answer looks like another family's convention: which, and what to set (families.py)

    @property
    def note(self) -> str:
        """One line for logs and status: what the answer was."""
        if not self.found_json:
            return "no JSON in the answer"
        parts = [f"{len(self.points)} point(s)"]
        if self.dropped:
            parts.append(f"{self.dropped} unusable item(s) dropped")
        if self.salvaged:
            parts.append("read from broken JSON")
        if self.hint:
            parts.append(self.hint)
        return ", ".join(parts)


def read_points(text: str, *, default_confidence: float) -> ReadAnswer:
    """The points in a model's answer `text`; a point without a stated confidence gets `default_confidence`."""
    text = (text or "")[:MAX_TEXT]
    found = False
    dropped = 0
    for chunk in json_chunks(text):
        points: list[VlmPoint] = []
        unusable = 0
        answers = 0
        for value in json_values(chunk):  # several when broken JSON leaves its complete items readable
            items = _items(value)
            if items is None:
                continue  # JSON, but not an answer (a number in the prose, an unrelated object)
            answers += 1
            got, bad = _points(items, default_confidence)
            points += got
            unusable += bad
        if answers:
            found = True
            if points or unusable == 0:
                return ReadAnswer(points, True, unusable)
            dropped = max(dropped, unusable)  # only unusable items here: the whole text may hold more
    pairs = [make_point(m.group(1), m.group(2), None, default_confidence) for m in _POINT_PAIR.finditer(text)]
    salvaged = [p for p in pairs if p is not None]
    if salvaged:
        return ReadAnswer(salvaged, True, len(pairs) - len(salvaged), salvaged=True)
    return ReadAnswer([], found, dropped)


def json_chunks(text: str) -> Iterator[str]:
    """Code-fenced blocks first (the model's own marking of its JSON), then the whole text."""
    for m in _FENCE.finditer(text):
        if m.group(1).strip():
            yield m.group(1)
    yield text


def json_values(text: str) -> Iterator[Any]:
    """Every JSON array or object in `text`, left to right, not descending into one already read."""
    decoder = json.JSONDecoder()
    i = 0
    n = len(text)
    while i < n:
        j = min((k for k in (text.find("[", i), text.find("{", i)) if k >= 0), default=-1)
        if j < 0:
            return
        try:
            value, end = decoder.raw_decode(text, j)
        except ValueError:
            i = j + 1
            continue
        yield value
        i = end


def _items(value: Any) -> list[Any] | None:
    """The answer's items if `value` looks like an answer (None if it does not)."""
    if isinstance(value, list):
        if len(value) == 2 and all(_is_number(v) for v in value):
            return [value]  # a bare [y, x]
        if all(isinstance(v, dict | list) for v in value):
            return value
        return None
    if isinstance(value, dict):
        if any(k in value for k in ("point", "box_2d", "y")):
            return [value]
        for key in _LIST_KEYS:
            inner = value.get(key)
            if isinstance(inner, list):
                return _items(inner) or ([] if not inner else None)
    return None


def _points(items: list[Any], default_confidence: float) -> tuple[list[VlmPoint], int]:
    out: list[VlmPoint] = []
    for item in items:
        point: VlmPoint | None = None
        if isinstance(item, list) and len(item) == 2:
            point = make_point(item[0], item[1], None, default_confidence)
        elif isinstance(item, dict):
            pair = item.get("point", item.get("point_yx"))
            conf = next((item[k] for k in _CONFIDENCE_KEYS if k in item), None)
            if isinstance(pair, str):
                pair = re.findall(NUMBER, pair)
            if isinstance(pair, list | tuple) and len(pair) == 2:
                point = make_point(pair[0], pair[1], conf, default_confidence)
            elif "y" in item and "x" in item:
                point = make_point(item["y"], item["x"], conf, default_confidence)
            box = item.get("box_2d")
            if isinstance(box, list | tuple) and len(box) == 4:  # Gemini's [ymin, xmin, ymax, xmax]
                b = [_number(v) for v in box]
                if all(v is not None for v in b):
                    ymin, xmin, ymax, xmax = b  # type: ignore[misc]
                    centre = (point.y, point.x) if point is not None else ((ymin + ymax) / 2, (xmin + xmax) / 2)
                    point = make_point(*centre, conf, default_confidence, box=(ymin, xmin, ymax, xmax))
        if point is not None:
            out.append(point)
    return out, len(items) - len(out)


def _is_number(v: Any) -> bool:
    return isinstance(v, int | float) and not isinstance(v, bool)


def _number(v: Any) -> float | None:
    if isinstance(v, bool):
        return None
    try:
        f = float(v)
    except (TypeError, ValueError):
        return None
    return f if math.isfinite(f) else None


def make_point(
    y: Any, x: Any, confidence: Any, default_confidence: float, *, box: tuple[float, float, float, float] | None = None
) -> VlmPoint | None:
    """A point from [y, x] in 0–1000 (None when not a finite number or not in the image, beyond EDGE_SLACK);
    a point a little past the edge is put on it. `box` (ymin, xmin, ymax, xmax in 0–1000) is clipped to the
    image."""
    fy, fx = _number(y), _number(x)
    if fy is None or fx is None:
        return None
    if not all(-EDGE_SLACK <= v <= 1000.0 + EDGE_SLACK for v in (fy, fx)):
        return None  # not in the image
    c = _number(confidence)
    if c is None or c < 0:
        c = default_confidence
    elif 1.0 < c <= 100.0:
        c /= 100.0  # a percentage
    if box is not None:
        box = tuple(min(max(float(b), 0.0), 1000.0) for b in box)  # type: ignore[assignment]
    return VlmPoint(y=min(max(fy, 0.0), 1000.0), x=min(max(fx, 0.0), 1000.0), confidence=min(c, 1.0), box=box)
