"""A tiny ray-cast RGB-D renderer for the VLM tests: coloured boxes and balls in front of a wall.

Each pixel's ray is intersected with every face analytically, so the depth image and the ground truth
are exact; faces are shaded by the angle to the ray, as a renderer would. The anchor ("map") frame has
z up; the camera pose is T_map_camera (optical frame: x right, y down, z forward).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from mission.core import se3
from mission.core.types import CameraIntrinsics, Frame

INTR = CameraIntrinsics(fx=250.0, fy=250.0, cx=160.0, cy=120.0, width=320, height=240)


@dataclass
class Box:
    centre: tuple[float, float, float]  # map frame, metres
    size: tuple[float, float, float]  # x, y, z extents
    bgr: tuple[int, int, int]
    yaw: float = 0.0


@dataclass
class Ball:
    centre: tuple[float, float, float]
    radius: float
    bgr: tuple[int, int, int]


@dataclass
class Scene:
    boxes: list[Box] = field(default_factory=list)
    balls: list[Ball] = field(default_factory=list)
    wall_x: float = 6.0  # a grey wall at x = wall_x (map), facing -x
    floor: bool = True


def camera_pose(x: float, y: float, yaw: float, height: float = 0.3) -> np.ndarray:
    """T_map_camera of a forward-looking camera on a robot at (x, y, yaw)."""
    return se3.compose(se3.planar(x, y, yaw, height), se3.transform(se3.R_BODY_OPTICAL))


def box_front_face(box: Box) -> np.ndarray:
    """T_map_face of the box face whose normal is -x in the box frame (z out of the face, x right, y up)."""
    body = se3.planar(box.centre[0], box.centre[1], box.yaw, box.centre[2])
    # face frame in box frame: origin at (-sx/2, 0, 0); z = -x_box, x = -y_box (right when facing it), y = z_box
    r = np.array([[0.0, 0.0, -1.0], [-1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    return se3.compose(body, se3.transform(r, (-box.size[0] / 2, 0.0, 0.0)))


def render(
    scene: Scene, T_map_camera: np.ndarray, stamp: float = 0.0, intr: CameraIntrinsics = INTR, anchor: bool = True
) -> Frame:
    h, w = intr.height, intr.width
    vv, uu = np.mgrid[0:h, 0:w].astype(np.float64)
    rays_c = np.stack([(uu - intr.cx) / intr.fx, (vv - intr.cy) / intr.fy, np.ones_like(uu)], -1)
    rays_c = rays_c.reshape(-1, 3)
    r_mc, o = T_map_camera[:3, :3], T_map_camera[:3, 3]
    rays = rays_c @ r_mc.T  # map-frame directions (not unit; t is then optical depth z)
    best_t = np.full(len(rays), np.inf)
    colour = np.zeros((len(rays), 3))

    def hit_plane(p0: np.ndarray, n: np.ndarray, inside, bgr) -> None:
        denom = rays @ n
        with np.errstate(divide="ignore", invalid="ignore"):
            t = ((p0 - o) @ n) / denom
        ok = np.isfinite(t) & (t > 1e-3) & (t < best_t)
        if not ok.any():
            return
        pts = o + rays[ok] * t[ok, None]
        ins = inside(pts)
        idx = np.flatnonzero(ok)[ins]
        best_t[idx] = t[idx]
        cosang = np.abs(rays[idx] @ n) / np.linalg.norm(rays[idx], axis=1)
        colour[idx] = np.asarray(bgr, float) * (0.55 + 0.45 * cosang[:, None])

    if scene.floor:
        hit_plane(np.zeros(3), np.array([0.0, 0.0, 1.0]), lambda p: np.ones(len(p), bool), (110, 120, 115))
    hit_plane(np.array([scene.wall_x, 0, 0]), np.array([-1.0, 0, 0]), lambda p: np.ones(len(p), bool), (170, 170, 170))
    for box in scene.boxes:
        body = se3.planar(box.centre[0], box.centre[1], box.yaw, box.centre[2])
        inv = se3.invert(body)
        half = np.asarray(box.size) / 2
        for axis in range(3):
            for sign in (-1, 1):
                n_local = np.zeros(3)
                n_local[axis] = sign
                p_local = n_local * half[axis]

                def inside(p, axis=axis, inv=inv, half=half):
                    q = se3.apply(inv, p)
                    others = [i for i in range(3) if i != axis]
                    return np.all(np.abs(q[:, others]) <= half[others] + 1e-9, axis=1)

                hit_plane(se3.apply(body, p_local), body[:3, :3] @ n_local, inside, box.bgr)
    for ball in scene.balls:
        c = np.asarray(ball.centre)
        a = np.einsum("ij,ij->i", rays, rays)
        b = 2 * rays @ (o - c)
        cc = float((o - c) @ (o - c) - ball.radius**2)
        disc = b * b - 4 * a * cc
        ok = disc >= 0
        t = np.full(len(rays), np.inf)
        t[ok] = (-b[ok] - np.sqrt(disc[ok])) / (2 * a[ok])
        ok &= (t > 1e-3) & (t < best_t)
        idx = np.flatnonzero(ok)
        best_t[idx] = t[idx]
        pts = o + rays[idx] * t[idx, None]
        nrm = (pts - c) / ball.radius
        cosang = np.abs(np.einsum("ij,ij->i", rays[idx], nrm)) / np.linalg.norm(rays[idx], axis=1)
        colour[idx] = np.asarray(ball.bgr, float) * (0.55 + 0.45 * cosang[:, None])

    depth = np.where(np.isfinite(best_t), best_t, 0.0).reshape(h, w).astype(np.float32)
    image = np.clip(colour, 0, 255).astype(np.uint8).reshape(h, w, 3)
    return Frame(
        image=image,
        stamp=stamp,
        intrinsics=intr,
        depth=depth,
        T_anchor_camera=T_map_camera.copy() if anchor else None,
        anchor_frame="map",
    )


def yaw_towards(x: float, y: float, tx: float, ty: float) -> float:
    return math.atan2(ty - y, tx - x)
