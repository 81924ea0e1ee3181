"""summary.html of a sweep: what a person reads first after `mission sweep`.

From the results table alone (so it can be rewritten from any sweep directory):

* the success rate per scenario and per matrix cell, each with its 95 % Wilson interval;
* the success rate against each ``--set`` key's values, one line per scenario, with intervals;
* re-acquisition-time CDFs per cell (every loss that was recovered, pooled over seeds);
* a scatter of docking errors (lateral against stand-off error, the tolerance box drawn);
* every failing run with its reason, its pictures and the `mission run` command that reproduces it.
"""

from __future__ import annotations

import html
from collections import defaultdict
from collections.abc import Sequence
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

import matplotlib.pyplot as plt
import numpy as np

from mission.app.overrides import format_value
from mission.core.files import atomic_write_text
from mission.sweep.stats import Rate
from mission.sweep.store import SweepStore
from mission.sweep.table import param_keys
from mission.viz.run_report import save_figure

SUMMARY_FILE = "summary.html"
PICTURES_DIR = "summary"
REACQUISITION_LIMIT_S = 10.0  # the design notes' bound (sim_run.REACQUISITION_S)
DOCK_LATERAL_TOL_M = 0.03
DOCK_DISTANCE_TOL_M = 0.025


def cells(rows: Sequence[dict[str, Any]]) -> dict[tuple[str, str], list[dict[str, Any]]]:
    """Rows by matrix cell (scenario, settings label), scenarios in first-seen order, settings sorted."""
    out: dict[tuple[str, str], list[dict[str, Any]]] = defaultdict(list)
    for r in rows:
        out[(r["scenario"], r.get("set") or "")].append(r)
    order = list(dict.fromkeys(r["scenario"] for r in rows))
    return dict(sorted(out.items(), key=lambda kv: (order.index(kv[0][0]), kv[0][1])))


def rate(rows: Sequence[dict[str, Any]]) -> Rate:
    return Rate(sum(1 for r in rows if r.get("success")), len(rows))


def write_summary(store: SweepStore) -> Path:
    """Write OUT/summary.html and its pictures from the recorded rows; returns the page's path."""
    rows = sorted(store.rows.values(), key=lambda r: (r["scenario"], r.get("set") or "", r["seed"]))
    pictures = store.out / PICTURES_DIR
    plots = [
        p
        for p in (
            _plot_rates(rows, pictures / "success_by_cell.png"),
            *(_plot_param(rows, key, pictures / f"success_by_{_slug(key)}.png") for key in param_keys(rows)),
            _plot_reacquisition(rows, pictures / "reacquisition_cdf.png"),
            _plot_docks(rows, pictures / "dock_errors.png"),
        )
        if p is not None
    ]
    page = _page(store, rows, [p.relative_to(store.out) for p in plots])
    path = store.out / SUMMARY_FILE
    atomic_write_text(path, page)
    return path


def _slug(key: str) -> str:
    return "".join(c if c.isalnum() or c in "._-" else "_" for c in key)


# ------------------------------------------------------------------------------------ pictures
def _figure(width: float, height: float) -> tuple[Any, Any]:
    return plt.subplots(figsize=(width, height))


def _save(fig: Any, path: Path) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.tight_layout()
    save_figure(fig, path)
    return path


def _errorbar(ax: Any, xs: Sequence[float], rates: Sequence[Rate], **style: Any) -> None:
    ys = np.array([r.value if r.value is not None else np.nan for r in rates])
    lo = np.array([(r.value or 0) - r.interval[0] if r.interval else 0 for r in rates])
    hi = np.array([r.interval[1] - (r.value or 0) if r.interval else 0 for r in rates])
    ax.errorbar(xs, ys, yerr=[lo, hi], capsize=4, **style)


def _plot_rates(rows: Sequence[dict[str, Any]], path: Path) -> Path | None:
    groups = cells(rows)
    if not groups:
        return None
    labels = [f"{s}\n{label}" if label else s for s, label in groups]
    rates = [rate(g) for g in groups.values()]
    fig, ax = _figure(max(5.0, 0.9 * len(groups) + 2), 3.8)
    x = np.arange(len(groups))
    ax.bar(x, [r.value or 0 for r in rates], color="#4c72b0", alpha=0.75)
    _errorbar(ax, x, rates, fmt="none", ecolor="black")
    for xi, r in zip(x, rates, strict=True):
        ax.text(xi, 0.02, f"{r.k}/{r.n}", ha="center", fontsize=8, color="white")
    slanted = len(groups) > 4 or max(len(max(label.split("\n"), key=len)) for label in labels) > 22
    ax.set_xticks(x, labels, fontsize=7, rotation=25 if slanted else 0, ha="right" if slanted else "center")
    ax.set_ylim(0, 1.05)
    ax.set_ylabel("success rate (95 % Wilson interval)")
    ax.set_title("Success rate per scenario and cell")
    return _save(fig, path)


def _plot_param(rows: Sequence[dict[str, Any]], key: str, path: Path) -> Path | None:
    by: dict[str, dict[str, list[dict[str, Any]]]] = defaultdict(lambda: defaultdict(list))
    for r in rows:
        params = r.get("params") or {}
        if key in params:
            by[r["scenario"]][format_value(params[key])].append(r)
    values = list(dict.fromkeys(v for per in by.values() for v in per))
    if not values:
        return None
    numeric = all(_is_number(v) for v in values)
    values.sort(key=lambda v: float(v) if numeric else v)
    fig, ax = _figure(6.5, 3.8)
    for i, (scenario, per) in enumerate(by.items()):
        present = [v for v in values if v in per]
        xs = [float(v) for v in present] if numeric else [values.index(v) + 0.05 * i for v in present]
        _errorbar(ax, xs, [rate(per[v]) for v in present], marker="o", label=scenario)
    if not numeric:
        ax.set_xticks(range(len(values)), values, fontsize=8)
    ax.set_ylim(-0.02, 1.05)
    ax.set_xlabel(key)
    ax.set_ylabel("success rate (95 % Wilson interval)")
    ax.set_title(f"Success rate by {key} (other settings pooled)")
    ax.legend(fontsize=7)
    ax.grid(alpha=0.3)
    return _save(fig, path)


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def _plot_reacquisition(rows: Sequence[dict[str, Any]], path: Path) -> Path | None:
    series = {
        f"{s} {label}".strip(): sorted(t for r in g for t in (r.get("reacquisition_times_s") or []))
        for (s, label), g in cells(rows).items()
    }
    series = {k: v for k, v in series.items() if v}
    if not series:
        return None
    fig, ax = _figure(6.5, 3.8)
    for label, values in series.items():
        v = np.asarray(values, dtype=float)
        ax.step(
            np.concatenate([[0.0], v]), np.arange(len(v) + 1) / len(v), where="post", label=f"{label} ({len(v)} losses)"
        )
    ax.axvline(REACQUISITION_LIMIT_S, color="grey", ls="--", lw=0.8, label=f"limit {REACQUISITION_LIMIT_S:g} s")
    ax.set(
        xlabel="re-acquisition time (s)",
        ylabel="fraction of recovered losses",
        title="Re-acquisition time after a loss (CDF over every run's losses)",
    )
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)
    return _save(fig, path)


def _plot_docks(rows: Sequence[dict[str, Any]], path: Path) -> Path | None:
    docked = [r for r in rows if r.get("dock_lateral_m") is not None and r.get("dock_distance_m") is not None]
    if not docked:
        return None
    fig, ax = _figure(5.5, 4.5)
    ax.add_patch(_box())
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for i, (label, group) in enumerate(cells(docked).items()):
        name = " ".join(p for p in label if p)
        for ok, marker in ((True, "o"), (False, "x")):  # one colour per cell; o succeeded, x failed
            pts = [(100 * r["dock_lateral_m"], 100 * r["dock_distance_m"]) for r in group if bool(r["success"]) is ok]
            if pts:
                xs, ys = zip(*pts, strict=True)
                ax.scatter(
                    xs,
                    ys,
                    marker=marker,
                    color=colours[i % len(colours)],
                    alpha=0.8,
                    label=f"{name} ({'ok' if ok else 'failed'})",
                )
    ax.set(
        xlabel="lateral error (cm)",
        ylabel="stand-off error (cm)",
        title="Docking errors (box: tolerance 3 cm × 2.5 cm)",
    )
    ax.set_xlim(left=0)
    ax.set_ylim(bottom=0)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)
    return _save(fig, path)


def _box() -> Any:
    from matplotlib.patches import Rectangle

    return Rectangle((0, 0), 100 * DOCK_LATERAL_TOL_M, 100 * DOCK_DISTANCE_TOL_M, color="#2ca02c", alpha=0.12)


# ------------------------------------------------------------------------------------ the page
STYLE = """
body { font-family: system-ui, sans-serif; margin: 1.5em; color: #222; }
table { border-collapse: collapse; margin: 0.5em 0 1.5em; font-size: 0.9em; }
th, td { border: 1px solid #ccc; padding: 0.25em 0.6em; text-align: left; vertical-align: top; }
th { background: #f0f0f0; }
td.num { text-align: right; font-variant-numeric: tabular-nums; }
.fail { color: #b00; } .ok { color: #070; }
img.plot { max-width: 48%; margin: 0.3em; border: 1px solid #ddd; }
img.thumb { width: 150px; }
code { font-size: 0.85em; }
"""


def _page(store: SweepStore, rows: Sequence[dict[str, Any]], plots: Sequence[Path]) -> str:
    e = html.escape
    info = store.info()
    plans = info.get("plans") or [{}]
    plan = plans[-1]
    planned = plan.get("runs")
    failing = [r for r in rows if not r.get("success")]
    head = [
        f"<h1>Sweep {e(str(store.out))}</h1>",
        f"<p>{len(rows)} runs recorded"
        + (f" (the last plan asked for {planned})" if planned is not None else "")
        + f"; {len(rows) - len(failing)} succeeded, {len(failing)} failed. "
        f"Written {datetime.now(timezone.utc).strftime('%Y-%m-%d %H:%M UTC')}.</p>",
        f"<p>Plan: {e(_plan_text(plan))}</p>",
        "<p>Tables: <a href='results.parquet'>results.parquet</a> · <a href='runs.jsonl'>runs.jsonl</a>. "
        "Rates are k/n with a 95 % Wilson interval; compare two sweeps with "
        "<code>mission sweep --compare A B</code>.</p>",
    ]
    body = [*head, "<h2>Success rate per cell</h2>", _cells_table(rows)]
    if plots:
        body += ["<h2>Pictures</h2>", "<div>"]
        body += [
            f"<a href='{e(p.as_posix())}'><img class='plot' src='{e(p.as_posix())}' alt='{e(p.stem)}'></a>"
            for p in plots
        ]
        body += ["</div>"]
    body += [f"<h2>Failing runs ({len(failing)})</h2>", _failures_table(failing) if failing else "<p>None.</p>"]
    return (
        "<!doctype html><html><head><meta charset='utf-8'><title>mission sweep</title>"
        f"<style>{STYLE}</style></head><body>\n" + "\n".join(body) + "\n</body></html>\n"
    )


def _plan_text(plan: dict[str, Any]) -> str:
    """``scenarios a, b · seeds 0-19 · --set K=V1,V2 · --max-duration 12``: the plan as it was typed."""
    parts = [f"scenarios {', '.join(plan.get('scenarios') or [])}", f"seeds {plan.get('seeds')}"]
    parts += [f"--set {k}={','.join(format_value(v) for v in vs)}" for k, vs in (plan.get("set") or {}).items()]
    for key, flag in (
        ("config_file", "--config"),
        ("tree", "--tree"),
        ("max_duration_s", "--max-duration"),
        ("pictures", "--pictures"),
    ):
        if plan.get(key) is not None:
            parts.append(f"{flag} {plan[key]:g}" if isinstance(plan[key], float) else f"{flag} {plan[key]}")
    return " · ".join(parts)


def _median(values: Sequence[float]) -> str:
    return f"{float(np.median(values)):.3g}" if values else "–"


def _cells_table(rows: Sequence[dict[str, Any]]) -> str:
    e = html.escape
    out = [
        "<table><tr><th>scenario</th><th>settings</th><th>runs</th><th>success rate</th>"
        "<th>losses recovered</th><th>re-acquisition median / max (s)</th>"
        "<th>dock lateral / stand-off median (cm)</th><th>collisions</th></tr>"
    ]
    for (scenario, label), group in cells(rows).items():
        r = rate(group)
        losses = sum(int(g.get("loss_events") or 0) for g in group)
        recovered = sum(int(g.get("loss_events_recovered") or 0) for g in group)
        reacq = [t for g in group for t in (g.get("reacquisition_times_s") or [])]
        lat = [100 * g["dock_lateral_m"] for g in group if g.get("dock_lateral_m") is not None]
        dist = [100 * g["dock_distance_m"] for g in group if g.get("dock_distance_m") is not None]
        cls = "ok" if r.k == r.n else "fail"
        out.append(
            f"<tr><td>{e(scenario)}</td><td><code>{e(label or '—')}</code></td><td class='num'>{r.n}</td>"
            f"<td class='num {cls}'>{e(r.text())}</td><td class='num'>{recovered}/{losses}</td>"
            f"<td class='num'>{_median(reacq)} / {max(reacq) if reacq else '–'}</td>"
            f"<td class='num'>{_median(lat)} / {_median(dist)}</td>"
            f"<td class='num'>{sum(int(g.get('collisions') or 0) for g in group)}</td></tr>"
        )
    out.append("</table>")
    return "\n".join(out)


def _failures_table(failing: Sequence[dict[str, Any]]) -> str:
    e = html.escape
    out = [
        "<table><tr><th>scenario</th><th>settings</th><th>seed</th><th>reason</th><th>pictures</th>"
        "<th>reproduce</th></tr>"
    ]
    for r in failing:
        folder = r.get("report_dir") or ""
        links = [f"<a href='{e(folder)}/report.json'>report.json</a>"]
        thumb = ""
        if r.get("pictures"):
            links = [
                f"<a href='{e(folder)}/report.html'>report</a>",
                *links,
                f"<a href='{e(folder)}/timeline.png'>timeline</a>",
            ]
            thumb = (
                f"<a href='{e(folder)}/trajectories.png'><img class='thumb' src='{e(folder)}/trajectories.png' "
                "alt='trajectories'></a><br>"
            )
        out.append(
            f"<tr><td>{e(r['scenario'])}</td><td><code>{e(r.get('set') or '—')}</code></td>"
            f"<td class='num'>{r['seed']}</td><td class='fail'>{e(str(r.get('reason', '')))}</td>"
            f"<td>{thumb}{' · '.join(links)}</td><td><code>{e(r.get('command') or '')}</code></td></tr>"
        )
    out.append("</table>")
    return "\n".join(out)
