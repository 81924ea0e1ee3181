"""`mission sweep --compare A B`: two sweeps side by side — did my change make the mission better?

Cells (scenario and settings) are matched by name. When the two sweeps share no cell but each has one
cell per scenario (a baseline against a tuned setting), the scenarios are matched instead, and the
table says so. Every matched cell gets both rates with their intervals, the difference, an exact test
(McNemar on the seeds both ran, Fisher's otherwise) and a one-line note on whether it is significant.
"""

from __future__ import annotations

import html
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from mission.core.files import atomic_write_text
from mission.sweep.stats import SIGNIFICANT_P, Comparison, compare
from mission.sweep.store import SweepStore
from mission.sweep.summary import cells


@dataclass(frozen=True)
class CellComparison:
    scenario: str
    a_set: str
    b_set: str
    comparison: Comparison


def compare_sweeps(a: str | Path, b: str | Path) -> tuple[list[CellComparison], list[str]]:
    """The matched cells of sweeps `a` and `b` (directories), and notes on what could not be matched."""
    ca, cb = cells(_rows(a)), cells(_rows(b))
    notes: list[str] = []
    pairs = [(k, k) for k in ca if k in cb]
    if not pairs:
        sa, sb = _one_cell_per_scenario(ca), _one_cell_per_scenario(cb)
        if sa and sb and set(sa) & set(sb):
            pairs = [(sa[s], sb[s]) for s in sa if s in sb]
            notes.append(
                "no cell has the same settings in both sweeps; scenarios matched instead (A's settings against B's)"
            )
    matched_a, matched_b = {p[0] for p in pairs}, {p[1] for p in pairs}
    notes += [f"only in A: {_name(k)}" for k in ca if k not in matched_a]
    notes += [f"only in B: {_name(k)}" for k in cb if k not in matched_b]
    out = []
    for ka, kb in pairs:
        outcomes_a = {int(r["seed"]): bool(r.get("success")) for r in ca[ka]}
        outcomes_b = {int(r["seed"]): bool(r.get("success")) for r in cb[kb]}
        out.append(CellComparison(ka[0], ka[1], kb[1], compare(outcomes_a, outcomes_b)))
    return out, notes


def _rows(path: str | Path) -> list[dict[str, Any]]:
    return list(SweepStore(path).load().rows.values())


def _one_cell_per_scenario(groups: dict[tuple[str, str], Any]) -> dict[str, tuple[str, str]] | None:
    by: dict[str, tuple[str, str]] = {}
    for key in groups:
        if key[0] in by:
            return None
        by[key[0]] = key
    return by


def _name(key: tuple[str, str]) -> str:
    return " ".join(p for p in key if p)


def text_table(a: str | Path, b: str | Path, rows: Sequence[CellComparison], notes: Sequence[str]) -> str:
    """The comparison as plain text for the terminal (one block per cell)."""
    lines = [f"A: {a}", f"B: {b}", ""]
    for c in rows:
        cell = c.scenario + (f" [{c.a_set}]" if c.a_set == c.b_set and c.a_set else "")
        if c.a_set != c.b_set:
            cell += f" [A: {c.a_set or 'no --set'} | B: {c.b_set or 'no --set'}]"
        lines += [cell, f"  A {c.comparison.a.text():<28} B {c.comparison.b.text()}", f"  {c.comparison.note()}"]
    if not rows:
        lines.append("no cell of A matches a cell of B")
    lines += ["", *notes] if notes else []
    lines.append(f"(significant: p < {SIGNIFICANT_P}; rates with 95 % Wilson intervals)")
    return "\n".join(lines)


def write_html(
    path: str | Path, a: str | Path, b: str | Path, rows: Sequence[CellComparison], notes: Sequence[str]
) -> Path:
    """The comparison as a page (with links to both summaries)."""
    e = html.escape
    out = [
        "<!doctype html><html><head><meta charset='utf-8'><title>mission sweep --compare</title>"
        "<style>body{font-family:system-ui,sans-serif;margin:1.5em}table{border-collapse:collapse}"
        "th,td{border:1px solid #ccc;padding:.25em .6em}th{background:#f0f0f0}.sig{font-weight:bold}</style>"
        "</head><body>",
        f"<h1>A: {e(str(a))} · B: {e(str(b))}</h1>",
        "<table><tr><th>scenario</th><th>A settings</th><th>A</th><th>B settings</th><th>B</th><th>note</th></tr>",
    ]
    for c in rows:
        cls = " class='sig'" if c.comparison.significant else ""
        out.append(
            f"<tr><td>{e(c.scenario)}</td><td><code>{e(c.a_set or '—')}</code></td>"
            f"<td>{e(c.comparison.a.text())}</td><td><code>{e(c.b_set or '—')}</code></td>"
            f"<td>{e(c.comparison.b.text())}</td><td{cls}>{e(c.comparison.note())}</td></tr>"
        )
    out.append("</table>")
    out += [f"<p>{e(n)}</p>" for n in notes]
    out.append(f"<p>Significant: p &lt; {SIGNIFICANT_P}. Rates with 95 % Wilson intervals.</p></body></html>")
    target = Path(path)
    atomic_write_text(target, "\n".join(out) + "\n")
    return target
