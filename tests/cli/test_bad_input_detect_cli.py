"""Bad files given to `mission detect`: each is one stderr line naming the file and why, the other files
are still processed, and the exit code is 1 (issue 9, bad-input matrix: the detect CLI).

Already covered in test_detect_cli.py: a missing file, a file with a PNG signature and garbage after it,
bad --intrinsics / --set values and an unknown --source.
"""

from __future__ import annotations

import json
import struct
import zlib
from pathlib import Path

import cv2
import numpy as np
import pytest

from mission.cli import main
from tools import synthetic_views as sv

MARKER = 0.2


@pytest.fixture(scope="module")
def view() -> sv.SyntheticView:
    """One rendered 4×4 marker (id 7, 20 cm) about 1.2 m from the camera."""
    rng = np.random.default_rng(21)
    return sv.render_marker_view(sv.random_pose(1.2, 20, rng), rng=rng, marker_size_m=MARKER)


@pytest.fixture(scope="module")
def good(view, tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("good") / "good.png"
    cv2.imwrite(str(path), view.image)
    return path


def _png_claiming(width: int, height: int) -> bytes:
    """A well-formed PNG header for a `width`×`height` grey image with almost no pixel data behind it."""

    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)

    ihdr = struct.pack(">IIBBBBB", width, height, 8, 0, 0, 0, 0)
    idat = zlib.compress(b"\x00" * 64)
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", idat) + chunk(b"IEND", b"")


def _bad_files(directory: Path, good: Path) -> dict[str, tuple[Path, str]]:
    """name → (path, the reason the error line gives)."""
    png = good.read_bytes()
    ok, jpg = cv2.imencode(".jpg", cv2.imread(str(good)))
    assert ok
    files = {
        "empty": (b"", "cannot read image (empty file)"),
        "truncated png": (png[: len(png) // 2], "cannot read image (not a decodable image)"),
        "truncated jpeg": (jpg.tobytes()[:200], "cannot read image (not a decodable image)"),
        "text file": (b"marker id 7 at 1.2 m\n", "cannot read image (not a decodable image)"),
        "decompression bomb": (
            _png_claiming(60000, 60000),
            "cannot read image (not a decodable image: larger than OpenCV's pixel limit)",
        ),
    }
    out = {}
    for name, (data, why) in files.items():
        path = directory / (name.replace(" ", "_") + (".jpg" if "jpeg" in name else ".png"))
        path.write_bytes(data)
        out[name] = (path, why)
    folder = directory / "folder.png"
    folder.mkdir()
    out["a directory"] = (folder, "cannot read image (not a file)")
    return out


@pytest.mark.parametrize(
    "case", ["empty", "truncated png", "truncated jpeg", "text file", "decompression bomb", "a directory"]
)
def test_a_bad_file_is_one_stderr_line_naming_it_and_the_good_file_after_it_is_still_detected(
    case, good, tmp_path, capfd
):
    path, why = _bad_files(tmp_path, good)[case]
    rc = main(["detect", str(path), str(good), "--json", "--set", f"marker_size_m={MARKER}"])
    out, err = capfd.readouterr()  # file-descriptor level: a C library printing to fd 2 would show up here
    assert rc == 1
    [record] = [json.loads(line) for line in out.splitlines()]
    assert record["image"] == str(good) and record["detections"][0]["marker_id"] == 7
    errors = [line for line in err.splitlines() if line.startswith("mission: error:")]
    assert errors == [f"mission: error: {path}: {why}"]
    # nothing else on stderr but the fallback-intrinsics note (no libpng / libjpeg chatter, no traceback)
    others = [line for line in err.splitlines() if line not in errors]
    assert all("fallback pinhole" in line for line in others), others


@pytest.mark.parametrize(
    ("kind", "convert"),
    [
        ("16-bit", lambda img: img.astype(np.uint16) * 257),
        ("4-channel BGRA", lambda img: cv2.cvtColor(img, cv2.COLOR_BGR2BGRA)),
        ("single-channel", lambda img: cv2.cvtColor(img, cv2.COLOR_BGR2GRAY)),
    ],
)
def test_16_bit_4_channel_and_mono_files_are_read_like_the_8_bit_colour_one(
    kind, convert, view, good, tmp_path, capsys
):
    path = tmp_path / "other.png"
    assert cv2.imwrite(str(path), convert(view.image))
    k = view.intrinsics
    argv = ["--json", "--set", f"marker_size_m={MARKER}", "--intrinsics", f"{k.fx},{k.fy},{k.cx},{k.cy}"]
    assert main(["detect", str(good), *argv]) == 0
    reference = json.loads(capsys.readouterr().out)["detections"][0]
    assert main(["detect", str(path), *argv]) == 0
    [det] = json.loads(capsys.readouterr().out)["detections"]
    assert det["marker_id"] == 7
    assert np.allclose(det["position"], reference["position"], atol=2e-3), kind


def test_an_image_too_small_to_hold_a_marker_names_its_size(tmp_path, good, capsys):
    tiny = tmp_path / "tiny.png"
    cv2.imwrite(str(tiny), np.zeros((3, 5, 3), np.uint8))
    assert main(["detect", str(tiny), str(good), "--json"]) == 1
    captured = capsys.readouterr()
    assert captured.err.strip() == f"mission: error: {tiny}: image 5×3 is too small to hold a marker"
    assert len(captured.out.splitlines()) == 1
