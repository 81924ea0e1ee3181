"""`mission bench` and `python -m bench.report`: what a user running the benchmarks sees.

The benchmarks run for real (quick mode, the two cheapest) in a subprocess, as a user types them; the
report is generated from the figures they wrote. No assertion on any speed: only on the shape of what is
printed and written (every figure names its baseline, every benchmark gets its table).
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

ROOT = Path(__file__).resolve().parents[2]
CHEAP = ("perception", "apriltag_backends")


def _mission(*args: str, timeout: float = 300) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "mission", *args], cwd=ROOT, capture_output=True, text=True, timeout=timeout, check=False
    )


@pytest.fixture(scope="module")
def quick_run(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, dict[str, Any]]:
    """`mission bench --quick --json --only perception,apriltag_backends -o DIR`: (DIR, parsed stdout)."""
    out = tmp_path_factory.mktemp("results")
    proc = _mission("bench", "--quick", "--json", "--only", ",".join(CHEAP), "-o", str(out))
    assert proc.returncode == 0, proc.stderr[-2000:]
    return out, json.loads(proc.stdout)


def test_quick_json_prints_every_benchmark_with_figures_that_name_their_baseline(quick_run):
    out, summary = quick_run
    assert set(summary["benchmarks"]) == set(CHEAP)
    assert summary["command"] == f"mission bench --quick --only {','.join(CHEAP)} -o {out}"
    assert summary["machine"]["cores"] >= 1 and summary["machine"]["opencv"]
    for name, entry in summary["benchmarks"].items():
        assert "error" not in entry, entry.get("error")
        figures = entry["result"]["figures"]
        assert figures, f"{name} has no figures"
        for f in figures:
            assert isinstance(f["baseline"], str) and f["baseline"].strip(), f"{name}: {f['label']} names no baseline"
            assert f["value"] is not None and f["unit"]
        # each benchmark's own file holds the same entry, with the command and the machine
        on_disk = json.loads((out / f"{name}.json").read_text())
        assert on_disk["result"]["figures"] == figures and on_disk["command"] == summary["command"]


def test_unknown_benchmark_name_is_a_one_line_error_listing_the_known_ones():
    proc = _mission("bench", "--quick", "--only", "perception,warp_drive", timeout=60)
    assert proc.returncode != 0
    lines = [ln for ln in proc.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1, proc.stderr
    assert "'warp_drive'" in lines[0] and "known:" in lines[0]
    for known in ("perception", "pose", "apriltag_backends", "tree", "latency", "sim", "missions", "ros", "soak"):
        assert known in lines[0]
    assert proc.stdout == ""


def test_report_writes_each_benchmarks_table_plots_and_the_hand_written_notes(quick_run, tmp_path):
    results, summary = quick_run
    docs = tmp_path / "docs"
    docs.mkdir()
    (docs / "notes.md").write_text(
        "<!-- note: apriltag_backends -->\n"
        "Why the default: corners {{apriltag_backends:details/results/apriltag3 (decimate 2)/1 m/corner_px_mean}} px.\n"
    )
    md_path = tmp_path / "BENCHMARKS.md"
    cmd = [sys.executable, "-m", "bench.report", str(results), "--out", str(md_path), "--docs", str(docs)]
    proc = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, timeout=120, check=False)
    assert proc.returncode == 0, proc.stderr
    md = md_path.read_text()
    for name in CHEAP:
        entry = summary["benchmarks"][name]
        section = md.split(f"\n## {name}\n", 1)[1].split("\n## ", 1)[0]
        assert "| Figure | Value | Baseline" in section
        for f in entry["result"]["figures"]:
            assert f["label"] in section and f["baseline"] in section
        assert f"Command: `{entry['command']}`" in section and entry["started_utc"] in section
        for plot in entry["result"]["plots"]:
            assert (docs / plot).is_file() and f"](docs/{plot})" in section  # copied, linked relative to the .md
    assert entry["machine"]["cpu"] in md  # the machine the figures were measured on
    corner = summary["benchmarks"]["apriltag_backends"]["result"]["details"]["results"]["apriltag3 (decimate 2)"]
    assert f"Why the default: corners {corner['1 m']['corner_px_mean']:.3g} px." in md
    assert "missions.json not in the results" in md  # the sweep's figures are absent here, and it says so


def test_report_names_the_file_that_is_not_a_benchmark_result(tmp_path):
    (tmp_path / "tree.json").write_text("{not json")
    cmd = [
        sys.executable,
        "-m",
        "bench.report",
        str(tmp_path),
        "--out",
        str(tmp_path / "B.md"),
        "--docs",
        str(tmp_path / "docs"),
    ]
    proc = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, timeout=60, check=False)
    assert proc.returncode == 2
    assert proc.stderr.count("\n") == 1 and "tree.json" in proc.stderr and "not readable as JSON" in proc.stderr
    assert not (tmp_path / "B.md").exists()


def _digests(directory: Path) -> dict[str, str]:
    import hashlib

    return {p.name: hashlib.sha256(p.read_bytes()).hexdigest() for p in sorted(directory.glob("*")) if p.is_file()}


def test_quick_figures_go_to_out_bench_quick_and_full_ones_to_the_committed_results():
    import argparse

    from bench.catalogue import QUICK_RESULTS, RESULTS
    from bench.command import command_line, output_dir

    def args(quick: bool) -> argparse.Namespace:
        return argparse.Namespace(quick=quick, only=None, output=None)

    assert output_dir(args(quick=True)) == QUICK_RESULTS == ROOT / "out" / "bench-quick"
    ignored = subprocess.run(
        ["git", "check-ignore", "-q", str(QUICK_RESULTS / "perception.json")], cwd=ROOT, check=False
    )
    assert ignored.returncode == 0  # never committed by accident
    assert output_dir(args(quick=False)) == RESULTS == ROOT / "bench" / "results"
    assert command_line(args(quick=True)) == "mission bench --quick"  # the default directory is not spelt out


@pytest.mark.parametrize("spelling", ["bench/results", "./bench/../bench/results/", str(ROOT / "bench" / "results")])
def test_a_quick_run_is_refused_the_committed_results_directory(spelling):
    before = _digests(ROOT / "bench" / "results")
    proc = _mission("bench", "--quick", "--only", "apriltag_backends", "-o", spelling, timeout=60)
    assert proc.returncode == 2 and proc.stdout == ""
    assert proc.stderr.splitlines() == [
        f"mission: error: -o {spelling}: --quick figures never go into the committed full-run results; "
        "expected another directory (the default is out/bench-quick)"
    ]
    assert _digests(ROOT / "bench" / "results") == before


def test_mission_bench_runs_from_any_directory_of_the_checkout(tmp_path):
    exe = Path(sys.executable).parent / "mission"  # the console script: bench/ is not on its sys.path
    proc = subprocess.run(
        [str(exe), "bench", "--only", "warp_drive"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert proc.returncode == 2 and "Traceback" not in proc.stderr, proc.stderr
    assert proc.stderr.startswith("mission: error: unknown benchmark 'warp_drive'; known: perception")


def test_the_report_of_other_results_is_written_beside_them_never_over_benchmarks_md(quick_run):
    results, _ = quick_run
    committed = (ROOT / "BENCHMARKS.md").read_bytes(), _digests(ROOT / "docs" / "bench")
    proc = subprocess.run(
        [sys.executable, "-m", "bench.report", str(results)],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.startswith(f"wrote {results / 'BENCHMARKS.md'} (")
    md = (results / "BENCHMARKS.md").read_text()
    assert "## perception" in md and "*quick run*" in md
    assert ((ROOT / "BENCHMARKS.md").read_bytes(), _digests(ROOT / "docs" / "bench")) == committed


def test_the_report_reads_the_committed_full_run_results_by_default(tmp_path):
    out = tmp_path / "BENCHMARKS.md"
    proc = subprocess.run(
        [sys.executable, "-m", "bench.report", "--out", str(out), "--docs", str(tmp_path / "docs")],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert proc.returncode == 0, proc.stderr
    md = out.read_text()
    for name in ("perception", "pose", "missions"):
        assert f"- Source: `bench/results/{name}.json`" in md
    assert "*quick run*" not in md  # no quick figure among the committed ones
