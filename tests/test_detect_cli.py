"""`mission detect IMAGE... --source NAME`: JSON and table output, per-file errors, exit codes."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest

from mission.cli import main
from mission.perception_plugins import synthetic_views as sv

MARKER = 0.2
ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def images(tmp_path_factory) -> tuple[list[Path], list[sv.SyntheticView]]:
    """Three consecutive frames of one slightly moving marker (id 7, 20 cm, ~1.5 m) as PNG files."""
    d = tmp_path_factory.mktemp("frames")
    views = sv.render_sequence(1.5, 30, 3, np.random.default_rng(11), marker_size_m=MARKER)
    paths = []
    for i, v in enumerate(views):
        p = d / f"frame_{i}.png"
        cv2.imwrite(str(p), v.image)
        paths.append(p)
    return paths, views


def _intrinsics_arg(view: sv.SyntheticView) -> str:
    k = view.intrinsics
    return f"{k.fx},{k.fy},{k.cx},{k.cy}"


def test_json_prints_one_object_per_image_with_the_pose(images, capsys):
    paths, views = images
    rc = main(["detect", *map(str, paths), "--json", "--set", f"marker_size_m={MARKER}",
               "--intrinsics", _intrinsics_arg(views[0])])
    out = [json.loads(line) for line in capsys.readouterr().out.splitlines()]
    assert rc == 0 and len(out) == 3
    for rec, path, view in zip(out, paths, views, strict=True):
        assert rec["image"] == str(path) and (rec["width"], rec["height"]) == (640, 480)
        [det] = rec["detections"]
        assert det["marker_id"] == 7 and det["source"] == "aruco"
        assert np.linalg.norm(np.array(det["position"]) - view.position) < 0.015
        assert det["extra"]["intrinsics"] == "calibrated"
    # One source instance saw the files in order, as consecutive frames of one marker track.
    assert [r["detections"][0]["extra"]["track_frames"] for r in out] == [1, 2, 3]


def test_without_json_a_readable_table(images, capsys):
    paths, views = images
    assert main(["detect", str(paths[0]), "--set", f"marker_size_m={MARKER}"]) == 0
    out = capsys.readouterr().out
    assert "1 detection" in out and "dist m" in out and "conf" in out
    row = next(line for line in out.splitlines() if line.split()[:1] == ["7"])
    assert float(row.split()[2]) == pytest.approx(views[0].distance, rel=0.03)
    assert "fallback pinhole" in out  # no --intrinsics given


def test_set_values_are_yaml(images, capsys):
    paths, _ = images
    assert main(["detect", str(paths[0]), "--json", "--set", "allowed_ids=[1, 2]"]) == 0
    assert json.loads(capsys.readouterr().out)["detections"] == []


def test_unreadable_files_are_reported_one_line_each_and_the_others_still_processed(images, tmp_path, capsys):
    paths, _ = images
    corrupt = tmp_path / "corrupt.png"
    corrupt.write_bytes(b"\x89PNG\r\n\x1a\n not really")
    missing = tmp_path / "missing.jpg"
    rc = main(["detect", str(missing), str(paths[0]), str(corrupt), "--json"])
    captured = capsys.readouterr()
    assert rc == 1
    assert [json.loads(line)["image"] for line in captured.out.splitlines()] == [str(paths[0])]
    err = captured.err.strip().splitlines()
    assert f"mission: error: {missing}: cannot read image (no such file)" in err
    assert f"mission: error: {corrupt}: cannot read image (not a decodable image)" in err


@pytest.mark.parametrize(("argv", "message"), [
    (["--intrinsics", "600,600,320"], "--intrinsics: expected four numbers fx,fy,cx,cy"),
    (["--intrinsics", "0,600,320,240"], "--intrinsics: expected four numbers"),
    (["--set", "marker_size_m=-0.1"], "--set marker_size_m: input should be greater than 0"),
    (["--set", "colour=red"], "--set colour: unknown key"),
    (["--set", "marker_sise_m=0.1"], "--set marker_sise_m: unknown key (did you mean marker_size_m?)"),
    (["--set", "oops"], "--set: expected KEY=VALUE"),
    (["--source", "nope"], "unknown perception plugin 'nope'; known plugins: "),
])  # fmt: skip
def test_usage_errors_are_one_line_and_exit_2(images, capsys, argv, message):
    paths, _ = images
    assert main(["detect", str(paths[0]), *argv]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    assert captured.err.count("\n") == 1 and message in captured.err


def test_installed_console_script(images):
    paths, views = images
    exe = Path(sys.executable).parent / "mission"
    proc = subprocess.run([str(exe), "detect", str(paths[0]), "--json", "--set", f"marker_size_m={MARKER}",
                           "--intrinsics", _intrinsics_arg(views[0])],
                          capture_output=True, text=True, timeout=60, cwd=ROOT)  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    [det] = json.loads(proc.stdout)["detections"]
    assert det["marker_id"] == 7
    assert proc.stderr == ""
