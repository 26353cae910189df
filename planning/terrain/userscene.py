"""Terrains a user brings: an MJCF scene file or a heightmap (NPY or PNG), turned into a TerrainScene.

- ``heightmap_scene(HeightmapParams)``: a grid of heights in meters (NPY) or gray levels (PNG, 8 or 16 bit, scaled
  by ``height_m``), seen from above like an image: columns run along +x, the first row is the +y edge. Its first
  column lies at ``x_start_m``, its rows are centered on ``y_center_m``; around it the floor is at z = 0 (with walls
  down to the lowest height when some heights are negative). The ground truth is the height field's own surface,
  triangulated as MuJoCo collides with it.
- ``mjcf_scene(MjcfSceneParams)``: a MuJoCo scene (static geoms: planes, boxes, spheres, capsules, cylinders,
  ellipsoids, height fields, meshes). MuJoCo compiles it (includes, mesh and height-field files, its own compiler
  settings); its geoms are then written back in world coordinates, so the robot's MJCF can hold them whatever its
  own compiler settings. Geoms named ``obstacle*`` are obstacles (never support; a body touching them is a
  collision); geoms that collide with nothing are drawn but ignored. There is no analytic height function, so the
  ground truth is ray-cast: a vertical ray from above onto the support geoms (obstacles left out, as the floor under
  a table is the support there, not its top).

Every geom of a user scene is renamed ``terrain_<name>`` (``terrain_obstacle_<name>`` for obstacles) and collides
with the robot like the built-in terrains' geoms (contype 1, conaffinity 1, its own friction).
"""

from __future__ import annotations

import re
import threading
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, ClassVar

import mujoco
import numpy as np
from numpy.typing import NDArray

from planning.terrain.scenes import (
    _ASSETS,
    AUTO_GOAL_PAST_M,
    AUTO_GOAL_X_M,
    MAX_HFIELD_CELLS,
    TerrainScene,
    _Builder,
    _param,
    _Params,
)

MAX_FILE_BYTES = 32 * 1024 * 1024  # largest terrain file read (a heightmap or an MJCF scene with its meshes)
MAX_SCENE_GEOMS = 5000  # most geoms in a user MJCF scene
_RAY_TOP_MARGIN_M = 1.0  # vertical rays start this far above the scene's highest point


class UserTerrainError(ValueError):
    """A user terrain file that cannot be used; the message names the file and the reason."""


# ---------------------------------------------------------------------------------------------------------------
# Parameters.


@dataclass(frozen=True)
class HeightmapParams(_Params):
    """A heightmap file. path: the .npy or .png file; cell_m: spacing of its samples (m); height_m: meters of a
    PNG's white (NPY: a scale applied to its heights, default 1); x_start_m: x of its first column (m);
    y_center_m: y of its middle row (m); goal_x_m: x of the goal (m), auto: 6 m, or 1 m past the heightmap if it
    ends beyond 5 m."""

    family: ClassVar[str] = "heightmap"
    path: str = ""
    cell_m: float | None = _param(None, 0.005, 1.0, required=True)
    height_m: float | None = _param(None, 0.001, 10.0)
    x_start_m: float = _param(1.0, -50.0, 50.0)
    y_center_m: float = _param(0.0, -50.0, 50.0)
    goal_x_m: float | None = _param(None, 0.5, 100.0)


@dataclass(frozen=True)
class MjcfSceneParams(_Params):
    """An MJCF scene file. path: the .xml file; goal_x_m: x of the goal (m), auto: 6 m, or 1 m past the scene's
    geoms (planes aside) if they end beyond 5 m."""

    family: ClassVar[str] = "mjcf"
    path: str = ""
    goal_x_m: float | None = _param(None, 0.5, 100.0)


HEIGHTMAP_SUFFIXES = (".npy", ".png")
MJCF_SUFFIXES = (".xml",)


def _auto_goal(p: Any, x_end: float) -> tuple[float, float]:
    if p.goal_x_m is not None:
        return (float(p.goal_x_m), 0.0)
    return (max(AUTO_GOAL_X_M, x_end + AUTO_GOAL_PAST_M), 0.0)


def _read_limited(path: Path) -> None:
    """Raises UserTerrainError unless path is a readable regular file of at most MAX_FILE_BYTES."""
    if not path.is_file():
        raise UserTerrainError(f"{path}: no such file")
    size = path.stat().st_size
    if size > MAX_FILE_BYTES:
        raise UserTerrainError(
            f"{path}: {size} bytes, more than the {MAX_FILE_BYTES} a terrain file may have"
        )


# ---------------------------------------------------------------------------------------------------------------
# Heightmaps.


def read_heightmap(path: Path, height_m: float | None) -> NDArray[np.float64]:
    """Gives the heights (m) of a heightmap file as (rows from +y to -y, columns along +x)."""
    _read_limited(path)
    suffix = path.suffix.lower()
    if suffix == ".npy":
        try:
            raw = np.load(path, allow_pickle=False)
        except (ValueError, OSError) as e:
            raise UserTerrainError(f"{path}: not a NumPy array file ({e})") from None
        if raw.dtype.kind not in "iuf":
            raise UserTerrainError(f"{path}: heights must be numbers, got dtype {raw.dtype}")
        heights = np.asarray(raw, dtype=np.float64) * (1.0 if height_m is None else height_m)
    elif suffix == ".png":
        if height_m is None:
            raise UserTerrainError(f"{path}: a PNG heightmap needs height_m, the height (m) of white")
        heights = _read_png(path) * height_m
    else:
        raise UserTerrainError(f"{path}: a heightmap is a .npy or .png file")
    if heights.ndim != 2 or min(heights.shape) < 2:
        raise UserTerrainError(
            f"{path}: a heightmap is a 2-D grid of at least 2×2, got shape {heights.shape}"
        )
    if heights.size > MAX_HFIELD_CELLS:
        raise UserTerrainError(
            f"{path}: {heights.shape[0]}×{heights.shape[1]} samples, more than {MAX_HFIELD_CELLS}"
        )
    if not np.isfinite(heights).all():
        raise UserTerrainError(f"{path}: heights must be finite (found NaN or inf)")
    return heights


def _read_png(path: Path) -> NDArray[np.float64]:
    """Gives a PNG's gray levels in [0, 1] (8 or 16 bit; color images are converted to gray)."""
    from PIL import Image, UnidentifiedImageError

    try:
        with Image.open(path) as img:
            if img.mode in ("I;16", "I;16B", "I;16L", "I"):
                a = np.asarray(img, dtype=np.float64)
                return a / (65535.0 if a.max() > 255 or img.mode.startswith("I;16") else 255.0)
            return np.asarray(img.convert("L"), dtype=np.float64) / 255.0
    except (UnidentifiedImageError, OSError) as e:
        raise UserTerrainError(f"{path}: not a readable PNG image ({e})") from None


def heightmap_scene(p: HeightmapParams, seed: int = 0) -> TerrainScene:
    """Gives the scene of a heightmap file (see the module docstring)."""
    path = Path(p.path)
    img = read_heightmap(path, p.height_m)
    assert p.cell_m is not None  # required, checked by HeightmapParams
    heights = np.flipud(img)  # the builder's rows run from -y to +y
    nrow, ncol = heights.shape
    lx, ly = (ncol - 1) * p.cell_m, (nrow - 1) * p.cell_m
    x0, x1 = p.x_start_m, p.x_start_m + lx
    y0, y1 = p.y_center_m - ly / 2, p.y_center_m + ly / 2
    h_min, h_max = float(heights.min()), float(heights.max())
    b = _Builder()
    if h_min < 0:
        # A plane at the lowest height, the floor around the heightmap at 0 as four boxes.
        b.plane("floor", h_min)
        big = 30.0
        z = (h_min, 0.0)
        b.box("frame_back", (x0 - big, x0), (-big, big), z, "terrain_step_mat")
        b.box("frame_front", (x1, x1 + big), (-big, big), z, "terrain_step_mat")
        b.box("frame_left", (x0, x1), (y1, y1 + big), z, "terrain_step_mat")
        b.box("frame_right", (x0, x1), (y0 - big, y0), z, "terrain_step_mat")
    else:
        b.plane("floor", 0.0)
    relief = h_max - h_min
    if relief > 0:
        b.hfield("heightmap", ((x0 + x1) / 2, (y0 + y1) / 2), (lx / 2, ly / 2), heights - h_min, h_min,
                 "terrain_rough_mat")  # fmt: skip
    elif h_min > 0:
        b.box("heightmap", (x0, x1), (y0, y1), (0.0, h_min), "terrain_rough_mat")
    b.span(x0, x1)
    description = (
        f"heightmap {path.name}: {ncol}×{nrow} samples every {p.cell_m * 100:g} cm over x {x0:.2f}–{x1:.2f} m, "
        f"heights {h_min:.2f}–{h_max:.2f} m"
    )
    return b.scene("heightmap", description, p, seed, _auto_goal(p, x1))


# ---------------------------------------------------------------------------------------------------------------
# MJCF scenes.

_TYPES = {
    int(mujoco.mjtGeom.mjGEOM_PLANE): "plane",
    int(mujoco.mjtGeom.mjGEOM_HFIELD): "hfield",
    int(mujoco.mjtGeom.mjGEOM_SPHERE): "sphere",
    int(mujoco.mjtGeom.mjGEOM_CAPSULE): "capsule",
    int(mujoco.mjtGeom.mjGEOM_ELLIPSOID): "ellipsoid",
    int(mujoco.mjtGeom.mjGEOM_CYLINDER): "cylinder",
    int(mujoco.mjtGeom.mjGEOM_BOX): "box",
    int(mujoco.mjtGeom.mjGEOM_MESH): "mesh",
}
_SIZE_COUNT = {"plane": 3, "sphere": 1, "capsule": 2, "ellipsoid": 3, "cylinder": 2, "box": 3}
_NAME_OK = re.compile(r"[^A-Za-z0-9_.-]")


def _f(values: Any) -> str:
    return " ".join(f"{float(v):.9g}" for v in np.ravel(values))


@dataclass(frozen=True, eq=False)
class _RayCastGround:
    """The support surface of a scene with no analytic height: vertical rays cast onto its support geoms."""

    model: mujoco.MjModel
    z_top_m: float
    geomgroup: NDArray[np.uint8]
    _local: threading.local = field(default_factory=threading.local, repr=False)

    def __reduce__(self) -> tuple[Any, ...]:
        # a scene goes to worker processes whole (sweeps, simulations): the per-thread MjData stays behind
        return (_RayCastGround, (self.model, self.z_top_m, self.geomgroup))

    def height(self, x: NDArray[np.float64], y: NDArray[np.float64]) -> NDArray[np.float64]:
        xb, yb = np.broadcast_arrays(np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64))
        out = np.empty(xb.shape)
        data = getattr(self._local, "data", None)
        if data is None:  # MjData is not shared between threads (a server runs sessions in several)
            data = mujoco.MjData(self.model)
            mujoco.mj_forward(self.model, data)
            self._local.data = data
        pnt = np.array([0.0, 0.0, self.z_top_m])
        down = np.array([0.0, 0.0, -1.0])
        gid = np.zeros(1, np.int32)
        flat_out = out.reshape(-1)
        for k, (xi, yi) in enumerate(zip(xb.reshape(-1).tolist(), yb.reshape(-1).tolist(), strict=True)):
            pnt[0], pnt[1] = xi, yi
            dist = mujoco.mj_ray(self.model, data, pnt, down, self.geomgroup, 1, -1, gid)
            flat_out[k] = self.z_top_m - dist if dist >= 0 else -np.inf
        return out


@dataclass
class _Geom:
    name: str
    kind: str
    obstacle: bool
    collides: bool
    xml_attrs: str


def mjcf_scene(p: MjcfSceneParams, seed: int = 0) -> TerrainScene:
    """Gives the scene of an MJCF file (see the module docstring)."""
    path = Path(p.path)
    _read_limited(path)
    check_file_references(path)
    try:
        model = mujoco.MjModel.from_xml_path(str(path))
    except ValueError as e:
        msg = str(e).strip().splitlines()
        raise UserTerrainError(f"{path}: MuJoCo cannot load it: {' '.join(msg)[:400]}") from None
    if model.njnt:
        body = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, int(model.jnt_bodyid[0])) or "a body"
        raise UserTerrainError(
            f"{path}: {body} has a joint; a terrain scene is static (the robot is added to it), remove its joints"
        )
    if model.ngeom == 0:
        raise UserTerrainError(f"{path}: no geoms")
    if model.ngeom > MAX_SCENE_GEOMS:
        raise UserTerrainError(f"{path}: {model.ngeom} geoms, more than {MAX_SCENE_GEOMS}")
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)

    assets: list[str] = []
    hfield_data: dict[str, NDArray[np.float64]] = {}
    geoms: list[_Geom] = []
    used: set[str] = set()
    obstacle_names: list[str] = []
    obstacle_boxes: list[tuple[float, float, float, float, float, float]] = []
    z_top = 0.0
    x_lo, x_hi = np.inf, -np.inf
    for g in range(model.ngeom):
        kind = _TYPES.get(int(model.geom_type[g]))
        src = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, g) or f"geom{g}"
        if kind is None:
            raise UserTerrainError(f"{path}: geom {src!r}: type {int(model.geom_type[g])} is not supported")
        obstacle = src.startswith(("obstacle", "terrain_obstacle_"))
        base = src.removeprefix("terrain_obstacle_").removeprefix("terrain_")
        if obstacle:
            base = base.removeprefix("obstacle").lstrip("_") or f"geom{g}"
        base = _NAME_OK.sub("_", base)
        name = ("terrain_obstacle_" if obstacle else "terrain_") + base
        k = 1
        while name in used:
            k += 1
            name = ("terrain_obstacle_" if obstacle else "terrain_") + f"{base}_{k}"
        used.add(name)
        collides = bool(model.geom_contype[g] or model.geom_conaffinity[g])
        quat = np.zeros(4)
        mujoco.mju_mat2Quat(quat, data.geom_xmat[g])
        rgba = model.mat_rgba[model.geom_matid[g]] if model.geom_matid[g] >= 0 else model.geom_rgba[g]
        attrs = f'type="{kind}" pos="{_f(data.geom_xpos[g])}" quat="{_f(quat)}"'
        if kind == "plane":
            attrs += ' size="30 30 0.1" material="terrain_floor_mat"'
        else:
            attrs += f' rgba="{_f(rgba)}"'
        if kind in _SIZE_COUNT and kind != "plane":
            attrs += f' size="{_f(model.geom_size[g][: _SIZE_COUNT[kind]])}"'
        elif kind == "hfield":
            h = int(model.geom_dataid[g])
            nrow, ncol = int(model.hfield_nrow[h]), int(model.hfield_ncol[h])
            adr = int(model.hfield_adr[h])
            hd = np.asarray(model.hfield_data[adr : adr + nrow * ncol], dtype=np.float64).copy()
            assets.append(
                f'<hfield name="{name}" nrow="{nrow}" ncol="{ncol}" size="{_f(model.hfield_size[h])}"/>\n'
            )
            hfield_data[name] = hd
            attrs += f' hfield="{name}"'
        elif kind == "mesh":
            m = int(model.geom_dataid[g])
            va, vn = int(model.mesh_vertadr[m]), int(model.mesh_vertnum[m])
            fa, fn = int(model.mesh_faceadr[m]), int(model.mesh_facenum[m])
            assets.append(
                f'<mesh name="{name}" vertex="{_f(model.mesh_vert[va : va + vn])}" '
                f'face="{" ".join(str(int(i)) for i in model.mesh_face[fa : fa + fn].ravel())}"/>\n'
            )
            attrs += f' mesh="{name}"'
        if collides:
            attrs += f' contype="1" conaffinity="1" condim="{int(model.geom_condim[g])}"'
            attrs += f' friction="{_f(model.geom_friction[g])}"'
        else:
            attrs += ' contype="0" conaffinity="0"'
        geoms.append(_Geom(name, kind, obstacle, collides, attrs))
        # World-frame bounding box from MuJoCo's geom-frame box.
        c, half = model.geom_aabb[g][:3], model.geom_aabb[g][3:]
        R = data.geom_xmat[g].reshape(3, 3)
        center = data.geom_xpos[g] + R @ c
        ext = np.abs(R) @ half
        if kind != "plane":
            z_top = max(z_top, float(center[2] + ext[2]))
            if collides:
                x_lo, x_hi = min(x_lo, float(center[0] - ext[0])), max(x_hi, float(center[0] + ext[0]))
        else:
            z_top = max(z_top, float(data.geom_xpos[g][2]))
        if obstacle and collides:
            obstacle_names.append(name)
            lo, hi = center - ext, center + ext
            obstacle_boxes.append((lo[0], hi[0], lo[1], hi[1], lo[2], hi[2]))
    if not any(gm.collides and not gm.obstacle for gm in geoms):
        raise UserTerrainError(
            f"{path}: no support geom (every geom is an obstacle or collides with nothing)"
        )

    asset_xml = _ASSETS + "".join(assets)
    worldbody_xml = "".join(f'<geom name="{gm.name}" {gm.xml_attrs}/>\n' for gm in geoms)
    # The ray-cast model: the same geoms, support in group 0, obstacles in 1 and non-colliding ones in 2, so that
    # rays see the support only.
    ray_xml = "".join(
        f'<geom name="{gm.name}" group="{0 if gm.collides and not gm.obstacle else (1 if gm.collides else 2)}" '
        f"{gm.xml_attrs}/>\n"
        for gm in geoms
    )
    ray_model = mujoco.MjModel.from_xml_string(
        f"<mujoco><asset>{asset_xml}</asset><worldbody>{ray_xml}</worldbody></mujoco>"
    )
    for name, hd in hfield_data.items():
        hid = mujoco.mj_name2id(ray_model, mujoco.mjtObj.mjOBJ_HFIELD, name)
        adr = ray_model.hfield_adr[hid]
        ray_model.hfield_data[adr : adr + hd.size] = hd
    ground = _RayCastGround(ray_model, z_top + _RAY_TOP_MARGIN_M, np.array([1, 0, 0, 0, 0, 0], np.uint8))
    span = (0.0, 0.0) if not np.isfinite(x_lo) else (x_lo, x_hi)
    scene = TerrainScene(
        name="mjcf",
        description=f"MJCF scene {path.name}: {model.ngeom} geoms, {len(obstacle_names)} obstacles",
        worldbody_xml=worldbody_xml,
        asset_xml=asset_xml,
        hfield_data=hfield_data,
        goal_xy=_auto_goal(p, span[1]),
        params=p,
        seed=seed,
        obstacle_geom_names=tuple(obstacle_names),
        obstacle_boxes=tuple(obstacle_boxes),
        _ground=(ground,),
        span_x=span,
    )
    if not np.isfinite(scene.ground_height(0.0, 0.0)):
        raise UserTerrainError(f"{path}: no support geom under the robot's start (x=0, y=0)")
    return scene


_FILE_ATTRS = ("file", "meshdir", "texturedir", "assetdir", "filefront", "fileback", "fileleft", "fileright",
               "fileup", "filedown")  # fmt: skip


def check_file_references(path: Path, root: Path | None = None) -> None:
    """Raises UserTerrainError if the MJCF at `path` names a file that may lie outside `root` (default: its own
    directory): an absolute path, any '..' step (MuJoCo resolves some references from the main file's directory,
    some from an asset directory, so none may climb), or a symbolic link leading out. Includes are followed."""
    root = (root or path.parent).resolve()
    seen: set[Path] = set()
    todo = [path]
    while todo:
        f = todo.pop()
        r = f.resolve()
        if r in seen:
            continue
        seen.add(r)
        try:
            tree = ET.parse(f)
        except ET.ParseError as e:
            raise UserTerrainError(f"{f}: not well-formed XML ({e})") from None
        except OSError as e:
            raise UserTerrainError(f"{f}: cannot read it ({e.strerror})") from None
        for el in tree.iter():
            for attr in _FILE_ATTRS:
                ref = el.get(attr)
                if ref is None:
                    continue
                p = Path(ref)
                inside = all((base / p).resolve().is_relative_to(root) for base in (f.parent, path.parent))
                if p.is_absolute() or ".." in p.parts or "\\" in ref or not inside:
                    raise UserTerrainError(
                        f"{f}: <{el.tag} {attr}={ref!r}> names a file outside the scene's directory (references "
                        "are relative, without '..')"
                    )
                if el.tag == "include" and attr == "file":
                    todo.append(f.parent / ref)
