"""mkdocs hooks (mkdocs.yml ``hooks:``): the site's benchmark results page is BENCHMARKS.md itself.

BENCHMARKS.md is generated at the repository root (``python -m bench.report``) with its pictures under
docs/bench/. The page docs/bench/results.md holds one marker; at build time it is replaced by that file, with
the pictures' paths made relative to the page, so the figures are written once and the site shows the same.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
MARKER = "<!-- include: BENCHMARKS.md -->"


def on_page_markdown(markdown: str, page: Any, **_: Any) -> str:
    if MARKER not in markdown:
        return markdown
    report = (ROOT / "BENCHMARKS.md").read_text(encoding="utf-8")
    report = report.split("\n", 1)[1]  # the page has its own title
    return markdown.replace(MARKER, report.replace("](docs/bench/", "]("))
