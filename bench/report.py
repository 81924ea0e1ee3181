"""BENCHMARKS.md from the figures `mission bench` wrote: ``python -m bench.report [bench/results]``.

BENCHMARKS.md (and the plots in docs/bench/) come from bench/results only, the committed figures of full
runs. Given another results directory (``out/bench-quick`` from ``mission bench --quick``), the report is
written inside it (``out/bench-quick/BENCHMARKS.md``) unless ``--out``/``--docs`` say otherwise.

Reads every ``<results>/<name>.json`` (one per benchmark: what ``mission bench`` writes — the command, the
machine, the date and the run's figures — or a bare ``run()`` result such as ``python -m bench.soak``
writes), and writes one section per benchmark: the command, the date, the machine and its load, a table of
figures (value, baseline, ratio, target, ✓/✗), the plots (copied to docs/bench/ so they render on GitHub)
and the details. Files ``<name>_<part>.json`` beside a ``<name>.json`` are parts of it and skipped.

Hand-written text is never lost on regeneration, because it lives outside the output:

* ``docs/bench/notes.md`` — sections ``<!-- note: NAME -->`` (NAME = a benchmark, or ``intro``), each
  placed after that benchmark's figures. ``{{NAME:path/into/result}}`` in a note is replaced by that
  value of the benchmark's result (e.g. ``{{apriltag_backends:details/results/opencv (subpix)/3 m/time_ms_median}}``),
  so the prose quotes the current run; ``{{NAME:fig:LABEL}}`` / ``{{NAME:fig:LABEL#baseline_value}}`` quote a figure.
* ``<results>/<name>.md`` — that run's own write-up (e.g. soak.md), included under its figures.
"""

from __future__ import annotations

import argparse
import json
import re
import shutil
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from bench.catalogue import BENCHMARKS, RESULTS, is_committed_results
from mission.core.errors import MissionError

ROOT = Path(__file__).resolve().parents[1]
DEFAULT_RESULTS = RESULTS  # the committed full-run figures; quick runs write out/bench-quick/ instead
DEFAULT_OUT = ROOT / "BENCHMARKS.md"
DEFAULT_DOCS = ROOT / "docs" / "bench"
NOTES = "notes.md"
SKIP = {"results.json"}  # the per-invocation summary; the per-benchmark files hold the same entries
MACHINE_KEYS = ("cpu", "cores", "os", "python", "opencv", "pybullet", "pupil_apriltags", "py_trees", "numpy")
# Benchmarks run outside `mission bench` record no command; how they were run.
KNOWN_COMMANDS = {
    "soak": "python -m bench.soak --part sim; python -m bench.soak --part ros; python -m bench.soak --merge",
}
_PLACEHOLDER = re.compile(r"\{\{([a-z0-9_]+):([^}]+)\}\}")


@dataclass
class Entry:
    """One benchmark's figures as found in the results directory."""

    name: str
    path: Path
    result: dict[str, Any]
    command: str | None = None
    description: str = ""
    started_utc: str | None = None
    elapsed_s: float | None = None
    quick: bool = False
    machine: dict[str, Any] = field(default_factory=dict)

    @property
    def figures(self) -> list[dict[str, Any]]:
        return list(self.result.get("figures", []))


def load_entry(path: Path) -> Entry:
    """A results file as an Entry; a MissionError naming the file when it is not one."""
    try:
        data = json.loads(path.read_text())
    except (OSError, json.JSONDecodeError) as err:
        raise MissionError(f"{path}: not readable as JSON ({err})") from None
    if not isinstance(data, dict):
        raise MissionError(f"{path}: expected a JSON object with 'result' or 'figures', got {type(data).__name__}")
    if "result" in data:  # written by `mission bench`
        return Entry(
            name=str(data.get("name", path.stem)),
            path=path,
            result=data["result"],
            command=data.get("command"),
            description=str(data.get("description", "")),
            started_utc=data.get("started_utc"),
            elapsed_s=data.get("elapsed_s"),
            quick=bool(data.get("quick")),
            machine=data.get("machine") or {},
        )
    if "figures" in data:  # a bare run() result (python -m bench.<module>)
        details = data.get("details") or {}
        return Entry(
            name=path.stem,
            path=path,
            result=data,
            command=KNOWN_COMMANDS.get(path.stem),
            quick=bool(details.get("quick")),
        )
    raise MissionError(f"{path}: expected a JSON object with 'result' (mission bench) or 'figures' (a run() result)")


def collect(results: Path) -> list[Entry]:
    """The benchmarks in `results`, in registry order then by name; parts (<name>_<part>.json) skipped."""
    if not results.is_dir():
        raise MissionError(f"{results}: no such results directory (run `mission bench -o {results}` first)")
    files = {p.stem: p for p in sorted(results.glob("*.json")) if p.name not in SKIP and not p.name.startswith(".")}
    registered = {b.name for b in BENCHMARKS}  # ros_missions is a benchmark of its own, not a part of ros
    parts = {s for s in files if s not in registered and any(s.startswith(f"{o}_") for o in files if o != s)}
    entries = [load_entry(p) for s, p in files.items() if s not in parts]
    order = {b.name: i for i, b in enumerate(BENCHMARKS)}
    descriptions = {b.name: b.description for b in BENCHMARKS}
    for e in entries:
        e.description = e.description or descriptions.get(e.name, "")
    return sorted(entries, key=lambda e: (order.get(e.name, len(order)), e.name))


# --------------------------------------------------------------------------------------------------
# formatting
# --------------------------------------------------------------------------------------------------


def fmt(value: Any) -> str:
    """A number as a person reads it (about 3 significant figures, no float noise); anything else as text."""
    if value is None:
        return "—"
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        mag = abs(value)
        if value != value:  # NaN
            return "—"
        if value == 0 or mag >= 1000:
            return f"{value:,.0f}"
        if mag >= 100:
            return f"{value:.0f}"
        if mag >= 10:
            return f"{value:.1f}"
        if mag >= 1:
            return f"{value:.2f}"
        return f"{value:.3g}"
    return str(value)


def cell(text: Any) -> str:
    """Text safe inside a markdown table cell."""
    return str(text).replace("|", "\\|").replace("\n", " ")


def verdict(meets: Any) -> str:
    return {True: "✓", False: "✗"}.get(meets, "")


def figure_table(figures: list[dict[str, Any]]) -> list[str]:
    lines = [
        "| Figure | Value | Baseline (what it is measured against) | Baseline value | Ratio | Target | |",
        "|---|---|---|---|---|---|---|",
    ]
    for f in figures:
        unit = f.get("unit") or ""
        sep = "" if unit in ("×", "%") else " "
        value = f"{fmt(f.get('value'))}{sep}{unit}" if f.get("value") is not None else "—"
        base = f.get("baseline_value")
        base_text = "—" if base is None else f"{fmt(base)}{sep}{unit}" if isinstance(base, int | float) else fmt(base)
        lines.append(
            f"| {cell(f.get('label', ''))} | {cell(value)} | {cell(f.get('baseline') or 'NOT NAMED')} | "
            f"{cell(base_text)} | {fmt(f.get('ratio'))} | {cell(f.get('target') or '')} | "
            f"{verdict(f.get('meets_target'))} |"
        )
    return lines


def machine_line(m: dict[str, Any], keys: tuple[str, ...] = MACHINE_KEYS) -> str:
    names = {
        "cpu": "",
        "cores": "cores",
        "os": "",
        "python": "Python",
        "opencv": "OpenCV",
        "pybullet": "pybullet",
        "pupil_apriltags": "pupil-apriltags",
        "py_trees": "py_trees",
        "numpy": "numpy",
    }
    parts = []
    for k in keys:
        if m.get(k) is None:
            continue
        label = names.get(k, k)
        parts.append(f"{m[k]} {label}" if k == "cores" else f"{label} {m[k]}".strip())
    return ", ".join(parts)


def _scalar(v: Any) -> bool:
    return not isinstance(v, dict | list) or (isinstance(v, list) and all(not isinstance(x, dict | list) for x in v))


def _flat(d: Any) -> bool:
    """A dict that fits one table row: scalars, or short lists of scalars (shown joined)."""
    return isinstance(d, dict) and all(_scalar(v) for v in d.values())


def _value(v: Any) -> str:
    if isinstance(v, list):
        text = ", ".join(fmt(x) for x in v)
        return text if len(text) <= 80 else text[:77] + "…"
    return fmt(v)


def table_of(rows: list[dict[str, Any]], first: str | None = None) -> list[str]:
    """A markdown table of flat dicts (columns in first-seen order; `first` names a leading key column)."""
    cols: list[str] = []
    for r in rows:
        cols += [k for k in r if k not in cols]
    head = ([first] if first is not None else []) + [c for c in cols if c != first]
    lines = ["| " + " | ".join(cell(h) for h in head) + " |", "|" + "---|" * len(head)]
    for r in rows:
        lines.append("| " + " | ".join(cell(_value(r.get(h))) for h in head) + " |")
    return lines


def _flatten_row(row: Any) -> Any:
    """A row whose values include flat dicts ({"ours": {...}, "raw": {...}}) as one flat row ("ours.n", …)."""
    if not isinstance(row, dict) or not any(_flat(v) and isinstance(v, dict) for v in row.values()):
        return row
    out: dict[str, Any] = {}
    for k, v in row.items():
        if isinstance(v, dict) and _flat(v):
            out.update({f"{k}.{a}": b for a, b in v.items()})
        else:
            out[k] = v
    return out


def _details(name: str, v: Any, out: list[str]) -> None:
    """One details item: a bullet for a scalar or a flat dict, a table for rows, recursion otherwise."""
    if isinstance(v, list):
        v = [_flatten_row(r) for r in v]
    if _scalar(v):
        out.append(f"- {name}: {_value(v)}")
    elif isinstance(v, list) and v and all(_flat(r) for r in v):
        out += ["", f"**{name}**", "", *table_of(v), ""]
    elif isinstance(v, dict) and _flat(v):
        out.append(f"- {name}: " + ", ".join(f"{a} {_value(b)}" for a, b in v.items()))
    elif (
        isinstance(v, dict)
        and v
        and all(isinstance(x, dict) for x in v.values())
        and len(v) <= 8
        and any(sum(1 for y in x.values() if _scalar(y)) > 10 for x in v.values())
    ):
        # a few wide records (e.g. per-scenario outcomes): one column per record, one row per field
        fields: list[str] = []
        for x in v.values():
            fields += [k for k, y in x.items() if _scalar(y) and k not in fields]
        out += ["", f"**{name}**", "", "| | " + " | ".join(cell(a) for a in v) + " |", "|---|" + "---|" * len(v)]
        out += [f"| {cell(f)} | " + " | ".join(cell(_value(x.get(f))) for x in v.values()) + " |" for f in fields]
        out.append("")
        for a, x in v.items():
            for k, y in x.items():
                if not _scalar(y) and y:
                    _details(f"{name}.{a}.{k}", y, out)
    elif isinstance(v, dict) and v and all(_flat(x) for x in v.values()):
        out += ["", f"**{name}**", "", *table_of([{"": a, **row} for a, row in v.items()], ""), ""]
    elif (
        isinstance(v, dict)
        and v
        and all(isinstance(x, dict) and x and all(_flat(y) for y in x.values()) for x in v.values())
    ):
        rows = [{"": f"{a} / {b}", **row} for a, sub in v.items() for b, row in sub.items()]
        out += ["", f"**{name}**", "", *table_of(rows, ""), ""]
    elif isinstance(v, dict):
        scalars = {k: x for k, x in v.items() if _scalar(x)}
        if scalars:
            out.append(f"- {name}: " + ", ".join(f"{a} {_value(b)}" for a, b in scalars.items()))
        for k, x in v.items():
            if k not in scalars:
                _details(f"{name}.{k}", x, out)
    else:
        text = json.dumps(v, default=str)
        out.append(f"- {name}: {cell(text if len(text) <= 300 else text[:297] + '…')}")


def details_block(details: dict[str, Any]) -> list[str]:
    """The run's details in a collapsed block: scalars as a list, row lists and nested tables as tables."""
    if not details:
        return []
    out = ["<details><summary>Details</summary>", ""]
    for k, v in details.items():
        if v is not None:
            _details(k, v, out)
    out += ["", "</details>"]
    return re.sub(r"\n{3,}", "\n\n", "\n".join(out)).split("\n")


def demote(markdown: str, levels: int = 2) -> str:
    """Headings one section deeper (a write-up's `# Title` becomes `### Title` inside its benchmark)."""
    return re.sub(r"^(#{1,5}) ", lambda m: "#" * (len(m.group(1)) + levels) + " ", markdown, flags=re.M)


# --------------------------------------------------------------------------------------------------
# hand-written notes
# --------------------------------------------------------------------------------------------------


def read_notes(path: Path) -> dict[str, str]:
    """Sections ``<!-- note: NAME -->`` of the notes file (empty when it does not exist)."""
    if not path.is_file():
        return {}
    notes: dict[str, str] = {}
    current: str | None = None
    buf: list[str] = []
    for line in path.read_text().splitlines():
        m = re.match(r"\s*<!--\s*note:\s*([a-z0-9_]+)\s*-->\s*$", line)
        if m:
            if current:
                notes[current] = "\n".join(buf).strip()
            current, buf = m.group(1), []
        elif current:
            buf.append(line)
    if current:
        notes[current] = "\n".join(buf).strip()
    return notes


def lookup(result: dict[str, Any], path: str) -> Any:
    """The value at `path` ("details/a/b") in a result, or of a figure: "fig:LABEL" (its value) or
    "fig:LABEL#field" (e.g. #baseline_value, #ratio)."""
    if path.startswith("fig:"):
        label, _, key = path[4:].partition("#")
        fig = next((f for f in result.get("figures", []) if f.get("label") == label), None)
        return None if fig is None else fig.get(key or "value")
    cur: Any = result
    for part in path.split("/"):
        if isinstance(cur, dict) and part in cur:
            cur = cur[part]
        elif isinstance(cur, list) and part.isdigit() and int(part) < len(cur):
            cur = cur[int(part)]
        else:
            return None
    return cur


def fill(text: str, entries: dict[str, Entry], missing: list[str]) -> str:
    """Replace ``{{name:path}}`` by the value in that benchmark's result ('n/a' and noted when absent)."""

    def sub(m: re.Match[str]) -> str:
        e = entries.get(m.group(1))
        value = None if e is None else lookup(e.result, m.group(2).strip())
        if value is None:
            missing.append(m.group(0))
            return "n/a"
        return fmt(value)

    return _PLACEHOLDER.sub(sub, text)


# --------------------------------------------------------------------------------------------------
# the document
# --------------------------------------------------------------------------------------------------


def common_machine(entries: list[Entry]) -> dict[str, Any] | None:
    fingerprints = {machine_line(e.machine) for e in entries if e.machine}
    if len(fingerprints) == 1:
        return next(e.machine for e in entries if e.machine)
    return None


def render(results: Path, out: Path, docs: Path) -> tuple[str, list[str]]:
    """The markdown for `results` (plots copied into `docs`, linked relative to `out`); and warnings."""
    entries = collect(results)
    by_name = {e.name: e for e in entries}
    notes = read_notes(docs / NOTES)
    warnings: list[str] = []
    rel_docs = Path(_relpath(docs, out.parent))
    machine = common_machine(entries)
    lines = [
        "# Benchmarks",
        "",
        f"<!-- Generated by `python -m bench.report {_display(results)}` from {_display(results)}/*.json. "
        "Do not edit here: hand-written text lives in docs/bench/notes.md and <results>/<name>.md. -->",
        "",
        "Every figure stands beside the baseline it is measured against, in the same run and on the same inputs "
        "(interleaved where it is a time, so both sides see the same machine load); the ratio is what to quote. "
        "Regenerate with `python -m bench.report` after `mission bench`.",
        "",
    ]
    if "intro" in notes:
        lines += [fill(notes["intro"], by_name, warnings), ""]
    if machine:
        lines += [f"**Machine:** {machine_line(machine)}.", ""]
    lines += ["| Benchmark | Measured | Command | Targets met |", "|---|---|---|---|"]
    for e in entries:
        targets = [f for f in e.figures if f.get("meets_target") is not None]
        met = sum(1 for f in targets if f.get("meets_target"))
        tmark = f"{met}/{len(targets)}" if targets else "no target"
        lines.append(f"| [{e.name}](#{_anchor(e)}) | {e.started_utc or '—'} | `{e.command or '—'}` | {tmark} |")
    if "missions" not in by_name:
        lines.append("| missions | not yet | `mission bench --only missions` | (missions.json not in the results) |")
    lines.append("")
    for e in entries:
        lines += section(e, machine, docs, rel_docs, results, notes, by_name, warnings)
    if "missions" not in by_name:
        lines += [
            "## missions",
            "",
            "Not in this results directory yet: `mission bench --only missions -o "
            f"{_display(results)}` writes missions.json (≥ 20 seeds per scenario).",
            "",
        ]
    for f in (f for e in entries for f in e.figures):
        if not f.get("baseline"):
            warnings.append(f"figure without a baseline: {f.get('label')!r}")
    return "\n".join(lines).rstrip() + "\n", warnings


def section(
    e: Entry,
    machine: dict[str, Any] | None,
    docs: Path,
    rel_docs: Path,
    results: Path,
    notes: dict[str, str],
    by_name: dict[str, Entry],
    warnings: list[str],
) -> list[str]:
    title = e.result.get("title") or e.description or e.name
    lines = [f"## {e.name}", "", f"**{title}**" + (" — *quick run*" if e.quick else ""), ""]
    meta = []
    if e.command:
        meta.append(f"- Command: `{e.command}`")
    if e.started_utc:
        took = f", took {e.elapsed_s:.0f} s" if isinstance(e.elapsed_s, int | float) else ""
        meta.append(f"- Date: {e.started_utc}{took}")
    load = e.machine.get("load_average_1min")
    if load is None:
        load = (e.result.get("details") or {}).get("load_average")
    if e.machine and machine_line(e.machine) != machine_line(machine or {}):
        meta.append(f"- Machine: {machine_line(e.machine)}")
    elif not e.machine:
        meta.append("- Machine: not recorded in this file (run outside `mission bench`; see the write-up below)")
    if load is not None:
        cores = e.machine.get("cores", 2)
        meta.append(f"- Load average (1 min) when the command started: {fmt(load)} on {cores} cores")
    meta.append(f"- Source: `{_display(e.path)}`")
    lines += [*meta, ""]
    if e.figures:
        lines += [*figure_table(e.figures), ""]
    else:
        lines += ["*(no figures)*", ""]
    for plot in e.result.get("plots", []) or []:
        src = results / plot
        if not src.is_file():
            warnings.append(f"{e.name}: plot {src} does not exist")
            continue
        docs.mkdir(parents=True, exist_ok=True)
        if src.resolve() != (docs / plot).resolve():
            shutil.copyfile(src, docs / plot)
        lines += [f"![{e.name}: {plot}]({(rel_docs / plot).as_posix()})", ""]
    if e.name in notes:
        lines += [fill(notes[e.name], by_name, warnings), ""]
    write_up = e.path.with_suffix(".md")
    if write_up.is_file():
        lines += [f"### Write-up of this run ({_display(write_up)})", "", demote(write_up.read_text().strip()), ""]
    lines += [*details_block(e.result.get("details") or {}), ""]
    return lines


def _anchor(e: Entry) -> str:
    return re.sub(r"[^a-z0-9_-]", "", e.name.lower().replace(" ", "-"))


def _relpath(target: Path, start: Path) -> str:
    import os

    return os.path.relpath(target.resolve(), start.resolve())


def _display(p: Path) -> str:
    try:
        return p.resolve().relative_to(ROOT).as_posix()
    except ValueError:
        return str(p)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m bench.report", description=__doc__.split("\n")[0])
    ap.add_argument(
        "results",
        nargs="?",
        type=Path,
        default=DEFAULT_RESULTS,
        help="results directory (default bench/results, the committed full-run figures)",
    )
    ap.add_argument(
        "--out",
        type=Path,
        default=None,
        help="markdown to write (default BENCHMARKS.md; RESULTS/BENCHMARKS.md for another results dir)",
    )
    ap.add_argument(
        "--docs",
        type=Path,
        default=None,
        help="where plots are copied and notes.md is read (default docs/bench; RESULTS/docs for another)",
    )
    args = ap.parse_args(argv)
    # BENCHMARKS.md and docs/bench/ are made from the committed results; any other results directory
    # (out/bench-quick/ of `mission bench --quick`) gets its report beside its figures unless told otherwise.
    committed = is_committed_results(args.results)
    args.out = args.out or (DEFAULT_OUT if committed else args.results / "BENCHMARKS.md")
    args.docs = args.docs or (DEFAULT_DOCS if committed else args.results / "docs")
    try:
        text, warnings = render(args.results, args.out, args.docs)
    except MissionError as err:
        print(f"bench.report: error: {err}", file=sys.stderr)
        return 2
    from mission.core.files import atomic_write_bytes

    atomic_write_bytes(args.out, text.encode())
    for w in warnings:
        print(f"bench.report: warning: {w}", file=sys.stderr)
    print(f"wrote {args.out} ({len(text.splitlines())} lines)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
