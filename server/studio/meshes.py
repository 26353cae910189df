"""Mesh geoms for the studio: a robot described with meshes looks like itself.

MuJoCo keeps every mesh's vertices in the frame of the geoms that use it (it recentres the mesh and folds the
offset into the geom's pos/quat), so a mesh geom draws as its vertices and faces at the geom's pose.
"""

from __future__ import annotations

import mujoco
import numpy as np

MAX_DRAWN_GROUP = (
    2  # geoms in groups 0–2 are drawn (MuJoCo's viewer default); higher groups hold collision shapes
)


def mesh_of(model: mujoco.MjModel, geom: int) -> tuple[np.ndarray, np.ndarray] | None:
    """Returns the vertices (V,3) float32, m, in the geom's frame, and faces (F,3) uint32 of a mesh geom, or None."""
    if int(model.geom_type[geom]) != int(mujoco.mjtGeom.mjGEOM_MESH):
        return None
    mid = int(model.geom_dataid[geom])
    if mid < 0:
        return None
    va, vn = int(model.mesh_vertadr[mid]), int(model.mesh_vertnum[mid])
    fa, fn = int(model.mesh_faceadr[mid]), int(model.mesh_facenum[mid])
    verts = np.asarray(model.mesh_vert[va : va + vn], dtype=np.float32)
    faces = np.asarray(model.mesh_face[fa : fa + fn], dtype=np.uint32)
    return verts, faces


def drawn(model: mujoco.MjModel, geom: int) -> bool:
    """Whether the studio draws a robot geom: visual groups only (collision copies in groups 3+ are hidden)."""
    return int(model.geom_group[geom]) <= MAX_DRAWN_GROUP
