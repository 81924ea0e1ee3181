"""A real camera's imperfections on the simulation's ideal pinhole image (issue 33): lens distortion, the
calibration the detector is told (never exactly the lens), and motion blur over the exposure.

The renderer draws a perfect pinhole. A real lens bends straight lines (plumb-bob k1, k2, p1, p2, k3), a
real calibration is off by a percent or two, and a camera turning at 1 rad/s with 20 ms of exposure smears
a marker over ω · t · fx ≈ 8 px. Each effect is a key of the scenario's ``camera:`` section and is off by
default, so an ``ideal`` world stays exactly what it was.

* **Distortion.** For each pixel of the distorted image, where it comes from in the ideal one is OpenCV's
  ``undistortPoints`` (the plumb-bob model inverted). A barrel lens sees more than its pinhole would, so the
  ideal image is rendered with a wider field of view (and the same size), wide enough that every distorted
  pixel has a source; one ``remap`` then makes the lens's picture. Depth is remapped the same way, nearest.
* **Calibration.** The frame carries the intrinsics and distortion the detector is *told*: the true ones
  with a seeded error (``calibration_focal_pct``, ``calibration_center_px``, ``calibration_k1``), or no
  distortion at all for a lens nobody calibrated (``lens_calibrated: false``). The ground truth keeps the
  true camera.
* **Depth.** A stereo camera's error grows with the square of the distance (``depth_noise_pct_at_2m``: about
  2 % at 2 m for common models), and it has no depth where the scene jumps (``depth_edge_holes_m``).
* **Latency.** A frame reaches the robot ``latency_s`` (+ up to ``latency_jitter_s``) after its exposure and
  keeps the exposure's stamp, as a driver stamps it.
* **Light.** ``scene_brightness`` dims the scene and the gain lifts it back, noise included; with
  ``light_variation`` the scene is brighter facing the light, and the auto-exposure follows with
  ``auto_exposure_s`` of lag, so a fast turn toward the light over-exposes for a moment. ``jpeg_quality``
  compresses the image as a compressed topic delivers it.
* **Motion blur.** The image is averaged over the exposure along the smear the camera's own rotation makes:
  a yaw rate ω moves the image sideways by ω · t · fx pixels at the centre. The kernel is that line, with
  sub-pixel ends, so a 10 px smear looks like one; the render is the middle of the exposure (the frame's
  stamp), so the smear is centred on it. A marker also moves in the picture as the robot drives and the
  target walks: its neighbourhood is smeared along its own image motion (sim/marker_optics.py).
* **Glare.** With ``lighting.gloss`` the printed markers mirror the light where its reflection points at
  the camera (sim/marker_optics.py).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import cv2
import numpy as np

from mission.core.types import CameraIntrinsics
from mission.sim.marker_optics import Exposure, MarkerOptics
from mission.sim.scenario import CameraSpec

BORDER_MARGIN = 1.02  # the wider render's field of view, beyond what the distorted corners need


def has_effects(cam: CameraSpec) -> bool:
    """Whether the scenario asks for anything beyond the ideal pinhole."""
    return (
        any(v != 0.0 for v in cam.distortion)
        or cam.exposure_s > 0
        or cam.calibration_focal_pct > 0
        or cam.calibration_center_px > 0
        or cam.calibration_k1 > 0
        or cam.latency_s > 0
        or cam.latency_jitter_s > 0
        or cam.depth_noise_pct_at_2m > 0
        or cam.depth_edge_holes_m > 0
        or cam.scene_brightness != 1.0
        or cam.light_variation > 0
        or cam.jpeg_quality > 0
    )


class CameraModel:
    """The scenario camera's lens, calibration and exposure, applied to ideal renders (module doc)."""

    def __init__(
        self,
        cam: CameraSpec,
        true_k: CameraIntrinsics,
        seed: int,
        render_k: Callable[[CameraSpec], CameraIntrinsics],
    ) -> None:
        self.cam = cam
        self.true_k = true_k
        self.distortion = np.asarray(cam.distortion, dtype=np.float64)
        self.K = _matrix(true_k)
        self.render_spec = cam
        self.render_k = true_k
        self._maps: tuple[np.ndarray, np.ndarray] | None = None
        if np.any(self.distortion != 0.0):
            scale = self._render_scale()
            vfov = 2.0 * math.degrees(math.atan(math.tan(math.radians(cam.vfov_deg) / 2.0) * scale))
            self.render_spec = cam.model_copy(update={"vfov_deg": vfov})
            self.render_k = render_k(self.render_spec)
            self._maps = self._distortion_maps()
        rng = np.random.default_rng(np.random.SeedSequence([int(seed), 33]))
        self.told = self._told(rng)
        self._rng = rng  # per frame: depth noise, latency jitter (after the calibration's draws)
        self.gain = 1.0  # the auto-exposure's gain now: it multiplies the sensor noise too
        self._ae_light: float | None = None  # the light level the auto-exposure has adapted to
        self._ae_t = 0.0
        self.optics = MarkerOptics(self.K, self.distortion, cam.width, cam.height)

    # -- set-up ----------------------------------------------------------------------------------------
    def _border_pixels(self) -> np.ndarray:
        w, h = self.cam.width, self.cam.height
        xs, ys = np.linspace(0, w - 1, 64), np.linspace(0, h - 1, 48)
        border = [(x, 0) for x in xs] + [(x, h - 1) for x in xs] + [(0, y) for y in ys] + [(w - 1, y) for y in ys]
        return np.asarray(border, dtype=np.float64)

    def _ideal_normalized(self, pixels: np.ndarray) -> np.ndarray:
        """Where distorted pixels look, as ideal normalized image coordinates (x/z, y/z)."""
        pts = cv2.undistortPoints(pixels.reshape(-1, 1, 2), self.K, self.distortion)
        return pts.reshape(-1, 2)

    def _render_scale(self) -> float:
        """How much wider than the pinhole the ideal render must look so every distorted pixel has a source."""
        k = self.true_k
        n = self._ideal_normalized(self._border_pixels())
        reach = max(
            float(np.max(np.abs(n[:, 0]))) * k.fx / max(k.cx, k.width - k.cx),
            float(np.max(np.abs(n[:, 1]))) * k.fy / max(k.cy, k.height - k.cy),
        )
        return max(1.0, reach) * BORDER_MARGIN

    def _distortion_maps(self) -> tuple[np.ndarray, np.ndarray]:
        w, h = self.cam.width, self.cam.height
        u, v = np.meshgrid(np.arange(w, dtype=np.float64), np.arange(h, dtype=np.float64))
        n = self._ideal_normalized(np.column_stack([u.ravel(), v.ravel()]))
        rk = self.render_k
        map_x = (n[:, 0] * rk.fx + rk.cx).reshape(h, w).astype(np.float32)
        map_y = (n[:, 1] * rk.fy + rk.cy).reshape(h, w).astype(np.float32)
        return map_x, map_y

    def _told(self, rng: np.random.Generator) -> CameraIntrinsics:
        """The calibration the detector gets: the true camera with the scenario's seeded error."""
        c, k = self.cam, self.true_k
        focal = 1.0 + rng.normal(0.0, c.calibration_focal_pct / 100.0) if c.calibration_focal_pct > 0 else 1.0
        dcx, dcy = rng.normal(0.0, c.calibration_center_px, 2) if c.calibration_center_px > 0 else (0.0, 0.0)
        dist = self.distortion.copy() if c.lens_calibrated else np.zeros(5)  # uncorrected: told a pinhole
        if c.calibration_k1 > 0:
            dist[0] += rng.normal(0.0, c.calibration_k1)
        return CameraIntrinsics(
            fx=k.fx * focal,
            fy=k.fy * focal,
            cx=k.cx + float(dcx),
            cy=k.cy + float(dcy),
            width=k.width,
            height=k.height,
            distortion=tuple(float(v) for v in dist) if np.any(dist != 0.0) else (),
        )

    # -- every frame ---------------------------------------------------------------------------------
    def apply(
        self, image: np.ndarray, depth: np.ndarray | None, yaw_rate: float, exposure: Exposure | None = None
    ) -> tuple[np.ndarray, np.ndarray | None]:
        """The lens's picture of an ideal render (made with :attr:`render_spec`): glare on glossy markers,
        blurred by the rotation, each marker by its own motion over the `exposure` too."""
        if self._maps is not None:
            map_x, map_y = self._maps
            image = cv2.remap(image, map_x, map_y, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
            if depth is not None:
                depth = cv2.remap(depth, map_x, map_y, cv2.INTER_NEAREST, borderMode=cv2.BORDER_REPLICATE)
        if depth is not None:
            depth = self.depth_errors(depth)
        if exposure is not None:
            self.optics.glare(image, exposure)
        sharp = image
        length = self.smear_px(yaw_rate)
        if length > 0.5:
            kernel = smear_kernel(length)
            centre = round(float((kernel[0] * np.arange(kernel.shape[1])).sum()))  # centred within ½ px
            image = cv2.filter2D(image, -1, kernel, anchor=(centre, 0), borderType=cv2.BORDER_REPLICATE)
        if exposure is not None and self.cam.exposure_s > 0:
            if image is sharp:
                image = sharp.copy()
            self.optics.smear(sharp, image, exposure, length)
        return image, depth

    def depth_errors(self, depth: np.ndarray) -> np.ndarray:
        """A stereo camera's depth: noise with σ ∝ distance² (so many % at 2 m), no depth across edges."""
        c = self.cam
        if c.depth_noise_pct_at_2m <= 0 and c.depth_edge_holes_m <= 0:
            return depth
        z = depth.astype(np.float32, copy=True)
        if c.depth_noise_pct_at_2m > 0:
            sigma = (c.depth_noise_pct_at_2m / 100.0) * 2.0 * (z / 2.0) ** 2
            z = z + self._rng.standard_normal(z.shape, dtype=np.float32) * np.nan_to_num(sigma)
        if c.depth_edge_holes_m > 0:
            jump = np.zeros(z.shape, dtype=bool)
            finite = np.nan_to_num(depth, nan=1e6, posinf=1e6)  # no return: far (finite, so no inf - inf warnings)
            dx = np.abs(np.diff(finite, axis=1)) > c.depth_edge_holes_m
            dy = np.abs(np.diff(finite, axis=0)) > c.depth_edge_holes_m
            jump[:, 1:] |= dx
            jump[:, :-1] |= dx
            jump[1:, :] |= dy
            jump[:-1, :] |= dy
            z[jump] = np.nan
        return z

    def delay(self) -> float:
        """How long after its exposure this frame reaches the robot (s)."""
        c = self.cam
        jitter = float(self._rng.uniform(0.0, c.latency_jitter_s)) if c.latency_jitter_s > 0 else 0.0
        return c.latency_s + jitter

    def light_level(self, heading: float, light_direction: tuple[float, float, float]) -> float:
        """The scene's brightness for a camera facing `heading` (map yaw): brighter toward the light."""
        lx, ly = light_direction[0], light_direction[1]
        toward = math.cos(heading - math.atan2(ly, lx)) if (lx or ly) else 0.0
        return self.cam.scene_brightness * (1.0 + self.cam.light_variation * toward)

    def expose(self, image: np.ndarray, light: float, t: float) -> np.ndarray:
        """The picture at the gain the auto-exposure has reached: a camera that turns toward the light is
        over-exposed for a moment, a dim scene is lifted by gain (and its noise with it, :attr:`gain`)."""
        c = self.cam
        if self._ae_light is None or c.auto_exposure_s <= 0:
            self._ae_light = light
        else:
            alpha = 1.0 - math.exp(-max(0.0, t - self._ae_t) / c.auto_exposure_s)
            self._ae_light += alpha * (light - self._ae_light)
        self._ae_t = t
        # the auto-exposure aims the scene at mid-grey: gain 1 / (what it adapted to), capped as a sensor's is
        self.gain = min(8.0, 1.0 / max(self._ae_light, 1e-3))
        scale = light * self.gain
        if abs(scale - 1.0) < 1e-6:
            return image
        return cv2.convertScaleAbs(image, alpha=scale)

    def compress(self, image: np.ndarray) -> np.ndarray:
        """JPEG at the camera's quality, as a compressed image topic delivers it."""
        if self.cam.jpeg_quality <= 0:
            return image
        ok, buf = cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, int(self.cam.jpeg_quality)])
        return cv2.imdecode(buf, cv2.IMREAD_UNCHANGED) if ok else image

    def smear_px(self, yaw_rate: float) -> float:
        """How far the image moves during one exposure when the camera turns at `yaw_rate` (rad/s)."""
        return abs(float(yaw_rate)) * self.cam.exposure_s * self.true_k.fx


def smear_kernel(length: float) -> np.ndarray:
    """A horizontal line kernel `length` px long (sub-pixel ends), summing to 1: a uniform smear."""
    n = math.ceil(length) + 1
    k = np.ones(n, dtype=np.float32)
    frac = length - math.floor(length)
    if frac > 0:
        k[-1] = frac  # the last pixel is covered part of the exposure
    else:
        k = k[:-1]
    return (k / k.sum()).reshape(1, -1)


def _matrix(k: CameraIntrinsics) -> np.ndarray:
    return np.array([[k.fx, 0.0, k.cx], [0.0, k.fy, k.cy], [0.0, 0.0, 1.0]])
