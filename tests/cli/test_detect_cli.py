"""`mission detect IMAGE... --source NAME`: JSON and table output, per-file errors, exit codes."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest

from mission.cli import main
from tools import synthetic_views as sv

MARKER = 0.2
ROOT = Path(__file__).resolve().parents[2]


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
    rc = main(
        [
            "detect",
            *map(str, paths),
            "--json",
            "--set",
            f"marker_size_m={MARKER}",
            "--intrinsics",
            _intrinsics_arg(views[0]),
        ]
    )
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


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--intrinsics", "600,600,320"], "--intrinsics: expected four numbers fx,fy,cx,cy"),
        (["--intrinsics", "0,600,320,240"], "--intrinsics: expected four numbers"),
        (["--set", "marker_size_m=-0.1"], "--set marker_size_m: input should be greater than 0"),
        (["--set", "colour=red"], "--set colour: unknown key"),
        (["--set", "marker_sise_m=0.1"], "--set marker_sise_m: unknown key (did you mean marker_size_m?)"),
        (["--set", "oops"], "--set: expected KEY=VALUE"),
        (["--source", "nope"], "unknown perception plugin 'nope'; known plugins: "),
    ],
)
def test_usage_errors_are_one_line_and_exit_2(images, capsys, argv, message):
    paths, _ = images
    assert main(["detect", str(paths[0]), *argv]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    assert captured.err.count("\n") == 1 and message in captured.err


def test_installed_console_script(images):
    paths, views = images
    exe = Path(sys.executable).parent / "mission"
    proc = subprocess.run(
        [
            str(exe),
            "detect",
            str(paths[0]),
            "--json",
            "--set",
            f"marker_size_m={MARKER}",
            "--intrinsics",
            _intrinsics_arg(views[0]),
        ],
        capture_output=True,
        text=True,
        timeout=60,
        cwd=ROOT,
    )
    assert proc.returncode == 0, proc.stderr
    [det] = json.loads(proc.stdout)["detections"]
    assert det["marker_id"] == 7
    assert proc.stderr == ""


# -- calibration files, and sources that need depth ---------------------------------------------------------


def test_a_calibration_file_gives_the_pose_the_intrinsics_would(images, tmp_path, capsys):
    paths, views = images
    k = views[0].intrinsics
    fs = cv2.FileStorage(str(tmp_path / "cam.yml"), cv2.FILE_STORAGE_WRITE)  # OpenCV's own calibration format
    fs.write("image_width", k.width)
    fs.write("image_height", k.height)
    fs.write("camera_matrix", k.matrix)
    fs.write("distortion_coefficients", np.zeros((1, 5)))
    fs.release()
    assert (
        main(
            [
                "detect",
                str(paths[0]),
                "--calibration",
                str(tmp_path / "cam.yml"),
                "--set",
                f"marker_size_m={MARKER}",
                "--json",
            ]
        )
        == 0
    )
    (det,) = json.loads(capsys.readouterr().out)["detections"]
    assert det["extra"]["intrinsics"] == "calibrated"
    assert np.linalg.norm(np.asarray(det["position"]) - views[0].position) < 0.02


def test_a_calibration_for_another_image_size_is_an_error_for_that_image(images, tmp_path, capsys):
    paths, _ = images
    (tmp_path / "cam.yaml").write_text(
        "image_width: 1280\nimage_height: 720\ncamera_matrix: {rows: 3, cols: 3, "
        "data: [900, 0, 640, 0, 900, 360, 0, 0, 1]}\n"
    )
    assert main(["detect", str(paths[0]), "--calibration", str(tmp_path / "cam.yaml")]) == 1
    err = capsys.readouterr().err
    assert "calibrated for 1280×720, the image is 640×480" in err and str(paths[0]) in err


def test_the_vlm_says_it_needs_depth_instead_of_finding_nothing(tmp_path):
    from tests.helpers.vlm_scene import Box, Scene, camera_pose, render

    frame = render(Scene(boxes=[Box((3.0, 0.2, 0.3), (0.4, 0.4, 0.6), (20, 20, 200))]), camera_pose(0, 0, 0))
    image = tmp_path / "red_box.png"
    cv2.imwrite(str(image), frame.image)
    for source in ("vlm", "vlm_stub"):
        proc = subprocess.run(
            [sys.executable, "-m", "mission", "detect", str(image), "--source", source],
            capture_output=True,
            text=True,
            timeout=60,
            cwd=ROOT,
        )
        assert proc.returncode == 2 and proc.stdout == ""
        assert f"--source {source} needs a depth image" in proc.stderr and "--depth FILE" in proc.stderr

    depth = tmp_path / "red_box_depth.png"
    cv2.imwrite(str(depth), np.nan_to_num(frame.depth * 1000.0).astype(np.uint16))  # 16-bit millimetres
    k = frame.intrinsics
    cmd = [
        sys.executable,
        "-m",
        "mission",
        "detect",
        str(image),
        "--source",
        "vlm_stub",
        "--depth",
        str(depth),
        "--intrinsics",
        f"{k.fx},{k.fy},{k.cx},{k.cy}",
        "--set",
        f"state_file={tmp_path / 'quota.json'}",
        "--set",
        "latency_s=0.05",
        "--json",
    ]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=120, cwd=ROOT)
    assert proc.returncode == 0, proc.stderr
    (det,) = json.loads(proc.stdout)["detections"]
    assert det["label"] == "red box" and abs(det["position"][2] - 2.8) < 0.15  # the box's front face, 2.8 m ahead


def test_a_depth_image_of_another_size_or_count_is_refused(images, tmp_path, capsys):
    paths, _ = images
    small = tmp_path / "small_depth.png"
    cv2.imwrite(str(small), np.full((10, 10), 1500, np.uint16))
    assert main(["detect", str(paths[0]), "--depth", str(small)]) == 1
    assert "depth" in capsys.readouterr().err
    assert main(["detect", str(paths[0]), str(paths[1]), "--depth", str(small)]) == 2
    assert "--depth: 1 depth image(s) for 2 image(s)" in capsys.readouterr().err


def test_the_vlm_stub_answers_every_image_of_one_command_and_of_the_next(tmp_path):
    """Images given to `mission detect` are requests, not a stream: no pacing between them, and the stub (no
    service counting its calls) keeps no budget from one command to the next."""
    from tests.helpers.vlm_scene import Box, Scene, camera_pose, render

    frame = render(Scene(boxes=[Box((3.0, 0.2, 0.3), (0.4, 0.4, 0.6), (20, 20, 200))]), camera_pose(0, 0, 0))
    image, depth = tmp_path / "red_box.png", tmp_path / "red_box_depth.png"
    cv2.imwrite(str(image), frame.image)
    cv2.imwrite(str(depth), np.nan_to_num(frame.depth * 1000.0).astype(np.uint16))
    k = frame.intrinsics
    cmd = [sys.executable, "-m", "mission", "detect", "--source", "vlm", "--json", "--set", "latency_s=0.05"]
    cmd += ["--set", "miss_rate=0"]  # the stub imitates a model that misses now and then: not here
    cmd += ["--intrinsics", f"{k.fx},{k.fy},{k.cx},{k.cy}", *[str(image)] * 3, *["--depth", str(depth)] * 3]
    env = {**os.environ, "XDG_CACHE_HOME": str(tmp_path / "cache")}  # the user's cache, fresh
    for _ in range(2):
        proc = subprocess.run(cmd, capture_output=True, text=True, timeout=120, cwd=ROOT, env=env)
        assert proc.returncode == 0, proc.stderr
        assert "rate limited" not in proc.stderr
        answers = [json.loads(line)["detections"] for line in proc.stdout.splitlines()]
        assert len(answers) == 3 and all(a and a[0]["label"] == "red box" for a in answers), answers
