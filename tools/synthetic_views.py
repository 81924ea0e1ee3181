"""Synthetic camera views of one square fiducial with a known pose: ground truth for tests and benchmarks.

A marker image (``cv2.aruco.generateImageMarker`` plus a white quiet zone of one cell) is projected into a
pinhole camera by the exact homography of the plane, composited on a textured background, blurred and
given sensor noise. Because the pose is chosen first, every image comes with its true camera-from-marker
transform and the true corner pixels.

Rendering is anti-aliased: the marker's region is drawn at ``supersample``× resolution and averaged down
(``INTER_AREA``), with the pixel-centre convention of OpenCV (pixel k spans [k − ½, k + ½]), so a detector
that finds corners without bias recovers them to a small fraction of a pixel. Without this, aliasing of
``warpPerspective`` alone adds ~0.3 px of corner error that no real camera has.

Conventions (see mission.core.types): camera optical frame x right, y down, z forward; marker frame x
right, y up, z out of the face (OpenCV ArUco), so a marker facing the camera squarely has rotation
``diag(1, -1, -1)``. The marker's side length is the black square's side, as ArUco defines it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from mission.core import se3
from mission.core.types import CameraIntrinsics

# A marker squarely facing the camera: marker x = camera x, marker y = −camera y, marker z = −camera z.
R_FRONTAL = np.diag([1.0, -1.0, -1.0])


def default_intrinsics(width: int = 640, height: int = 480, vfov_deg: float = 45.0) -> CameraIntrinsics:
    """The test camera: square pixels, 45° vertical field of view (fx = fy ≈ 579 px at 640×480)."""
    return CameraIntrinsics.from_vertical_fov(width, height, vfov_deg)


@dataclass
class SyntheticView:
    """One rendered image and the truth it was rendered from."""

    image: np.ndarray  # H×W×3 uint8 BGR
    intrinsics: CameraIntrinsics
    T_cam_marker: np.ndarray  # 4×4, camera optical frame ← marker frame
    marker_id: int
    marker_size_m: float
    corners: np.ndarray  # 4×2 true corner pixels, TL TR BR BL (as ArUco orders them)

    @property
    def position(self) -> np.ndarray:
        return self.T_cam_marker[:3, 3].copy()

    @property
    def rotation(self) -> np.ndarray:
        return self.T_cam_marker[:3, :3].copy()

    @property
    def distance(self) -> float:
        return float(np.linalg.norm(self.T_cam_marker[:3, 3]))


def marker_corners_3d(marker_size_m: float) -> np.ndarray:
    """The black square's corners in the marker frame, TL TR BR BL (the order ArUco reports)."""
    h = marker_size_m / 2.0
    return np.array([[-h, h, 0.0], [h, h, 0.0], [h, -h, 0.0], [-h, -h, 0.0]])


def off_axis_angle(T_cam_marker: np.ndarray) -> float:
    """Angle (rad) between the marker's face normal and the direction from the marker to the camera."""
    t = T_cam_marker[:3, 3]
    to_cam = -t / np.linalg.norm(t)
    return math.acos(float(np.clip(T_cam_marker[:3, 2] @ to_cam, -1.0, 1.0)))


def pose_facing_camera(position: np.ndarray, tilt_axis_angle: float, tilt: float, roll: float) -> np.ndarray:
    """T_cam_marker at `position` whose face normal is `tilt` rad off the line of sight to the camera.

    The marker first faces the camera exactly along the viewing ray, is rolled by `roll` about that ray,
    then tilted by `tilt` about an axis perpendicular to the ray at angle `tilt_axis_angle`.
    """
    p = np.asarray(position, dtype=np.float64)
    z = -p / np.linalg.norm(p)  # marker normal towards the camera
    # Rotate the frontal orientation so its z axis (−camera z) lands on the viewing ray's reverse.
    r_align = _rotation_between(R_FRONTAL[:, 2], z)
    r0 = r_align @ R_FRONTAL
    roll_r = se3.rvec_to_matrix(z * roll)
    axis = r0 @ np.array([math.cos(tilt_axis_angle), math.sin(tilt_axis_angle), 0.0])
    tilt_r = se3.rvec_to_matrix(axis * tilt)
    return se3.transform(tilt_r @ roll_r @ r0, p)


def _rotation_between(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The smallest rotation taking unit vector a onto unit vector b."""
    a = a / np.linalg.norm(a)
    b = b / np.linalg.norm(b)
    axis = np.cross(a, b)
    s = float(np.linalg.norm(axis))
    c = float(a @ b)
    if s < 1e-12:
        if c > 0:
            return np.eye(3)
        perp = np.array([1.0, 0.0, 0.0]) if abs(a[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
        perp -= a * (perp @ a)
        return se3.rvec_to_matrix(perp / np.linalg.norm(perp) * math.pi)
    return se3.rvec_to_matrix(axis / s * math.atan2(s, c))


def random_pose(
    distance_m: float,
    max_off_axis_deg: float,
    rng: np.random.Generator,
    intrinsics: CameraIntrinsics | None = None,
    marker_size_m: float = 0.2,
    margin_px: float = 12.0,
) -> np.ndarray:
    """A random T_cam_marker at range `distance_m`, ≤ `max_off_axis_deg` off axis, fully inside the image.

    The marker centre is placed anywhere in the image where the whole marker (plus `margin_px`) fits; the
    off-axis angle is drawn uniformly in [0, max], its direction and the in-plane roll uniformly.
    """
    k = intrinsics or default_intrinsics()
    corners3d = marker_corners_3d(marker_size_m)
    for _ in range(200):
        u = rng.uniform(margin_px, k.width - margin_px)
        v = rng.uniform(margin_px, k.height - margin_px)
        ray = np.array([(u - k.cx) / k.fx, (v - k.cy) / k.fy, 1.0])
        pos = ray / np.linalg.norm(ray) * distance_m
        t = pose_facing_camera(
            pos,
            tilt_axis_angle=rng.uniform(0, 2 * math.pi),
            tilt=math.radians(rng.uniform(0.0, max_off_axis_deg)),
            roll=rng.uniform(-math.pi, math.pi),
        )
        px = k.project(se3.apply(t, corners3d * 1.25))  # the quiet zone must fit too
        if (
            (px.min(axis=0) >= margin_px).all()
            and (px[:, 0] <= k.width - margin_px).all()
            and (px[:, 1] <= k.height - margin_px).all()
        ):
            return t
    raise ValueError(f"a {marker_size_m} m marker at {distance_m} m does not fit in a {k.width}×{k.height} image")


def _background(rng: np.random.Generator, width: int, height: int) -> np.ndarray:
    """A smooth random texture with a brightness gradient (float32, grey levels 0..255)."""
    coarse = rng.uniform(60, 200, size=(height // 32 + 2, width // 32 + 2)).astype(np.float32)
    bg = cv2.resize(coarse, (width, height), interpolation=cv2.INTER_CUBIC)
    fine = cv2.GaussianBlur(rng.standard_normal((height, width), dtype=np.float32) * 12.0, (0, 0), 1.5)
    gy, gx = np.mgrid[0:height, 0:width].astype(np.float32)
    grad = rng.uniform(-30, 30) * gx / width + rng.uniform(-30, 30) * gy / height
    return np.clip(bg + fine + grad, 0, 255)


def _marker_texture(dictionary: int, marker_id: int, side_px: int) -> tuple[np.ndarray, float, float]:
    """The marker with one white cell of quiet zone: (image, black-square origin px, black-square side px)."""
    d = cv2.aruco.getPredefinedDictionary(dictionary)
    cells = d.markerSize + 2  # data bits + the black border
    ppc = max(2, math.ceil(side_px / cells))
    side = cells * ppc
    img = cv2.aruco.generateImageMarker(d, marker_id, side, borderBits=1)
    img = cv2.copyMakeBorder(img, ppc, ppc, ppc, ppc, cv2.BORDER_CONSTANT, value=255)
    return img, ppc - 0.5, float(side)


def render_marker_view(
    T_cam_marker: np.ndarray,
    *,
    marker_id: int = 7,
    marker_size_m: float = 0.2,
    dictionary: int = cv2.aruco.DICT_4X4_250,
    intrinsics: CameraIntrinsics | None = None,
    blur_sigma: float = 0.7,
    noise_sigma: float = 3.0,
    rng: np.random.Generator | None = None,
    supersample: int = 4,
    black: float | None = None,
    white: float | None = None,
    background: np.ndarray | None = None,
) -> SyntheticView:
    """Render one marker at pose `T_cam_marker` (camera ← marker) on a random background.

    `blur_sigma` (px) models defocus and the lens, `noise_sigma` (grey levels) the sensor; `black` and
    `white` are the printed marker's grey levels (random in 15–50 / 190–245 when not given);
    `background` (H×W float32 grey) replaces the random texture. The distortion of `intrinsics` is
    ignored (an ideal pinhole renders the image).
    """
    rng = rng if rng is not None else np.random.default_rng()
    k = intrinsics or default_intrinsics()
    w, h, s = k.width, k.height, int(supersample)
    img = _background(rng, w, h) if background is None else np.array(background, dtype=np.float32)

    corners3d = marker_corners_3d(marker_size_m)
    corners_px = k.project(se3.apply(T_cam_marker, corners3d))
    quiet_px = k.project(se3.apply(T_cam_marker, corners3d * ((6 + 2) / 6 + 0.5)))  # generous bound
    if (se3.apply(T_cam_marker, corners3d)[:, 2] <= 0.01).any():
        raise ValueError("the marker is behind the camera")

    x0 = int(max(0, math.floor(quiet_px[:, 0].min()) - 2))
    y0 = int(max(0, math.floor(quiet_px[:, 1].min()) - 2))
    x1 = int(min(w, math.ceil(quiet_px[:, 0].max()) + 3))
    y1 = int(min(h, math.ceil(quiet_px[:, 1].max()) + 3))
    if x1 > x0 and y1 > y0:
        side_hi = float(np.max(np.linalg.norm(np.roll(corners_px, -1, axis=0) - corners_px, axis=1))) * s
        tex, origin, side = _marker_texture(dictionary, marker_id, int(min(4096, max(48, side_hi))))
        src = np.array(
            [[origin, origin], [origin + side, origin], [origin + side, origin + side], [origin, origin + side]],
            dtype=np.float32,
        )
        # Low-res pixel u covers high-res pixels s·u … s·u + s − 1, whose centres average to s·u + (s − 1)/2.
        dst = (s * (corners_px - np.array([x0, y0])) + (s - 1) / 2.0).astype(np.float32)
        hom = cv2.getPerspectiveTransform(src, dst)
        size_hi = ((x1 - x0) * s, (y1 - y0) * s)
        black = rng.uniform(15, 50) if black is None else black
        white = rng.uniform(190, 245) if white is None else white
        tex_f = black + (white - black) * (tex.astype(np.float32) / 255.0)
        warped = cv2.warpPerspective(tex_f, hom, size_hi, flags=cv2.INTER_LINEAR, borderValue=0.0)
        mask = cv2.warpPerspective(
            np.ones(tex.shape, np.float32), hom, size_hi, flags=cv2.INTER_LINEAR, borderValue=0.0
        )
        size_lo = (x1 - x0, y1 - y0)
        warped = cv2.resize(warped, size_lo, interpolation=cv2.INTER_AREA)
        alpha = cv2.resize(mask, size_lo, interpolation=cv2.INTER_AREA)
        roi = img[y0:y1, x0:x1]
        img[y0:y1, x0:x1] = alpha * warped + (1.0 - alpha) * roi

    if blur_sigma > 0:
        img = cv2.GaussianBlur(img, (0, 0), blur_sigma)
    if noise_sigma > 0:
        img = img + rng.standard_normal(img.shape, dtype=np.float32) * np.float32(noise_sigma)
    grey = np.clip(np.rint(img), 0, 255).astype(np.uint8)
    # A slight colour cast per channel, so BGR input is really colour (detectors convert it to grey).
    tint = rng.uniform(0.9, 1.0, size=3)
    out = cv2.merge([cv2.convertScaleAbs(grey, alpha=float(a)) for a in tint])
    return SyntheticView(
        out, k, np.asarray(T_cam_marker, dtype=np.float64).copy(), marker_id, marker_size_m, corners_px
    )


def render_markers_view(
    placements: list[tuple[int, np.ndarray]],
    *,
    marker_size_m: float,
    intrinsics: CameraIntrinsics,
    rng: np.random.Generator,
    dictionary: int = cv2.aruco.DICT_4X4_250,
) -> list[SyntheticView]:
    """Several markers ((id, T_cam_marker) each) in one image: each rendered onto the one before, blur and
    sensor noise applied once, with the last. The last view's image is the picture; every view keeps its own
    marker's true corners."""
    views: list[SyntheticView] = []
    background = None
    for i, (marker_id, T) in enumerate(placements):
        last = i == len(placements) - 1
        v = render_marker_view(
            T,
            marker_id=marker_id,
            marker_size_m=marker_size_m,
            dictionary=dictionary,
            intrinsics=intrinsics,
            rng=rng,
            background=background,
            blur_sigma=0.7 if last else 0.0,
            noise_sigma=3.0 if last else 0.0,
        )
        background = cv2.cvtColor(v.image, cv2.COLOR_BGR2GRAY).astype(np.float32)
        views.append(v)
    return views


def pose_sequence(
    T_start: np.ndarray,
    n: int,
    rng: np.random.Generator,
    step_m: float = 0.004,
    step_deg: float = 0.4,
) -> list[np.ndarray]:
    """`n` poses drifting slightly from `T_start`, as a hand-held or slowly driving camera sees a marker.

    Each step moves the marker by a smooth random velocity of about `step_m` metres and `step_deg`
    degrees per frame (a 30 Hz camera at ~0.1 m/s and ~12°/s), so consecutive frames differ a little
    and their image noise is independent.
    """
    out = [np.asarray(T_start, dtype=np.float64).copy()]
    v = rng.normal(0, step_m, 3)
    w = np.radians(rng.normal(0, step_deg, 3))
    for _ in range(n - 1):
        v = 0.8 * v + 0.2 * rng.normal(0, step_m, 3)
        w = 0.8 * w + 0.2 * np.radians(rng.normal(0, step_deg, 3))
        prev = out[-1]
        t = se3.transform(prev[:3, :3] @ se3.rvec_to_matrix(w), prev[:3, 3] + v)
        out.append(t)
    return out


def render_sequence(
    distance_m: float,
    max_off_axis_deg: float,
    n: int,
    rng: np.random.Generator,
    *,
    marker_id: int = 7,
    marker_size_m: float = 0.2,
    dictionary: int = cv2.aruco.DICT_4X4_250,
    intrinsics: CameraIntrinsics | None = None,
    blur_sigma: float = 0.7,
    noise_sigma: float = 3.0,
) -> list[SyntheticView]:
    """`n` views of one marker slightly moving around a random pose (the temporal-disambiguation case).

    Background and marker grey levels stay fixed over the sequence (the same scene), the noise does not.
    """
    k = intrinsics or default_intrinsics()
    start = random_pose(distance_m, max_off_axis_deg, rng, k, marker_size_m, margin_px=30.0)
    black, white = rng.uniform(15, 50), rng.uniform(190, 245)
    bg = _background(rng, k.width, k.height)
    poses = pose_sequence(start, n, rng, step_m=0.003 * distance_m)
    return [
        render_marker_view(
            t,
            marker_id=marker_id,
            marker_size_m=marker_size_m,
            dictionary=dictionary,
            intrinsics=k,
            blur_sigma=blur_sigma,
            noise_sigma=noise_sigma,
            rng=rng,
            black=black,
            white=white,
            background=bg,
        )
        for t in poses
    ]
