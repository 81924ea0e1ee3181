"""How each model family writes its answer — the fake model's side of tests/helpers/vlm_servers.py, written
from each family's published format (see tests/perception/vlm/golden/README.md), independent of the
readers under test (perception_plugins/vlm/families.py).

:func:`native_answer` writes "the target is at (u, v), a fraction of the image's width and height" the
way a model of that family would, for the image it was sent (its width and height in pixels).
"""

from __future__ import annotations

import json
import math


def qwen25_processor_size(width: int, height: int) -> tuple[int, int]:
    """(width, height) of the image Qwen2.5-VL's processor makes of a sent one (its default pixel budget):
    sides rounded to multiples of 28, then scaled into 3136 … 12845056 pixels."""
    f, lo, hi = 28, 3136, 12845056
    h, w = max(f, round(height / f) * f), max(f, round(width / f) * f)
    if h * w > hi:
        b = math.sqrt(height * width / hi)
        h, w = max(f, math.floor(height / b / f) * f), max(f, math.floor(width / b / f) * f)
    elif h * w < lo:
        b = math.sqrt(lo / (height * width))
        h, w = math.ceil(height * b / f) * f, math.ceil(width * b / f) * f
    return w, h


def native_answer(
    family: str, u: float | None, v: float | None, width: int, height: int, label: str = "red box"
) -> str:
    """The answer of a `family` model seeing the target at fractions (u, v) of the sent image (None: not
    there), in that family's own format, order and scale."""
    if u is None or v is None:
        return "There are none." if family.startswith("molmo") else "[]"
    if family in ("gemini-er", "generic"):
        return json.dumps([{"point": [round(v * 1000), round(u * 1000)], "label": label}])
    if family == "qwen2.5-vl":
        rw, rh = qwen25_processor_size(width, height)
        item = {"point_2d": [round(u * rw), round(v * rh)], "label": label}
        return "```json\n" + json.dumps([item], indent="\t") + "\n```"
    if family == "qwen3-vl":
        return "```json\n" + json.dumps([{"point_2d": [round(u * 1000), round(v * 1000)], "label": label}]) + "\n```"
    if family == "molmo":
        return f' <point x="{u * 100:.1f}" y="{v * 100:.1f}" alt="{label}">{label}</point>'
    if family == "molmo2":
        return f'<points coords="1 1 {round(u * 1000):03d} {round(v * 1000):03d}">{label}</points>'
    raise ValueError(family)
