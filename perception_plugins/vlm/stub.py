"""`client: stub` — the colour-and-shape stand-in for a vision-language model, one VlmClient among others.

It answers the VLM's question (client.py: "where is the <label>?", points ``[y, x]`` in 0–1000 with a
confidence) for labels that name a colour and, optionally, a shape ("red box", "blue ball", "green
cube", "yellow bottle"): HSV colour segmentation, then a shape score per blob. It works on any BGR
image — a sim render or a photo — and imitates a remote model's manners: latency, occasional misses and
pixel noise, all seeded so runs repeat. So the whole VLM pipeline runs, and is tested, without a network.
"""

from __future__ import annotations

import re
import threading
from dataclasses import dataclass
from typing import TYPE_CHECKING

import cv2
import numpy as np

from mission.core.errors import ConfigError
from mission.perception_plugins.vlm.client import VlmPoint

if TYPE_CHECKING:
    from mission.perception_plugins.vlm.client import RequestBudget
    from mission.perception_plugins.vlm.source import VlmParams

# HSV ranges in OpenCV units (H 0–179, S and V 0–255): (h_lo, h_hi, s_lo, s_hi, v_lo, v_hi); several per colour.
_SAT = 90  # "clearly coloured": below this saturation a pixel is white/grey/black
_VAL = 50
COLOUR_RANGES: dict[str, tuple[tuple[int, int, int, int, int, int], ...]] = {
    "red": ((0, 9, _SAT, 255, _VAL, 255), (170, 179, _SAT, 255, _VAL, 255)),
    "orange": ((10, 21, _SAT, 255, _VAL, 255),),
    "yellow": ((22, 34, _SAT, 255, _VAL, 255),),
    "green": ((35, 85, _SAT, 255, _VAL, 255),),
    "cyan": ((86, 99, _SAT, 255, _VAL, 255),),
    "blue": ((100, 130, _SAT, 255, _VAL, 255),),
    "purple": ((131, 150, _SAT, 255, _VAL, 255),),
    "magenta": ((151, 169, _SAT, 255, _VAL, 255),),
    "white": ((0, 179, 0, 40, 200, 255),),
    "grey": ((0, 179, 0, 40, 60, 199),),
    "black": ((0, 179, 0, 255, 0, 45),),
}
COLOUR_SYNONYMS = {"violet": "purple", "pink": "magenta", "gray": "grey", "teal": "cyan", "turquoise": "cyan"}

# Shape words → the silhouette the stub scores for. Any other noun (bottle, bag, …) means "any shape".
SHAPE_WORDS = {
    **dict.fromkeys(("box", "boxes", "cube", "cubes", "block", "crate", "brick", "package", "carton", "cuboid"), "box"),
    **dict.fromkeys(("ball", "balls", "sphere", "orb", "globe", "disc", "disk", "circle"), "round"),
}


@dataclass(frozen=True)
class ObjectQuery:
    """What a label asks for, as the stub understands it."""

    colour: str | None
    shape: str | None  # "box", "round" or None (any shape)


def parse_label(label: str) -> ObjectQuery:
    """Colour and shape words of a free-text label ("big red cube" → red, box); unknown words are ignored."""
    colour = shape = None
    for word in re.findall(r"[a-z]+", label.lower()):
        word = COLOUR_SYNONYMS.get(word, word)
        if colour is None and word in COLOUR_RANGES:
            colour = word
        if shape is None and word in SHAPE_WORDS:
            shape = SHAPE_WORDS[word]
    return ObjectQuery(colour, shape)


def known_colours() -> list[str]:
    """Every colour word a label may use (synonyms included), for error messages."""
    return sorted(set(COLOUR_RANGES) | set(COLOUR_SYNONYMS))


@dataclass(frozen=True)
class Blob:
    """One candidate region: its centroid (px), area (px², holes filled) and how well it fits the shape."""

    u: float
    v: float
    area: float
    shape_score: float


def colour_mask(image_bgr: np.ndarray, colour: str) -> np.ndarray:
    """Binary mask (uint8 0/255) of the pixels of a named colour, with specks removed and gaps closed."""
    hsv = cv2.cvtColor(image_bgr, cv2.COLOR_BGR2HSV)
    mask = np.zeros(hsv.shape[:2], np.uint8)
    for h0, h1, s0, s1, v0, v1 in COLOUR_RANGES[colour]:
        mask |= cv2.inRange(hsv, (h0, s0, v0), (h1, s1, v1))
    kernel = np.ones((3, 3), np.uint8)
    mask = cv2.morphologyEx(mask, cv2.MORPH_OPEN, kernel)
    return cv2.morphologyEx(mask, cv2.MORPH_CLOSE, kernel, iterations=2)


def shape_score(contour: np.ndarray, shape: str | None) -> float:
    """0..1: how much a silhouette looks like the asked shape.

    A box seen from anywhere is a convex polygon of 4–6 corners (one face, or two or three faces);
    a ball is a disc (many polygon corners, fills its enclosing circle). With no shape asked, a compact
    convex blob scores higher than a ragged one (solidity).
    """
    area = cv2.contourArea(contour)
    hull_area = cv2.contourArea(cv2.convexHull(contour))
    solidity = area / hull_area if hull_area > 0 else 0.0
    if shape is None:
        return float(np.clip(solidity, 0.0, 1.0))
    perimeter = cv2.arcLength(contour, True)
    corners = len(cv2.approxPolyDP(contour, 0.03 * perimeter, True))
    (_, _), radius = cv2.minEnclosingCircle(contour)
    disc_fill = area / (np.pi * radius * radius) if radius > 0 else 0.0
    if shape == "box":
        corner_fit = 1.0 if 4 <= corners <= 6 else 0.5 if corners <= 8 else 0.2
        return float(np.clip(solidity * corner_fit, 0.0, 1.0))
    # round
    corner_fit = 1.0 if corners >= 7 else 0.4
    return float(np.clip(min(solidity, disc_fill / 0.85) * corner_fit, 0.0, 1.0))


def find_blobs(image_bgr: np.ndarray, query: ObjectQuery, min_area_px: float) -> list[Blob]:
    """Every region of the query's colour at least `min_area_px` large, best match first.

    Holes are filled (the outer contour's area and centroid are used), so a marker printed on a red box
    does not split the box or move its centre.
    """
    if query.colour is None or image_bgr.ndim != 3 or image_bgr.shape[2] != 3:
        return []
    mask = colour_mask(image_bgr, query.colour)
    contours, _ = cv2.findContours(mask, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
    blobs = []
    for c in contours:
        m = cv2.moments(c)
        if m["m00"] < min_area_px:
            continue
        blobs.append(Blob(m["m10"] / m["m00"], m["m01"] / m["m00"], m["m00"], shape_score(c, query.shape)))
    # Prefer the right shape, then the bigger region (nearer or larger object).
    blobs.sort(key=lambda b: (round(b.shape_score, 1), b.area), reverse=True)
    return blobs


class ColourShapeClient:
    """The shipped stand-in for a VLM: finds "<colour> [shape]" by HSV segmentation and shape.

    Behaves like a remote model: each call waits `latency_s` (interrupted by :meth:`close`), returns no
    point with probability `miss_rate`, and adds Gaussian noise of `pixel_noise` px to the point.
    Calls are expected one at a time (the source has one worker), so the seeded generator stays
    reproducible.
    """

    def __init__(
        self,
        *,
        latency_s: float = 0.0,
        miss_rate: float = 0.0,
        pixel_noise: float = 0.0,
        seed: int = 0,
        min_area_px: float = 40.0,
    ) -> None:
        self.latency_s = latency_s
        self.miss_rate = miss_rate
        self.pixel_noise = pixel_noise
        self.min_area_px = min_area_px
        self._rng = np.random.default_rng(seed)
        self._closed = threading.Event()
        self.calls = 0

    def locate(self, image: np.ndarray, label: str) -> list[VlmPoint]:
        """Points for the object named by `label` (best first); [] when it is not seen or "missed"."""
        self.calls += 1
        if self.latency_s > 0 and self._closed.wait(self.latency_s):
            return []  # closed while "waiting for the server"
        miss = self._rng.random() < self.miss_rate
        noise = self._rng.normal(0.0, self.pixel_noise, size=2) if self.pixel_noise > 0 else np.zeros(2)
        if miss:
            return []
        blobs = find_blobs(image, parse_label(label), self.min_area_px)
        if not blobs:
            return []
        h, w = image.shape[:2]
        out = []
        for i, b in enumerate(blobs[:5]):
            u = float(np.clip(b.u + (noise[0] if i == 0 else 0.0), 0, w - 1))
            v = float(np.clip(b.v + (noise[1] if i == 0 else 0.0), 0, h - 1))
            confidence = 0.5 + 0.45 * b.shape_score  # a plausible blob of the right colour is worth ≥ 0.5
            out.append(VlmPoint(y=round(v / h * 1000), x=round(u / w * 1000), confidence=round(confidence, 3)))
        return out

    def close(self) -> None:
        self._closed.set()


def stub_client(params: VlmParams, budget: RequestBudget | None = None) -> ColourShapeClient:
    """A local stand-in for a VLM: finds '<colour> [shape]' by colour and shape, offline, no quota.

    The ``client: stub`` entry point, built from the VLM source's params; it never retries, so it has no use
    for the request budget.

    A label without a colour word is a config error now rather than a stub that never finds anything.
    With ``clock: frame`` the stub answers at once: the source holds the answer for ``latency_s`` of frame
    time instead, so a seeded simulation repeats whatever the machine's speed."""
    if parse_label(params.label).colour is None:
        raise ConfigError(
            f"the stub client finds objects by colour: name one of {', '.join(known_colours())} "
            f"in the label, got {params.label!r}",
            key="label",
        )
    return ColourShapeClient(
        latency_s=params.latency_s if params.clock == "wall" else 0.0,
        miss_rate=params.miss_rate,
        pixel_noise=params.pixel_noise,
        seed=params.seed,
        min_area_px=params.min_blob_area_px,
    )
