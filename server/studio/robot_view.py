"""MuJoCo geoms as viser scene nodes: the static terrain once, the robot as one frame per body posed every frame.

Robot geoms hang under their body's frame with their fixed local pose (MuJoCo geom_pos/geom_quat), so a frame
update is one position and one orientation per body (from MuJoCo xpos/xquat), not per geom.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from server.engine import GeomVisual, Visuals

ROBOT_TINT = (235, 190, 40)  # the trunk's yellow when the MJCF gives no color


def _rgb(rgba: tuple[float, float, float, float]) -> tuple[int, int, int]:
    return (int(round(rgba[0] * 255)), int(round(rgba[1] * 255)), int(round(rgba[2] * 255)))


def capsule_mesh(
    radius: float, half_length: float, segments: int = 16, rings: int = 6
) -> tuple[np.ndarray, np.ndarray]:
    """Returns (vertices (V,3), faces (F,3)) of a capsule along z: a cylinder of 2·half_length with hemispherical
    caps of `radius` (MuJoCo's capsule size convention), m."""
    phis = np.linspace(0.0, 2.0 * np.pi, segments, endpoint=False)
    rows = []
    # top cap (pole to equator), then bottom cap (equator to pole)
    for k in range(rings + 1):
        th = 0.5 * np.pi * (1.0 - k / rings)
        rows.append((radius * np.cos(th), half_length + radius * np.sin(th)))
    for k in range(rings + 1):
        th = 0.5 * np.pi * k / rings
        rows.append((radius * np.cos(th), -half_length - radius * np.sin(th)))
    verts = []
    for r, z in rows:
        for p in phis:
            verts.append((r * np.cos(p), r * np.sin(p), z))
    faces = []
    n = segments
    for i in range(len(rows) - 1):
        for j in range(n):
            a, b = i * n + j, i * n + (j + 1) % n
            c, d = (i + 1) * n + j, (i + 1) * n + (j + 1) % n
            faces.append((a, c, b))
            faces.append((b, c, d))
    return np.asarray(verts, dtype=np.float32), np.asarray(faces, dtype=np.uint32)


def hfield_mesh(z: np.ndarray, half_x: float, half_y: float) -> tuple[np.ndarray, np.ndarray]:
    """Returns (vertices, faces) of a MuJoCo height field: rows along y, columns along x, heights z (m)."""
    nrow, ncol = z.shape
    xs = np.linspace(-half_x, half_x, ncol)
    ys = np.linspace(-half_y, half_y, nrow)
    X, Y = np.meshgrid(xs, ys)
    verts = np.stack([X.ravel(), Y.ravel(), z.ravel()], axis=1).astype(np.float32)
    idx = np.arange(nrow * ncol).reshape(nrow, ncol)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel(), idx[1:, :-1].ravel(), idx[1:, 1:].ravel()
    faces = np.concatenate([np.stack([a, b, c], 1), np.stack([b, d, c], 1)]).astype(np.uint32)
    return verts, faces


def add_geom(
    scene: Any, name: str, g: GeomVisual, *, color: tuple[int, int, int] | None = None
) -> Any | None:
    """Adds one geom at its pose (relative to the node's parent); returns the handle (None for kinds not drawn)."""
    rgb = color or _rgb(g.rgba)
    opacity = None if g.rgba[3] >= 0.999 else float(g.rgba[3])
    pose = {"position": g.pos, "wxyz": g.wxyz}
    sx, sy, sz = g.size
    if g.kind == "box":
        return scene.add_box(name, color=rgb, dimensions=(2 * sx, 2 * sy, 2 * sz), opacity=opacity, **pose)
    if g.kind == "sphere":
        return scene.add_icosphere(name, radius=sx, color=rgb, subdivisions=2, opacity=opacity, **pose)
    if g.kind == "ellipsoid":
        return scene.add_icosphere(name, radius=1.0, scale=(sx, sy, sz), color=rgb, subdivisions=2, **pose)
    if g.kind == "cylinder":
        return scene.add_cylinder(name, radius=sx, height=2 * sy, color=rgb, radial_segments=20, **pose)
    if g.kind == "capsule":
        v, f = capsule_mesh(sx, sy)
        return scene.add_mesh_simple(name, v, f, color=rgb, opacity=opacity, **pose)
    if g.kind == "plane":
        # MuJoCo planes are infinite; draw the given half extents (or 20 m) as a thin slab with its top at z = 0
        hx, hy = (sx or 20.0), (sy or 20.0)
        p = (g.pos[0], g.pos[1], g.pos[2] - 0.005)
        return scene.add_box(name, color=rgb, dimensions=(2 * hx, 2 * hy, 0.01), position=p, wxyz=g.wxyz,
                             receive_shadow=True)  # fmt: skip
    if g.kind == "mesh" and g.mesh is not None:
        return scene.add_mesh_simple(name, g.mesh[0], g.mesh[1], color=rgb, opacity=opacity, **pose)
    if g.kind == "hfield" and g.hfield_z is not None and g.hfield_half_xy is not None:
        v, f = hfield_mesh(g.hfield_z, *g.hfield_half_xy)
        return scene.add_mesh_simple(name, v, f, color=rgb, flat_shading=True, **pose)
    return None


class RobotView:
    """The terrain and the robot of one session in a viser scene (server.scene, client.scene or a recorder)."""

    def __init__(self, scene: Any, visuals: Visuals, root: str = "/world") -> None:
        self.scene = scene
        self.root = root
        self.visuals = visuals
        self.terrain: list[Any] = []
        self.bodies: list[Any] = []
        self.geoms: list[Any] = []
        self._build()

    def _build(self) -> None:
        sc, root = self.scene, self.root
        for i, g in enumerate(self.visuals.terrain_geoms):
            h = add_geom(sc, f"{root}/terrain/{i:03d}_{g.name}", g)
            if h is not None:
                self.terrain.append(h)
        if any(g.kind == "plane" for g in self.visuals.terrain_geoms):
            self.terrain.append(
                sc.add_grid(f"{root}/terrain/grid", width=20.0, height=20.0, cell_size=0.5, section_size=1.0,
                            position=(0.0, 0.0, 0.001), plane="xy")
            )  # fmt: skip
        for b, name in enumerate(self.visuals.body_names):
            self.bodies.append(sc.add_frame(f"{root}/robot/{b:02d}_{name}", show_axes=False))
        for i, g in enumerate(self.visuals.robot_geoms):
            body = self.bodies[g.body]
            h = add_geom(sc, f"{body.name}/{i:02d}_{g.name}", g)
            if h is not None:
                self.geoms.append(h)

    def set_poses(self, xpos: np.ndarray, xquat: np.ndarray) -> None:
        """Poses the robot: xpos (nb,3) m and xquat (nb,4) wxyz of its bodies, world frame."""
        for h, p, q in zip(self.bodies, xpos, xquat, strict=False):
            h.position = p
            h.wxyz = q

    def remove(self) -> None:
        for h in [*self.geoms, *self.bodies, *self.terrain]:
            try:
                h.remove()
            except Exception:  # noqa: BLE001 - a node already gone (client disconnected) is fine
                pass
        self.geoms.clear()
        self.bodies.clear()
        self.terrain.clear()
