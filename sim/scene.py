"""The pybullet scene of a scenario: floor, walls, obstacles, the target box with its marker quads, the
dock tag, and a visual robot. pybullet is used as a renderer and ray caster only; motion is kinematic
(see sim/robot.py), so there is no physics step and nothing drifts.

Every body gets a collision shape except the robot, so ray tests (lidar, line of sight) see the world
and never the robot itself. Marker quads have no collision shape either: a ray to a marker's centre
(5 mm in front of its face) is clear exactly when nothing solid is in between.
"""

from __future__ import annotations

import contextlib
import importlib.util
import math
import weakref
from dataclasses import dataclass, field

import cv2
import numpy as np

from mission.core import se3
from mission.core.errors import ConfigError
from mission.core.types import CameraIntrinsics
from mission.sim.geometry import Footprint
from mission.sim.markers import marker_asset, quad_side
from mission.sim.quiet import pybullet, quiet
from mission.sim.scenario import CameraSpec, Lighting, Obstacle, Scenario, obstacle_footprint

MARKER_OFFSET_M = 0.005  # quads float this far in front of the face they sit on (FIELD_NOTES)
DOCK_PANEL_T = 0.02  # thickness of the white board carrying the dock tag
FACE_NORMALS = {"front": (1.0, 0.0), "back": (-1.0, 0.0), "left": (0.0, 1.0), "right": (0.0, -1.0)}


def face_rotation(nx: float, ny: float) -> np.ndarray:
    """Rotation of a marker frame on a vertical face with outward normal (nx, ny, 0): z = n, y = up."""
    z = np.array([nx, ny, 0.0])
    y = np.array([0.0, 0.0, 1.0])
    return np.column_stack([np.cross(y, z), y, z])


@dataclass
class MarkerMount:
    """One marker quad fixed to the target body: its pose in the body frame and what it encodes."""

    face: str
    marker_id: int
    dictionary: str
    size_m: float
    T_body_marker: np.ndarray


@dataclass
class WorldBodies:
    floor: int = -1
    walls: list[int] = field(default_factory=list)
    obstacles: list[int] = field(default_factory=list)
    unknown: list[int] = field(default_factory=list)
    movers: list[int] = field(default_factory=list)
    target: int | None = None
    dock: int | None = None
    dock_tag: int | None = None
    robot: int = -1


def _rgba(c: tuple[float, float, float]) -> list[float]:
    return [float(c[0]), float(c[1]), float(c[2]), 1.0]


class World:
    """Owns one pybullet DIRECT client and the bodies of one scenario."""

    def __init__(
        self,
        scenario: Scenario,
        marker_jitter: list[np.ndarray] | None = None,
        renderer: str = "tiny",
        composite_room: bool | None = None,
    ):
        self.sc = scenario
        self.renderer = renderer
        # TinyRenderer's cost is per covered pixel and the floor and walls cover most of every image, so
        # with it they are painted analytically behind the rendered objects (see RoomPainter).
        self.composite_room = (renderer == "tiny") if composite_room is None else composite_room
        self.painter: RoomPainter | None = None
        self._marker_jitter = marker_jitter or []
        self.p = pybullet()
        self.cid = -1
        self.bodies = WorldBodies()
        self.markers: list[MarkerMount] = []
        self.T_map_dock: np.ndarray | None = None
        self._mesh_cache: dict[tuple[str, int, float, int], int] = {}

    # -- building --------------------------------------------------------------------------------------
    def build(self) -> None:
        p = self.p
        with quiet():
            self.cid = p.connect(p.DIRECT)
        # Disconnect (quietly) at interpreter exit if the owner never called close(): the EGL plugin
        # prints a goodbye line when a client is torn down.
        self._finalizer = weakref.finalize(self, _disconnect, p, self.cid)
        with quiet():
            if self.renderer == "egl":
                spec = importlib.util.find_spec("eglRenderer")
                if spec is None or spec.origin is None:
                    raise ConfigError("egl: pybullet's eglRenderer plugin is not installed", key="camera.renderer")
                plugin = p.loadPlugin(spec.origin, "_eglRendererPlugin", physicsClientId=self.cid)
                if plugin < 0:
                    raise ConfigError(
                        "egl: pybullet could not load its EGL renderer plugin (no EGL/Mesa?); use 'tiny'",
                        key="camera.renderer",
                    )
            sc = self.sc
            sx, sy = sc.room.size
            t = sc.room.wall_thickness
            if not self.composite_room:
                self.bodies.floor = self._box(
                    (sx / 2, sy / 2, -0.01), (sx / 2 + t + 1.0, sy / 2 + t + 1.0, 0.01), 0.0, sc.room.floor_color
                )
            for ob in wall_obstacles(sc):
                self.bodies.walls.append(self._obstacle(ob, visual=not self.composite_room))
            self.bodies.obstacles = [self._obstacle(ob) for ob in sc.obstacles]
            self.bodies.unknown = [self._obstacle(ob) for ob in sc.unknown_obstacles]
            self.bodies.movers = [self._obstacle(ob) for ob in sc.moving_obstacles]
            if sc.dock is not None:
                self._build_dock()
            if sc.target is not None:
                self._build_target()
            self._build_robot()
            if self.composite_room:
                self.painter = RoomPainter(sc, self._probe_colors())

    def _box(self, pos, half, yaw, color, collide: bool = True, visual: bool = True) -> int:
        p = self.p
        if visual:
            vis = p.createVisualShape(
                p.GEOM_BOX, halfExtents=list(half), rgbaColor=_rgba(color), physicsClientId=self.cid
            )
        else:  # pybullet draws the collision shape of a body without a visual: give it an invisible speck
            vis = p.createVisualShape(p.GEOM_SPHERE, radius=1e-4, rgbaColor=_rgba(color), physicsClientId=self.cid)
        col = p.createCollisionShape(p.GEOM_BOX, halfExtents=list(half), physicsClientId=self.cid) if collide else -1
        q = p.getQuaternionFromEuler([0, 0, yaw])
        return p.createMultiBody(0, col, vis, list(pos), q, physicsClientId=self.cid)

    def _obstacle(self, ob: Obstacle, visual: bool = True) -> int:
        p = self.p
        if ob.shape == "box":
            half = (ob.size[0] / 2, ob.size[1] / 2, ob.size[2] / 2)
            return self._box((ob.x, ob.y, half[2]), half, math.radians(ob.yaw_deg), ob.color, visual=visual)
        vis = p.createVisualShape(
            p.GEOM_CYLINDER, radius=ob.radius, length=ob.height, rgbaColor=_rgba(ob.color), physicsClientId=self.cid
        )
        col = p.createCollisionShape(p.GEOM_CYLINDER, radius=ob.radius, height=ob.height, physicsClientId=self.cid)
        return p.createMultiBody(0, col, vis, [ob.x, ob.y, ob.height / 2], [0, 0, 0, 1], physicsClientId=self.cid)

    def _marker_visual(self, dictionary: str, marker_id: int, size_m: float, quiet_cells: int) -> int:
        key = (dictionary, marker_id, size_m, quiet_cells)
        if key not in self._mesh_cache:
            asset = marker_asset(dictionary, marker_id, size_m, quiet_cells)
            self._mesh_cache[key] = self.p.createVisualShape(
                self.p.GEOM_MESH, fileName=str(asset.obj_path), meshScale=[1, 1, 1], physicsClientId=self.cid
            )
        return self._mesh_cache[key]

    def camera_height(self) -> float:
        return self.sc.camera.mount.z

    def _build_target(self) -> None:
        p, tg = self.p, self.sc.target
        assert tg is not None
        hx, hy, hz = tg.size[0] / 2, tg.size[1] / 2, tg.size[2] / 2
        vis = p.createVisualShape(
            p.GEOM_BOX, halfExtents=[hx, hy, hz], rgbaColor=_rgba(tg.color), physicsClientId=self.cid
        )
        col = p.createCollisionShape(p.GEOM_BOX, halfExtents=[hx, hy, hz], physicsClientId=self.cid)
        link_vis, link_pos, link_orn = [], [], []
        for i, m in enumerate(tg.markers):
            side = marker_asset(m.dictionary, m.id, m.printed_size_m, m.quiet_cells).quad_side_m
            nx, ny = FACE_NORMALS[m.face]
            half_depth = hx if m.face in ("front", "back") else hy
            height = self.camera_height() if m.height_m is None else m.height_m
            height = min(max(height, side / 2), tg.size[2] - side / 2)
            T = se3.transform(
                face_rotation(nx, ny),
                (nx * (half_depth + MARKER_OFFSET_M), ny * (half_depth + MARKER_OFFSET_M), height - hz),
            )
            if i < len(self._marker_jitter):
                T = T @ self._marker_jitter[i]  # mounted slightly off-centre / rotated in its plane
            self.markers.append(MarkerMount(m.face, m.id, m.dictionary, m.printed_size_m, T))
            pos, quat = se3.to_pos_quat(T)
            link_vis.append(self._marker_visual(m.dictionary, m.id, m.printed_size_m, m.quiet_cells))
            link_pos.append(pos.tolist())
            link_orn.append(quat.tolist())
        n = len(link_vis)
        self.bodies.target = p.createMultiBody(
            0,
            col,
            vis,
            [tg.x, tg.y, hz],
            p.getQuaternionFromEuler([0, 0, math.radians(tg.yaw_deg)]),
            linkMasses=[0.0] * n,
            linkCollisionShapeIndices=[-1] * n,
            linkVisualShapeIndices=link_vis,
            linkPositions=link_pos,
            linkOrientations=link_orn,
            linkInertialFramePositions=[[0, 0, 0]] * n,
            linkInertialFrameOrientations=[[0, 0, 0, 1]] * n,
            linkParentIndices=[0] * n,
            linkJointTypes=[p.JOINT_FIXED] * n,
            linkJointAxis=[[0, 0, 1]] * n,
            physicsClientId=self.cid,
        )

    def _build_dock(self) -> None:
        p, d = self.p, self.sc.dock
        assert d is not None
        yaw = math.radians(d.yaw_deg)
        nx, ny = math.cos(yaw), math.sin(yaw)
        z = self.camera_height() if d.z is None else d.z
        side = marker_asset(d.dictionary, d.id, d.printed_size_m, d.quiet_cells).quad_side_m
        panel = side + 0.06
        # The board's front face sits DOCK_PANEL_T/2 in front of (x, y); its back half is inside the wall.
        self.bodies.dock = self._box(
            (d.x, d.y, max(z, panel / 2)), (DOCK_PANEL_T / 2, panel / 2, panel / 2), yaw, (0.95, 0.95, 0.95)
        )
        off = DOCK_PANEL_T / 2 + MARKER_OFFSET_M
        self.T_map_dock = se3.transform(face_rotation(nx, ny), (d.x + nx * off, d.y + ny * off, z))
        pos, quat = se3.to_pos_quat(self.T_map_dock)
        vis = self._marker_visual(d.dictionary, d.id, d.printed_size_m, d.quiet_cells)
        self.bodies.dock_tag = p.createMultiBody(0, -1, vis, pos.tolist(), quat.tolist(), physicsClientId=self.cid)

    def _build_robot(self) -> None:
        p, r = self.p, self.sc.robot
        vis = p.createVisualShape(
            p.GEOM_CYLINDER, radius=r.radius, length=r.height, rgbaColor=_rgba(r.color), physicsClientId=self.cid
        )
        self.bodies.robot = p.createMultiBody(
            0, -1, vis, [r.x, r.y, r.height / 2], [0, 0, 0, 1], physicsClientId=self.cid
        )

    def _probe_colors(self) -> dict[str, np.ndarray]:
        """How TinyRenderer shades the floor and each wall under this lighting (one tiny render each).

        A probe quad with the surface's colour and normal is put far outside the room and looked at
        from 1 m; the centre pixel is the colour the painter uses, so painted and rendered surfaces
        match exactly (flat shading: the colour depends on the normal and the light only).
        """
        p, sc = self.p, self.sc
        far = np.array([1000.0, 1000.0, 1000.0])
        probes = {"floor": ((0.0, 0.0, 1.0), sc.room.floor_color)}
        for name, n in (("west", (1, 0, 0)), ("east", (-1, 0, 0)), ("south", (0, 1, 0)), ("north", (0, -1, 0))):
            probes[name] = (n, sc.room.wall_color)
        out = {}
        light = sc.lighting
        for name, (n, color) in probes.items():
            nv = np.asarray(n, dtype=float)
            body = self._box(far.tolist(), (1.0, 1.0, 1.0), 0.0, color, collide=False)
            # Look at the face of the probe cube whose outward normal is n, from 1 m along n, slightly oblique.
            face = far + nv * 1.0
            eye = face + nv * 1.0 + (np.array([0.3, 0.2, 0.0]) if nv[2] != 0 else np.array([0.0, 0.0, 0.2]))
            up = [0, 1, 0] if nv[2] != 0 else [0, 0, 1]
            view = p.computeViewMatrix(eye.tolist(), face.tolist(), up, physicsClientId=self.cid)
            proj = p.computeProjectionMatrixFOV(20, 1.0, 0.05, 10.0, physicsClientId=self.cid)
            _, _, rgba, _, _ = p.getCameraImage(
                8,
                8,
                view,
                proj,
                shadow=0,
                renderer=p.ER_TINY_RENDERER,
                lightDirection=list(light.direction),
                lightAmbientCoeff=light.ambient,
                lightDiffuseCoeff=light.diffuse,
                lightSpecularCoeff=light.specular,
                flags=p.ER_NO_SEGMENTATION_MASK,
                physicsClientId=self.cid,
            )
            px = np.asarray(rgba, dtype=np.uint8).reshape(8, 8, 4)[4, 4, :3]
            out[name] = px[::-1].copy()  # BGR
            p.removeBody(body, physicsClientId=self.cid)
        return out

    # -- moving things -------------------------------------------------------------------------------
    def set_robot_pose(self, x: float, y: float, yaw: float) -> None:
        q = self.p.getQuaternionFromEuler([0, 0, yaw])
        self.p.resetBasePositionAndOrientation(
            self.bodies.robot, [x, y, self.sc.robot.height / 2], q, physicsClientId=self.cid
        )

    def set_target_pose(self, x: float, y: float, yaw: float) -> None:
        if self.bodies.target is None or self.sc.target is None:
            return
        q = self.p.getQuaternionFromEuler([0, 0, yaw])
        self.p.resetBasePositionAndOrientation(
            self.bodies.target, [x, y, self.sc.target.size[2] / 2], q, physicsClientId=self.cid
        )

    def remove_target(self) -> None:
        """The target has left the map: its body goes far below the floor, out of every camera and ray."""
        if self.bodies.target is not None:
            self.p.resetBasePositionAndOrientation(
                self.bodies.target, [0.0, 0.0, -100.0], [0, 0, 0, 1], physicsClientId=self.cid
            )

    def set_mover_pose(self, i: int, x: float, y: float, yaw: float) -> None:
        ob = self.sc.moving_obstacles[i]
        q = self.p.getQuaternionFromEuler([0, 0, yaw])
        self.p.resetBasePositionAndOrientation(self.bodies.movers[i], [x, y, ob.top / 2], q, physicsClientId=self.cid)

    def T_map_target(self, x: float, y: float, yaw: float) -> np.ndarray:
        """Pose of the target body's centre for a floor pose."""
        assert self.sc.target is not None
        return se3.planar(x, y, yaw, self.sc.target.size[2] / 2)

    # -- sensing -------------------------------------------------------------------------------------
    def render(
        self, T_map_optical: np.ndarray, cam: CameraSpec, light: Lighting, *, depth: bool
    ) -> tuple[np.ndarray, np.ndarray | None]:
        """BGR uint8 image (and z-depth in metres) seen from an optical frame (x right, y down, z forward)."""
        p = self.p
        eye = T_map_optical[:3, 3]
        fwd = T_map_optical[:3, 2]
        up = -T_map_optical[:3, 1]
        view = p.computeViewMatrix(eye.tolist(), (eye + fwd).tolist(), up.tolist(), physicsClientId=self.cid)
        proj = p.computeProjectionMatrixFOV(
            cam.vfov_deg, cam.width / cam.height, cam.near_m, cam.far_m, physicsClientId=self.cid
        )
        renderer = p.ER_BULLET_HARDWARE_OPENGL if self.renderer == "egl" else p.ER_TINY_RENDERER
        with quiet():
            _, _, rgba, zbuf, _ = p.getCameraImage(
                cam.width,
                cam.height,
                view,
                proj,
                shadow=0,
                renderer=renderer,
                lightDirection=list(light.direction),
                lightAmbientCoeff=light.ambient,
                lightDiffuseCoeff=light.diffuse,
                lightSpecularCoeff=light.specular,
                flags=p.ER_NO_SEGMENTATION_MASK,
                physicsClientId=self.cid,
            )
        rgba = np.asarray(rgba, dtype=np.uint8).reshape(cam.height, cam.width, 4)
        bgr = cv2.cvtColor(rgba, cv2.COLOR_RGBA2BGR)
        d = np.asarray(zbuf, dtype=np.float32).reshape(cam.height, cam.width)
        z = None
        if depth:
            n, f = cam.near_m, cam.far_m
            z = (f * n / (f - (f - n) * d)).astype(np.float32)
            z[d >= 1.0] = np.nan  # nothing within the far plane
        if self.painter is not None:
            self.painter.paint(bgr, z, d >= 1.0, T_map_optical, cam)
        return bgr, z

    def ray_fractions(self, froms: np.ndarray, tos: np.ndarray) -> np.ndarray:
        """Hit fraction along each ray (1.0 = no hit); batched in chunks pybullet accepts."""
        out = np.ones(len(froms))
        step = 16000
        for i in range(0, len(froms), step):
            res = self.p.rayTestBatch(
                froms[i : i + step].tolist(), tos[i : i + step].tolist(), physicsClientId=self.cid
            )
            out[i : i + len(res)] = [r[2] if r[0] >= 0 else 1.0 for r in res]
        return out

    def ray_hit(self, a: np.ndarray, b: np.ndarray) -> int:
        """The body id the segment a → b hits first, or -1 when it is clear."""
        return int(self.p.rayTest(list(map(float, a)), list(map(float, b)), physicsClientId=self.cid)[0][0])

    def close(self) -> None:
        if self.cid >= 0:
            self._finalizer()
            self.cid = -1


def _disconnect(p: object, cid: int) -> None:
    with quiet(), contextlib.suppress(Exception):
        p.disconnect(physicsClientId=cid)  # type: ignore[attr-defined]


def wall_obstacles(sc: Scenario) -> list[Obstacle]:
    """The four room walls as box obstacles just outside [0, sx] × [0, sy]."""
    sx, sy = sc.room.size
    t, h, c = sc.room.wall_thickness, sc.room.wall_height, sc.room.wall_color
    return [
        Obstacle(shape="box", x=-t / 2, y=sy / 2, size=(t, sy + 2 * t, h), color=c, name="west wall"),
        Obstacle(shape="box", x=sx + t / 2, y=sy / 2, size=(t, sy + 2 * t, h), color=c, name="east wall"),
        Obstacle(shape="box", x=sx / 2, y=-t / 2, size=(sx + 2 * t, t, h), color=c, name="south wall"),
        Obstacle(shape="box", x=sx / 2, y=sy + t / 2, size=(sx + 2 * t, t, h), color=c, name="north wall"),
    ]


def static_footprints(sc: Scenario) -> list[Footprint]:
    """What is in the pre-built map: walls, static obstacles and the dock board."""
    fps = [obstacle_footprint(o) for o in [*wall_obstacles(sc), *sc.obstacles]]
    if sc.dock is not None:
        d = sc.dock
        side = quad_side(d.dictionary, d.printed_size_m, d.quiet_cells) + 0.06
        fps.append(Footprint("box", d.x, d.y, math.radians(d.yaw_deg), DOCK_PANEL_T / 2, side / 2, name="dock"))
    return fps


def unknown_footprints(sc: Scenario) -> list[Footprint]:
    """Obstacles the map does not know about (the lidar sees them)."""
    return [obstacle_footprint(o) for o in sc.unknown_obstacles]


def intrinsics_for(cam: CameraSpec, renderer: str) -> CameraIntrinsics:
    """The pinhole that matches pybullet's image (FIELD_NOTES: TinyRenderer cy = H/2 − 1; EGL half-pixel)."""
    if renderer == "egl":
        return CameraIntrinsics.from_vertical_fov(
            cam.width, cam.height, cam.vfov_deg, cx=cam.width / 2 - 0.5, cy=cam.height / 2 - 0.5
        )
    return CameraIntrinsics.from_vertical_fov(
        cam.width, cam.height, cam.vfov_deg, cx=cam.width / 2, cy=cam.height / 2 - 1
    )


class RoomPainter:
    """Paints the floor and the room's walls into the pixels TinyRenderer left empty.

    Exact for a convex room seen from inside: a pixel shows a wall or the floor exactly when no object
    is in front of it, and the floor and walls are the farthest surfaces. Each pixel's ray is
    intersected with the floor plane and the four inner wall planes; above the walls is the sky
    (TinyRenderer's white). Depth is filled in too when it is asked for.
    """

    def __init__(self, sc: Scenario, colors: dict[str, np.ndarray]) -> None:
        self.sx, self.sy = sc.room.size
        self.wall_h = sc.room.wall_height
        self.colors = colors
        self._rays: dict[tuple[int, int, float], np.ndarray] = {}
        self._floor: np.ndarray | None = None

    def _floor_image(self, h: int, w: int) -> np.ndarray:
        if self._floor is None or self._floor.shape[:2] != (h, w):
            self._floor = np.empty((h, w, 3), dtype=np.uint8)
            self._floor[:] = self.colors["floor"]
        return self._floor

    def _camera_rays(self, cam: CameraSpec) -> np.ndarray:
        """Per-pixel ray directions (optical frame, z = 1), one row per pixel, for this camera."""
        key = (cam.width, cam.height, cam.vfov_deg)
        if key not in self._rays:
            k = intrinsics_for(cam, "tiny")
            u, v = np.meshgrid(np.arange(cam.width, dtype=np.float32), np.arange(cam.height, dtype=np.float32))
            rays = np.stack([(u - k.cx) / k.fx, (v - k.cy) / k.fy, np.ones_like(u)], axis=-1)
            self._rays[key] = rays.reshape(-1, 3)
        return self._rays[key]

    def paint(
        self, bgr: np.ndarray, depth: np.ndarray | None, empty: np.ndarray, T_map_optical: np.ndarray, cam: CameraSpec
    ) -> None:
        """Fill the `empty` pixels of `bgr` (and `depth`) with the floor, the walls or the sky."""
        if not empty.any():
            return
        k = intrinsics_for(cam, "tiny")
        ex, ey, ez = (float(v) for v in T_map_optical[:3, 3])
        R = T_map_optical[:3, :3]
        h, w = bgr.shape[:2]
        if abs(R[2, 0]) > 1e-9 or abs(R[2, 2]) > 1e-9:
            return self._paint_general(bgr, depth, empty, T_map_optical, cam)
        # Level camera (no pitch, no roll): a column's rays share one horizontal direction, so the wall a
        # column sees and the rows where it meets the floor and its top edge follow from one division.
        u = np.arange(w, dtype=np.float64)
        hd = (R[:, 0:1] * ((u - k.cx) / k.fx) + R[:, 2:3]).T  # map direction of row cy per column (W×3)
        dx, dy = hd[:, 0], hd[:, 1]
        with np.errstate(divide="ignore", invalid="ignore"):
            tx = np.where(dx > 1e-12, (self.sx - ex) / dx, np.where(dx < -1e-12, -ex / dx, np.inf))
            ty = np.where(dy > 1e-12, (self.sy - ey) / dy, np.where(dy < -1e-12, -ey / dy, np.inf))
        t_wall = np.minimum(tx, ty)  # optical z-depth of the wall in each column
        v_top = k.cy - k.fy * (self.wall_h - ez) / t_wall
        v_bot = k.cy + k.fy * ez / t_wall
        rows = np.arange(h, dtype=np.float64)[:, None]
        floor = rows > v_bot[None, :]
        wall = ~floor & (rows >= v_top[None, :])
        col = np.where(
            (tx <= ty)[:, None],
            np.where((dx < 0)[:, None], self.colors["west"], self.colors["east"]),
            np.where((dy < 0)[:, None], self.colors["south"], self.colors["north"]),
        ).astype(np.uint8)
        # cv2 does the full-frame copies (3–4× faster than numpy's masked copies): the wall colours of each
        # column stretched down the image, the floor over them below the wall's foot, then into the empty
        # pixels that are not sky (TinyRenderer leaves the sky white already).
        bg = cv2.resize(col[None, :, :], (w, h), interpolation=cv2.INTER_NEAREST)
        cv2.copyTo(self._floor_image(h, w), floor.view(np.uint8), bg)
        cv2.copyTo(bg, (empty & (floor | wall)).view(np.uint8), bgr)
        if depth is not None:
            with np.errstate(divide="ignore"):
                tf = ez * k.fy / (rows - k.cy)
            fill = np.where(floor, tf, np.where(wall, t_wall[None, :], np.nan))
            fill = np.where(fill <= cam.far_m, fill, np.nan).astype(np.float32)
            np.copyto(depth, fill, where=empty)
        return None

    def _paint_general(
        self, bgr: np.ndarray, depth: np.ndarray | None, empty: np.ndarray, T_map_optical: np.ndarray, cam: CameraSpec
    ) -> None:
        """Any camera orientation: intersect every empty pixel's ray with the floor and wall planes."""
        idx = np.flatnonzero(empty.ravel())
        rays = self._camera_rays(cam)[idx]
        d = rays @ T_map_optical[:3, :3].T.astype(np.float32)  # map-frame directions, optical z = 1
        ex, ey, ez = (float(v) for v in T_map_optical[:3, 3])
        dx, dy, dz = d[:, 0], d[:, 1], d[:, 2]
        inf = np.float32(np.inf)
        with np.errstate(divide="ignore", invalid="ignore"):
            tx = np.where(dx > 0, (self.sx - ex) / dx, np.where(dx < 0, -ex / dx, inf))
            ty = np.where(dy > 0, (self.sy - ey) / dy, np.where(dy < 0, -ey / dy, inf))
            tf = np.where(dz < 0, -ez / dz, inf)
        t_wall = np.minimum(tx, ty)
        wall_z = ez + t_wall * dz
        floor = tf <= t_wall
        wall = ~floor & (wall_z <= self.wall_h)
        flat = bgr.reshape(-1, 3)
        flat[idx[floor]] = self.colors["floor"]
        xw = wall & (tx <= ty)
        yw = wall & (tx > ty)
        flat[idx[xw & (dx < 0)]] = self.colors["west"]
        flat[idx[xw & (dx > 0)]] = self.colors["east"]
        flat[idx[yw & (dy < 0)]] = self.colors["south"]
        flat[idx[yw & (dy > 0)]] = self.colors["north"]
        if depth is not None:
            dflat = depth.reshape(-1)
            t = np.where(floor, tf, np.where(wall, t_wall, np.nan)).astype(np.float32)
            dflat[idx] = np.where(t <= cam.far_m, t, np.nan)
