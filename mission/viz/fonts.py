"""Text widths in DejaVu Sans, so a layout sizes its boxes without a browser or Graphviz.

DejaVu Sans ships with matplotlib (a dependency) and is the first font the SVG asks for, so the widths
measured here are the widths drawn. When the font cannot be read, an average width keeps layouts sane.
"""

from __future__ import annotations

from functools import lru_cache

FONT_FAMILY = "'DejaVu Sans', Verdana, 'Liberation Sans', Arial, sans-serif"
MONO_FAMILY = "'DejaVu Sans Mono', 'Liberation Mono', Menlo, monospace"
_REF_SIZE = 100.0


@lru_cache(maxsize=4)
def _advances(bold: bool) -> dict[str, float] | None:
    """Advance width of each printable ASCII character at 100 px, or None when the font is unavailable."""
    try:
        from matplotlib import font_manager, ft2font

        props = font_manager.FontProperties(family="DejaVu Sans", weight="bold" if bold else "normal")
        font = ft2font.FT2Font(font_manager.findfont(props, fallback_to_default=True))
        font.set_size(_REF_SIZE, 72)
        return {chr(c): font.load_char(c).linearHoriAdvance / 65536.0 for c in range(32, 127)}
    except Exception:  # a missing or unreadable font only makes boxes a little less snug
        return None


def text_width(text: str, size: float, *, bold: bool = False, mono: bool = False) -> float:
    """Width in px of `text` drawn at `size` px."""
    if mono:
        return 0.602 * size * len(text)
    adv = _advances(bold)
    if adv is None:
        return (0.64 if bold else 0.58) * size * len(text)
    wide = adv["M"]
    return sum(adv.get(ch, wide) for ch in text) * size / _REF_SIZE


def fit(text: str, size: float, max_width: float, *, bold: bool = False, mono: bool = False) -> str:
    """`text` shortened with an ellipsis so it fits in `max_width` px."""
    if text_width(text, size, bold=bold, mono=mono) <= max_width:
        return text
    lo, hi = 0, len(text)
    while lo < hi:
        mid = (lo + hi + 1) // 2
        if text_width(text[:mid] + "…", size, bold=bold, mono=mono) <= max_width:
            lo = mid
        else:
            hi = mid - 1
    return text[:lo] + "…"
