"""`mission run --record out.gif|out.mp4`: the camera view with detections beside the top-down map, under a
banner with the mission state, sim time, target distance and the active branch.

Frames are taken every 1/fps seconds of *simulated* time, so a recording plays at the run's own speed
whatever the machine. MP4 (H.264, via imageio-ffmpeg) streams to disk; GIF keeps frames in memory as
palette images (≈ W×H bytes each) and, past `max_frames`, drops every other frame and halves the frame
rate — a long run still fits, and still spans the whole run.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from functools import lru_cache
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from mission.core import blackboard as bbk
from mission.core.errors import MissionError
from mission.core.files import atomic_path, ensure_parent, unwritable
from mission.core.observers import RunObserver, Tick
from mission.viz.overlay import draw_detections
from mission.viz.style import STATE_COLOURS
from mission.viz.topdown import MapView, annotate_scale

BANNER_H = 40
FORMATS = (".gif", ".mp4")


@lru_cache(maxsize=4)
def _font(size: int, bold: bool = False) -> Any:
    from matplotlib import font_manager
    from PIL import ImageFont

    props = font_manager.FontProperties(family="DejaVu Sans", weight="bold" if bold else "normal")
    return ImageFont.truetype(font_manager.findfont(props, fallback_to_default=True), size)


def banner(width: int, state: str, fields: list[str], branch: str) -> np.ndarray:
    """The strip above a frame: a state pill, then facts, then the active branch (BGR)."""
    from PIL import Image, ImageDraw

    img = Image.new("RGB", (width, BANNER_H), (31, 38, 51))
    draw = ImageDraw.Draw(img)
    colour = STATE_COLOURS.get(state, "#5f6368")
    label = state or "—"
    f_bold, f_text = _font(15, True), _font(13)
    tw = draw.textlength(label, font=f_bold)
    pill_w = max(84, int(tw) + 24)
    draw.rounded_rectangle((8, 8, 8 + pill_w, BANNER_H - 8), radius=12, fill=colour)
    draw.text((8 + (pill_w - tw) / 2, 11), label, font=f_bold, fill=(255, 255, 255))
    x = 20 + pill_w
    for text in fields:
        draw.text((x, 12), text, font=f_text, fill=(232, 234, 237))
        x += int(draw.textlength(text, font=f_text)) + 18
    if branch and x < width - 40:
        avail = width - x - 10
        while branch and draw.textlength(branch, font=f_text) > avail:
            branch = "…" + branch[2:]
        draw.text((x, 12), branch, font=f_text, fill=(154, 164, 178))
    return cv2.cvtColor(np.asarray(img), cv2.COLOR_RGB2BGR)


def compose(
    camera: np.ndarray | None, map_img: np.ndarray, height: int, top: Callable[[int], np.ndarray] | None = None
) -> np.ndarray:
    """Camera (scaled to `height`) | map (scaled to `height`), with `top(width)` above them; BGR, even sizes."""
    if camera is None:
        cam = np.full((height, round(height * 4 / 3), 3), 40, np.uint8)
        cv2.putText(
            cam, "no camera image", (20, height // 2), cv2.FONT_HERSHEY_SIMPLEX, 0.6, (200, 200, 200), 1, cv2.LINE_AA
        )
    else:
        h, w = camera.shape[:2]
        cam = cv2.resize(camera, (max(2, round(w * height / h)), height), interpolation=cv2.INTER_AREA)
    mh, mw = map_img.shape[:2]
    scale = height / mh
    mp = cv2.resize(map_img, (max(2, round(mw * scale)), height), interpolation=cv2.INTER_AREA)
    gap = np.full((height, 4, 3), 31, np.uint8)
    body = np.hstack([cam, gap, mp])
    if top is not None:
        body = np.vstack([top(body.shape[1]), body])
    h, w = body.shape[:2]
    return body[: h - h % 2, : w - w % 2]  # H.264 wants even sizes


class Recorder(RunObserver):
    """A run observer writing the run to a GIF or MP4 at `fps` frames per simulated second."""

    def __init__(self, path: str | Path, fps: float = 5.0, height: int = 300, max_frames: int = 600) -> None:
        self.path = Path(path)
        if self.path.suffix.lower() not in FORMATS:
            raise MissionError(f"--record {self.path}: expected a .gif or .mp4 file name")
        try:  # fail before the (slow) simulation starts when the file cannot be written
            ensure_parent(self.path)
            with open(self.path, "ab"):
                pass
        except OSError as err:
            raise MissionError(f"--record {self.path}: {unwritable(err, self.path)}") from None
        self.fps = float(fps)
        self.height = int(height)
        self.max_frames = int(max_frames)
        self.frames: list[Any] = []  # GIF: palette images
        self.frame_count = 0
        self._stride = 1  # GIF decimation: keep every `stride`-th due frame
        self._due_index = 0
        self._next_t: float | None = None
        self._writer: Any = None
        self._view: MapView | None = None
        self._robot_trail: list[tuple[float, float]] = []
        self._target_trail: list[tuple[float, float]] = []

    @property
    def is_gif(self) -> bool:
        return self.path.suffix.lower() == ".gif"

    def on_start(self, runner: Any) -> None:
        adapter = runner.world
        grid = getattr(adapter, "occupancy_grid", None) or runner.get(bbk.MAP)
        self._view = MapView(grid, size=self.height)
        if not self.is_gif:
            import imageio.v2 as iio

            try:
                self._writer = iio.get_writer(
                    str(self.path),
                    format="FFMPEG",
                    mode="I",
                    fps=self.fps,
                    codec="libx264",
                    quality=7,
                    pixelformat="yuv420p",
                    macro_block_size=2,
                    ffmpeg_log_level="error",
                )
            except Exception as err:  # imageio-ffmpeg missing or broken
                raise MissionError(f"--record {self.path}: cannot write MP4 ({err}); record a .gif instead") from err

    def on_tick(self, runner: Any, tick: Tick) -> None:
        ground_truth = tick.ground_truth
        t = float(getattr(ground_truth, "stamp", None) or runner.get(bbk.CLOCK, 0.0) or 0.0)
        robot, target = self._poses(runner, ground_truth)
        if robot is not None:
            self._robot_trail.append((robot[0], robot[1]))
        if target is not None:
            self._target_trail.append((target[0], target[1]))
        if self._next_t is not None and t + 1e-9 < self._next_t:
            return
        self._next_t = (t if self._next_t is None else self._next_t) + 1.0 / self.fps
        if self._next_t <= t:  # a long gap between ticks: restart the frame clock
            self._next_t = t + 1.0 / self.fps
        self._due_index += 1
        if self.is_gif and (self._due_index - 1) % self._stride:
            return
        self._add(self.frame(runner, ground_truth, t, robot, target))

    def _poses(self, runner: Any, gt: Any) -> tuple[tuple[float, float, float] | None, ...]:
        """Robot and target (x, y, yaw): ground truth when simulated, else the robot's own estimate."""
        robot = getattr(gt, "robot", None)
        if robot is None:
            robot = getattr(runner.get(bbk.ROBOT_STATE), "pose", None)
        target = getattr(gt, "target", None)
        return tuple(None if p is None else (p.x, p.y, p.yaw) for p in (robot, target))

    def frame(self, runner: Any, gt: Any, t: float, robot: Any, target: Any) -> np.ndarray:
        """One composed BGR frame for the current tick."""
        fr = runner.get(bbk.FRAME)
        camera = None
        if fr is not None:
            camera = draw_detections(fr.image, runner.get(bbk.DETECTIONS, []) or [], getattr(fr, "intrinsics", None))
        goal = runner.get(bbk.NAV_GOAL)
        goal_p = None if goal is None else (goal.pose.x, goal.pose.y, goal.pose.yaw)
        estimates = []
        for tr in (runner.get(bbk.TRACKS, {}) or {}).values():
            pm = getattr(tr, "pose_map", None)
            if pm is not None:
                estimates.append((float(pm[0][3]), float(pm[1][3])))
        assert self._view is not None
        map_img = self._view.draw(
            robot, target, goal_p, self._robot_trail[-2000:], self._target_trail[-2000:], estimates
        )
        annotate_scale(map_img, self._view)
        fields = [f"t = {t:.1f} s"]
        if robot is not None and target is not None:
            fields.append(f"target {math.hypot(target[0] - robot[0], target[1] - robot[1]):4.1f} m")
        branch = " › ".join(runner.active_branch()[-3:]) if hasattr(runner, "active_branch") else ""
        state = runner.get(bbk.STATE, "") or ""
        return compose(camera, map_img, self.height, lambda width: banner(width, state, fields, branch))

    def _add(self, bgr: np.ndarray) -> None:
        rgb = cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB)
        self.frame_count += 1
        if not self.is_gif:
            self._writer.append_data(rgb)
            return
        from PIL import Image

        self.frames.append(Image.fromarray(rgb).quantize(colors=255, method=Image.Quantize.FASTOCTREE))
        if len(self.frames) > self.max_frames:  # keep the whole run: every other frame, half the rate
            self.frames = self.frames[::2]
            self._stride *= 2

    def on_end(self, runner: Any, outcome: Any) -> None:
        self.close()

    def close(self) -> None:
        if self._writer is not None:
            self._writer.close()
            self._writer = None
        if self.is_gif and self.frames:
            duration_ms = round(1000.0 * self._stride / self.fps)
            with atomic_path(self.path) as tmp:
                self.frames[0].save(
                    tmp,
                    format="GIF",
                    save_all=True,
                    append_images=self.frames[1:],
                    duration=duration_ms,
                    loop=0,
                    optimize=False,
                    disposal=1,
                )
            self.frames = []
