"""Model families: how each kind of pointing model is asked, and how its answer is read.

Every family answers "where is the <label>?" in the form it was trained on, and a point read in another
family's convention lands on the wrong pixel without any error. So each family has its own prompt and its
own reader; both end in the one form the rest of the source uses, :class:`VlmPoint` (``[y, x]`` in 0–1000
of the image, best first, with the box when the model gave one).

==============  ===========================================================  ========================
family          the answer                                                   scale
==============  ===========================================================  ========================
``gemini-er``   ``[{"point": [y, x], "label"}]``, ``box_2d`` [ymin, xmin,    0–1000
                ymax, xmax] (Gemini Robotics-ER)
``qwen2.5-vl``  ``[{"bbox_2d": [x1, y1, x2, y2], "label"}]``,                pixels of the image as the
                ``point_2d`` [x, y]                                          processor resized it
``qwen3-vl``    the same keys, [x, y] order                                  0–1000
``molmo``       ``<point x="61.5" y="40.6" alt="…">label</point>``,          percent, 0–100
                ``<points x1= y1= x2= y2= …>``
``molmo2``      ``<points coords="IMG ID X Y ID X Y …">label</points>``      0–1000
                (image index, then point id, x, y per point)
``generic``     as ``gemini-er`` (the prompt says it all)                    0–1000
==============  ===========================================================  ========================

Qwen2.5-VL answers in pixels of the image its processor made: the sent image resized by
:func:`smart_resize` (both sides multiples of 28, the pixel count within ``min_pixels`` … ``max_pixels``);
the reader divides by that size, so the point holds for the image we have whatever its size.

A family not set in config is taken from the model's name when the name says it (:func:`detect_family`).
"""

from __future__ import annotations

import dataclasses
import logging
import math
import re
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Literal

from mission.perception_plugins.vlm.client import VlmPoint
from mission.perception_plugins.vlm.pointing import (
    NUMBER,
    ReadAnswer,
    json_chunks,
    json_values,
    make_point,
    read_points,
)

log = logging.getLogger(__name__)

Family = Literal["gemini-er", "qwen2.5-vl", "qwen3-vl", "molmo", "molmo2", "generic"]
FAMILIES: tuple[str, ...] = ("gemini-er", "qwen2.5-vl", "qwen3-vl", "molmo", "molmo2", "generic")

QWEN_FACTOR = 28  # Qwen2.5-VL: patch 14 × merge 2; a resized side is a multiple of this
QWEN_MIN_PIXELS = 56 * 56  # the Qwen2.5-VL processor's defaults (preprocessor_config.json)
QWEN_MAX_PIXELS = 28 * 28 * 16384
QWEN_MAX_RATIO = 200

#: Gemini Robotics-ER's documented pointing question: [y, x] normalised to 0–1000.
GEMINI_PROMPT = (
    "Point to the {label} in the image. Answer with JSON only, a list of at most 5 objects of the form "
    '[{"point": [y, x], "label": "<what it is>"}], most likely first, where [y, x] is the centre of the '
    "object with y and x normalised to 0-1000 (y down from the top edge, x right from the left edge). "
    "Answer [] if there is no {label} in the image."
)
#: Qwen's grounding question (its cookbooks' wording): boxes as JSON, [x1, y1, x2, y2].
QWEN_PROMPT = (
    "Locate the {label} in the image and output its bbox coordinates in JSON format, "
    '[{"bbox_2d": [x1, y1, x2, y2], "label": "{label}"}]. Output [] if there is no {label}.'
)
#: Molmo and Molmo2 are trained on "Point to …"; they answer with their point tags.
MOLMO_PROMPT = "Point to the {label}."

PROMPTS: dict[str, str] = {
    "gemini-er": GEMINI_PROMPT,
    "qwen2.5-vl": QWEN_PROMPT,
    "qwen3-vl": QWEN_PROMPT,
    "molmo": MOLMO_PROMPT,
    "molmo2": MOLMO_PROMPT,
    "generic": GEMINI_PROMPT,
}

# what a model's name says about its family, first match wins (molmo2 before molmo, qwen3 before …)
_NAMES: tuple[tuple[str, re.Pattern[str]], ...] = (
    ("gemini-er", re.compile(r"gemini")),  # Robotics-ER, and the Gemini models it shares its convention with
    ("qwen2.5-vl", re.compile(r"qwen2[._]?5[-_ ]?vl")),
    ("qwen3-vl", re.compile(r"qwen3[._]?\d*[-_ ]?vl")),
    ("molmo2", re.compile(r"molmo[-_ ]?2")),
    ("molmo", re.compile(r"molmo")),
)


def detect_family(model: str | None) -> str | None:
    """The family a model's name says it belongs to (``gemini-robotics-er-2-preview`` → gemini-er,
    ``Qwen/Qwen2.5-VL-7B-Instruct`` → qwen2.5-vl,
    ``qwen2.5vl:7b`` → qwen2.5-vl, ``allenai/Molmo2-8B`` → molmo2); None when the name does not say."""
    name = (model or "").lower()
    return next((family for family, pattern in _NAMES if pattern.search(name)), None)


def smart_resize(
    height: int,
    width: int,
    *,
    factor: int = QWEN_FACTOR,
    min_pixels: int = QWEN_MIN_PIXELS,
    max_pixels: int = QWEN_MAX_PIXELS,
) -> tuple[int, int]:
    """(height, width) of the image as Qwen2.5-VL's processor resizes it: each side rounded to a multiple of
    `factor`, then scaled (keeping the aspect ratio, again to multiples of `factor`) into the pixel budget."""
    if height <= 0 or width <= 0:
        raise ValueError(f"an image of {width}×{height} px has nothing to resize")
    if max(height, width) / min(height, width) > QWEN_MAX_RATIO:
        raise ValueError(f"aspect ratio of {width}×{height} px is beyond {QWEN_MAX_RATIO}")
    h = max(factor, round(height / factor) * factor)
    w = max(factor, round(width / factor) * factor)
    if h * w > max_pixels:
        beta = math.sqrt(height * width / max_pixels)
        h = max(factor, math.floor(height / beta / factor) * factor)
        w = max(factor, math.floor(width / beta / factor) * factor)
    elif h * w < min_pixels:
        beta = math.sqrt(min_pixels / (height * width))
        h = math.ceil(height * beta / factor) * factor
        w = math.ceil(width * beta / factor) * factor
    return h, w


@dataclass(frozen=True)
class AnswerReader:
    """Reads one family's answers to an image sent at `sent_size` (width, height px)."""

    family: str
    default_confidence: float
    sent_size: tuple[int, int] = (1000, 1000)
    min_pixels: int = QWEN_MIN_PIXELS
    max_pixels: int = QWEN_MAX_PIXELS

    def __call__(self, text: str) -> ReadAnswer:
        return read_family(self, text)

    def qwen_scale(self) -> tuple[float, float]:
        """(x, y) divisors that take this family's Qwen coordinates to fractions of the image."""
        if self.family == "qwen2.5-vl":
            w, h = self.sent_size
            rh, rw = smart_resize(h, w, min_pixels=self.min_pixels, max_pixels=self.max_pixels)
            return float(rw), float(rh)
        return 1000.0, 1000.0


def read_family(reader: AnswerReader, text: str) -> ReadAnswer:
    """The points in `text`, read in `reader.family`'s own convention, with a hint when the answer looks
    like another family's (ReadAnswer.hint)."""
    f = reader.family
    if f in ("gemini-er", "generic"):
        read = read_points(text, default_confidence=reader.default_confidence)
    elif f in ("qwen2.5-vl", "qwen3-vl"):
        read = _read_qwen(text, reader)
    elif f == "molmo":
        read = _read_molmo(text, reader.default_confidence)
    elif f == "molmo2":
        read = _read_molmo2(text, reader.default_confidence)
    else:
        raise ValueError(f"unknown model family {f!r}; expected one of {', '.join(FAMILIES)}")
    hint = misread_hint(f, text, read)
    return dataclasses.replace(read, hint=hint) if hint else read


_HINT_FORMS: tuple[tuple[str, re.Pattern[str], str], ...] = (
    ("molmo2", re.compile(r"<points?\b[^>]*\bcoords\s*=", re.I), 'Molmo2\'s <points coords="…">; set family molmo2'),
    ("molmo", re.compile(r"<points?\b[^>]*\bx1?\s*=", re.I), "Molmo's <point x y> in percent; set family molmo"),
    (
        "qwen",
        re.compile(r"[\"'](?:bbox_2d|point_2d)[\"']"),
        "Qwen's bbox_2d / point_2d [x, y]; set family qwen2.5-vl (pixels) or qwen3-vl (0-1000)",
    ),
    ("gemini", re.compile(r"[\"'](?:point|box_2d)[\"']\s*:"), 'Gemini\'s [{"point": [y, x]}]; set family gemini-er'),
)


def misread_hint(family: str, text: str, read: ReadAnswer) -> str:
    """Why an answer that gave no usable point (or dropped some) was probably read in the wrong convention,
    as "answers look like …; set family …" — "" when nothing suggests it."""
    if read.points and not read.dropped:
        return ""
    own = {"gemini-er": "gemini", "generic": "gemini", "qwen2.5-vl": "qwen", "qwen3-vl": "qwen"}.get(family, family)
    for name, pattern, words in _HINT_FORMS:
        if name != own and pattern.search(text or ""):
            return f"answers look like {words}"
    if family == "qwen2.5-vl" and read.dropped:
        return "answers look like 0-1000, not pixels of the resized image; set family qwen3-vl"
    if family == "qwen3-vl" and read.dropped:
        return "answers look like pixels, not 0-1000; set family qwen2.5-vl"
    if family == "molmo" and read.dropped:
        return "answers look like 0-1000, not percent; set family molmo2 or gemini-er"
    return ""


# -- Qwen ------------------------------------------------------------------------------------------
_QWEN_BOX = re.compile(r'["\']bbox_2d["\']\s*:\s*\[\s*' + r"\s*,\s*".join([f"({NUMBER})"] * 4) + r"\s*\]")
_QWEN_POINT = re.compile(r'["\']point_2d["\']\s*:\s*\[\s*(' + NUMBER + r")\s*,\s*(" + NUMBER + r")\s*\]")


def _read_qwen(text: str, reader: AnswerReader) -> ReadAnswer:
    sx, sy = reader.qwen_scale()

    def to_point(item: Any) -> VlmPoint | None:
        conf = item.get("confidence", item.get("score")) if isinstance(item, dict) else None
        box = item.get("bbox_2d") if isinstance(item, dict) else None
        point = item.get("point_2d") if isinstance(item, dict) else None
        if _numbers(box, 4):
            x1, y1, x2, y2 = (float(v) for v in box)
            return make_point(
                (y1 + y2) / 2 / sy * 1000,
                (x1 + x2) / 2 / sx * 1000,
                conf,
                reader.default_confidence,
                box=(y1 / sy * 1000, x1 / sx * 1000, y2 / sy * 1000, x2 / sx * 1000),
            )
        if _numbers(point, 2):
            x, y = (float(v) for v in point)
            return make_point(y / sy * 1000, x / sx * 1000, conf, reader.default_confidence)
        return None

    def is_item(v: Any) -> bool:
        return isinstance(v, dict) and ("bbox_2d" in v or "point_2d" in v)

    read = _read_json_items(text, is_item, to_point)
    if read is not None:
        return read
    # cut off or not JSON: what "bbox_2d" / "point_2d" arrays can still be read
    items: list[dict[str, Any]] = [{"bbox_2d": list(m.groups())} for m in _QWEN_BOX.finditer(text)]
    items += [{"point_2d": list(m.groups())} for m in _QWEN_POINT.finditer(text)]
    if items:
        got = [p for p in (to_point(i) for i in items) if p is not None]
        return ReadAnswer(got, True, len(items) - len(got), salvaged=True)
    return ReadAnswer([], False)


def _read_json_items(
    text: str, is_item: Callable[[Any], bool], to_point: Callable[[Any], VlmPoint | None]
) -> ReadAnswer | None:
    """The points of the first JSON list (or single object) of `is_item` items in `text`; None if none."""
    for chunk in json_chunks(text):
        for value in json_values(chunk):
            if isinstance(value, dict) and not is_item(value):
                inner = next((v for v in value.values() if isinstance(v, list)), None)
                value = inner if inner is not None else value
            items = [value] if is_item(value) else value if isinstance(value, list) else None
            if items is None or (items and not any(is_item(i) for i in items)):
                continue
            got = [p for p in (to_point(i) for i in items) if p is not None]
            return ReadAnswer(got, True, len(items) - len(got))
    return None


def _numbers(v: Any, n: int) -> bool:
    if not isinstance(v, list | tuple) or len(v) != n:
        return False
    try:
        return all(math.isfinite(float(x)) for x in v)
    except (TypeError, ValueError):
        return False


# -- Molmo -----------------------------------------------------------------------------------------
_TAG = re.compile(r"<(points?)\b([^>]*)>", re.I)
_ATTR = re.compile(r'(\w+)\s*=\s*"([^"]*)"')


def _read_molmo(text: str, default_confidence: float) -> ReadAnswer:
    """``<point x y>`` and ``<points x1 y1 x2 y2 …>`` in percent of the image (x right, y down)."""
    points: list[VlmPoint] = []
    seen = dropped = 0
    for m in _TAG.finditer(text):
        attrs = dict(_ATTR.findall(m.group(2)))
        if "coords" in attrs:
            continue  # Molmo2's form: not this family's
        pairs: list[tuple[str, str]] = []
        if "x" in attrs and "y" in attrs:
            pairs.append((attrs["x"], attrs["y"]))
        k = 1
        while f"x{k}" in attrs and f"y{k}" in attrs:
            pairs.append((attrs[f"x{k}"], attrs[f"y{k}"]))
            k += 1
        for x, y in pairs:
            seen += 1
            p = _scaled(y, x, 10.0, default_confidence)
            if p is None:
                dropped += 1
            else:
                points.append(p)
    return ReadAnswer(points, seen > 0, dropped)


def _read_molmo2(text: str, default_confidence: float) -> ReadAnswer:
    """``<points coords="1 1 308 305 2 752 377">``: per image (``;``-separated, its index first, maybe
    ``1:``), then point id, x, y for each point, in 0–1000."""
    points: list[VlmPoint] = []
    seen = dropped = 0
    for m in _TAG.finditer(text):
        coords = dict(_ATTR.findall(m.group(2))).get("coords")
        if coords is None:
            continue
        for group in coords.replace("\t", ";").split(";"):
            numbers = re.findall(NUMBER, group.replace(":", " "))
            if not numbers:
                continue
            body = numbers[1:]  # numbers[0] is the image's index, not a point
            if len(body) % 3:
                dropped += 1  # a group we cannot split into (id, x, y)
                body = body[: len(body) - len(body) % 3]
            for i in range(0, len(body), 3):
                seen += 1
                p = _scaled(body[i + 2], body[i + 1], 1.0, default_confidence)
                if p is None:
                    dropped += 1
                else:
                    points.append(p)
    return ReadAnswer(points, seen > 0 or dropped > 0, dropped)


def _scaled(y: str, x: str, scale: float, default_confidence: float) -> VlmPoint | None:
    try:
        fy, fx = float(y) * scale, float(x) * scale
    except ValueError:
        return None
    return make_point(fy, fx, None, default_confidence)


def resolve_family(configured: str | None, model: str | None, *, key: str, fallback: str = "generic") -> str:
    """The family a client uses: `configured` (config `key`) when set, else the one the model's name says
    (logged, so a run says how its answers were read), else `fallback` (logged as a warning: set it)."""
    if configured:
        return configured
    found = detect_family(model)
    if found is not None:
        log.info("model %r: family %s, from its name (set %s to change it)", model, found, key)
        return found
    log.warning(
        "model %r: its name does not say its family; reading answers as %s ([y, x] in 0-1000 JSON) - set %s",
        model,
        fallback,
        key,
    )
    return fallback
