"""Terrain scenes as MuJoCo geoms, generated from parameters and a seed.

Every scene lies along +x between about 1 m and 5 m ahead of the robot's start (the robot starts at x=0, y=0 on
ground at z=0), so walking to ``goal_xy`` = (6, 0) crosses it. Each scene gives:

- ``worldbody_xml``: geoms to insert inside ``<worldbody>`` (including the ground), every geom named ``terrain_*``,
  obstacles that nothing may touch (rails, table, tall boxes) named ``terrain_obstacle_*``;
- ``asset_xml``: textures, materials and height fields to insert inside ``<asset>``;
- ``hfield_data``: normalized heights to write into ``model.hfield_data`` after compile (the XML already carries
  them as ``elevation``, so writing them is optional);
- ``obstacle_boxes``: (x0, x1, y0, y1, z0, z1) of every obstacle geom (all are axis-aligned boxes), for
  ground-truth maps;
- ``ground_height(x, y)``: the true height of the surface a foot can stand on (the floor under a table, not its top;
  the floor beside a rail post, not the post's top), for tests and metrics.

Heights are in meters, lengths in meters, angles in degrees.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, ClassVar, Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

TERRAIN_NAMES: tuple[str, ...] = (
    "flat",
    "stairs",
    "stones",
    "clutter",
    "under-table",
    "slope",
    "rough",
    "mixed",
)

FRICTION = "0.8 0.005 0.0001"
_COLLIDE = f'contype="1" conaffinity="1" friction="{FRICTION}"'

_ASSETS = """\
<texture name="terrain_grid_tex" type="2d" builtin="checker" rgb1="0.32 0.34 0.38" rgb2="0.26 0.28 0.32"
         width="512" height="512" mark="edge" markrgb="0.45 0.47 0.5"/>
<material name="terrain_floor_mat" texture="terrain_grid_tex" texrepeat="8 8" texuniform="true" reflectance="0.05"/>
<material name="terrain_step_mat" rgba="0.62 0.58 0.52 1"/>
<material name="terrain_stone_mat" rgba="0.55 0.55 0.6 1"/>
<material name="terrain_box_mat" rgba="0.72 0.55 0.35 1"/>
<material name="terrain_obstacle_mat" rgba="0.75 0.3 0.25 1"/>
<material name="terrain_rough_mat" rgba="0.45 0.5 0.42 1"/>
"""


# ---------------------------------------------------------------------------------------------------------------
# Ground pieces: the analytic surfaces behind ground_height().


@dataclass(frozen=True)
class _Plane:
    z_m: float

    def height(self, x: NDArray[np.float64], y: NDArray[np.float64]) -> NDArray[np.float64]:
        return np.full(np.broadcast(x, y).shape, self.z_m)

    def height_of(self, x: float, y: float) -> float:
        """height at one point, on Python floats (the same value)"""
        return self.z_m


@dataclass(frozen=True)
class _Box:
    """Axis-aligned (in x, y) box whose top is a support surface."""

    x_min: float
    x_max: float
    y_min: float
    y_max: float
    z_top: float

    def height(self, x: NDArray[np.float64], y: NDArray[np.float64]) -> NDArray[np.float64]:
        inside = (x >= self.x_min) & (x <= self.x_max) & (y >= self.y_min) & (y <= self.y_max)
        return np.where(inside, self.z_top, -np.inf)

    def height_of(self, x: float, y: float) -> float:
        """height at one point, on Python floats (the same value)"""
        inside = self.x_min <= x <= self.x_max and self.y_min <= y <= self.y_max
        return self.z_top if inside else -math.inf


@dataclass(frozen=True)
class _Ramp:
    """Surface rising linearly along x from z0 at x_min to z1 at x_max."""

    x_min: float
    x_max: float
    y_min: float
    y_max: float
    z0: float
    z1: float

    def height(self, x: NDArray[np.float64], y: NDArray[np.float64]) -> NDArray[np.float64]:
        inside = (x >= self.x_min) & (x <= self.x_max) & (y >= self.y_min) & (y <= self.y_max)
        s = (x - self.x_min) / (self.x_max - self.x_min)
        return np.where(inside, self.z0 + s * (self.z1 - self.z0), -np.inf)

    def height_of(self, x: float, y: float) -> float:
        """height at one point, on Python floats (the same arithmetic)"""
        if not (self.x_min <= x <= self.x_max and self.y_min <= y <= self.y_max):
            return -math.inf
        s = (x - self.x_min) / (self.x_max - self.x_min)
        return self.z0 + s * (self.z1 - self.z0)


@dataclass(frozen=True, eq=False)
class _HField:
    """MuJoCo height field: rows along y (row 0 at y = cy - ry), columns along x; z = z0 + data * elevation."""

    cx: float
    cy: float
    rx: float
    ry: float
    z0: float
    elevation: float
    data: NDArray[np.float64]  # (nrow, ncol), normalized to [0, 1]

    def height(self, x: NDArray[np.float64], y: NDArray[np.float64]) -> NDArray[np.float64]:
        nrow, ncol = self.data.shape
        u = (x - (self.cx - self.rx)) / (2 * self.rx) * (ncol - 1)
        v = (y - (self.cy - self.ry)) / (2 * self.ry) * (nrow - 1)
        inside = (u >= 0) & (u <= ncol - 1) & (v >= 0) & (v <= nrow - 1)
        u = np.clip(u, 0, ncol - 1 - 1e-9)
        v = np.clip(v, 0, nrow - 1 - 1e-9)
        i0 = np.floor(v).astype(np.intp)
        j0 = np.floor(u).astype(np.intp)
        fu = u - j0
        fv = v - i0
        d = self.data
        # MuJoCo splits each cell into two triangles along the diagonal (i0, j0)-(i0+1, j0+1).
        h00 = d[i0, j0]
        h11 = d[i0 + 1, j0 + 1]
        lower = fu >= fv
        h_other = np.where(lower, d[i0, j0 + 1], d[i0 + 1, j0])
        a = np.where(lower, fu - fv, fv - fu)
        b = np.where(lower, fv, fu)
        h = h00 + a * (h_other - h00) + b * (h11 - h00)
        return np.where(inside, self.z0 + h * self.elevation, -np.inf)


_GroundPiece = _Plane | _Box | _Ramp | _HField


class GroundSurface(Protocol):
    """A support surface: its height (m) at world (x, y), -inf where it is absent."""

    def height(self, x: NDArray[np.float64], y: NDArray[np.float64]) -> NDArray[np.float64]: ...


# ---------------------------------------------------------------------------------------------------------------
# The scene.


@dataclass(frozen=True, eq=False)
class TerrainScene:
    """A terrain ready to insert into an MJCF model; see the module docstring."""

    name: str
    description: str
    worldbody_xml: str
    asset_xml: str
    hfield_data: dict[str, NDArray[np.float64]]
    goal_xy: tuple[float, float]
    params: Any
    seed: int
    obstacle_geom_names: tuple[str, ...]
    obstacle_boxes: tuple[tuple[float, float, float, float, float, float], ...]
    _ground: tuple[GroundSurface, ...] = field(repr=False)
    span_x: tuple[float, float] = (0.0, 0.0)  # where the terrain lies along x (m); (0, 0) for flat ground

    def ground_height(self, x: ArrayLike, y: ArrayLike) -> Any:
        """Gives the true support height (m) at world (x, y): a float for scalars, an array for arrays."""
        if type(x) is float and type(y) is float:
            # one point (the loop's fall check, every physics step): the pieces that can, on Python floats (their
            # height_of: the same values; the max of them is exact in any order)
            zf = -math.inf
            for piece in self._ground:
                of = getattr(piece, "height_of", None)
                h = of(x, y) if of is not None else float(piece.height(np.float64(x), np.float64(y)))
                if h > zf or h != h:  # a NaN wins, as np.maximum's
                    zf = h
            return zf
        xa = np.asarray(x, dtype=np.float64)
        ya = np.asarray(y, dtype=np.float64)
        z = np.full(np.broadcast(xa, ya).shape, -np.inf)
        for piece in self._ground:
            z = np.maximum(z, piece.height(xa, ya))
        if z.ndim == 0:
            return float(z)
        return z

    def mjcf(self, extra_worldbody: str = "", extra_asset: str = "", model_name: str = "terrain") -> str:
        """Gives a complete, compilable MJCF document holding this terrain (plus optional extra XML)."""
        return (
            f'<mujoco model="{model_name}">\n<asset>\n{self.asset_xml}{extra_asset}</asset>\n'
            f"<worldbody>\n{self.worldbody_xml}{extra_worldbody}</worldbody>\n</mujoco>\n"
        )


class _Builder:
    """Collects geoms (as XML) and ground pieces while a scene is generated."""

    def __init__(self) -> None:
        self.lines: list[str] = []
        self.ground: list[_GroundPiece] = []
        self.obstacles: list[str] = []
        self.obstacle_boxes: list[tuple[float, float, float, float, float, float]] = []
        self.assets: list[str] = []
        self.hfields: dict[str, NDArray[np.float64]] = {}
        self.span_x: tuple[float, float] = (0.0, 0.0)
        self._names: set[str] = set()

    def span(self, x0: float, x1: float) -> None:
        """Sets where the terrain lies along x (m), for judging a crossing and placing an auto goal."""
        self.span_x = (float(x0), float(x1))

    def _name(self, name: str) -> str:
        if name in self._names:
            raise ValueError(f"duplicate terrain geom name {name!r}")
        self._names.add(name)
        return name

    def plane(self, name: str, z_m: float) -> None:
        n = self._name(f"terrain_{name}")
        self.lines.append(
            f'<geom name="{n}" type="plane" size="30 30 0.1" pos="0 0 {z_m:.5f}" material="terrain_floor_mat" {_COLLIDE}/>'
        )
        self.ground.append(_Plane(z_m))

    def box(
        self,
        name: str,
        x: tuple[float, float],
        y: tuple[float, float],
        z: tuple[float, float],
        material: str,
        *,
        obstacle: bool = False,
        support: bool = True,
    ) -> None:
        """Adds an axis-aligned box spanning x, y, z = (min, max) each; obstacles are never support."""
        prefix = "terrain_obstacle_" if obstacle else "terrain_"
        n = self._name(prefix + name)
        c = [(x[0] + x[1]) / 2, (y[0] + y[1]) / 2, (z[0] + z[1]) / 2]
        h = [(x[1] - x[0]) / 2, (y[1] - y[0]) / 2, (z[1] - z[0]) / 2]
        if min(h) <= 0:
            raise ValueError(f"box {n}: every extent must be positive, got half sizes {h}")
        self.lines.append(
            f'<geom name="{n}" type="box" pos="{c[0]:.5f} {c[1]:.5f} {c[2]:.5f}" '
            f'size="{h[0]:.5f} {h[1]:.5f} {h[2]:.5f}" material="{material}" {_COLLIDE}/>'
        )
        if obstacle:
            self.obstacles.append(n)
            self.obstacle_boxes.append((x[0], x[1], y[0], y[1], z[0], z[1]))
        elif support:
            self.ground.append(_Box(x[0], x[1], y[0], y[1], z[1]))

    def ramp(
        self, name: str, x: tuple[float, float], y: tuple[float, float], z: tuple[float, float], material: str
    ) -> None:
        """Adds a ramp whose top rises from z[0] at x[0] to z[1] at x[1] (a thick box pitched about y)."""
        n = self._name(f"terrain_{name}")
        run = x[1] - x[0]
        rise = z[1] - z[0]
        length = float(np.hypot(run, rise))
        pitch = float(np.arctan2(rise, run))
        thickness = 0.2
        n_top = np.array([-np.sin(pitch), 0.0, np.cos(pitch)])
        top_mid = np.array([(x[0] + x[1]) / 2, (y[0] + y[1]) / 2, (z[0] + z[1]) / 2])
        c = top_mid - thickness / 2 * n_top
        # A rotation about y by a positive angle takes +x toward -z, so rising along +x is -pitch. A quaternion, not
        # euler: the robot's MJCF (which the scene is inserted into) may set <compiler angle="radian"/>.
        qw, qy = np.cos(-pitch / 2), np.sin(-pitch / 2)
        self.lines.append(
            f'<geom name="{n}" type="box" pos="{c[0]:.5f} {c[1]:.5f} {c[2]:.5f}" '
            f'size="{length / 2:.5f} {(y[1] - y[0]) / 2:.5f} {thickness / 2:.5f}" '
            f'quat="{qw:.8f} 0 {qy:.8f} 0" material="{material}" {_COLLIDE}/>'
        )
        self.ground.append(_Ramp(x[0], x[1], y[0], y[1], z[0], z[1]))

    def hfield(
        self,
        name: str,
        center_xy: tuple[float, float],
        radius_xy: tuple[float, float],
        heights_m: NDArray[np.float64],
        z0_m: float,
        material: str,
    ) -> None:
        """Adds a height field; heights_m (nrow along y, ncol along x) are >= 0 above z0_m."""
        n = self._name(f"terrain_{name}")
        h_max = float(np.max(heights_m))
        if h_max <= 0:
            raise ValueError(f"height field {n}: heights must have a positive maximum")
        data = np.ascontiguousarray(heights_m / h_max, dtype=np.float64)
        nrow, ncol = data.shape
        elevation = " ".join(f"{v:.5f}" for v in data.ravel())
        self.assets.append(
            f'<hfield name="{n}" nrow="{nrow}" ncol="{ncol}" '
            f'size="{radius_xy[0]:.5f} {radius_xy[1]:.5f} {h_max:.5f} 0.1" elevation="{elevation}"/>\n'
        )
        self.lines.append(
            f'<geom name="{n}" type="hfield" hfield="{n}" pos="{center_xy[0]:.5f} {center_xy[1]:.5f} {z0_m:.5f}" '
            f'material="{material}" {_COLLIDE}/>'
        )
        self.hfields[n] = data.ravel().copy()
        self.ground.append(_HField(center_xy[0], center_xy[1], radius_xy[0], radius_xy[1], z0_m, h_max, data))

    def scene(
        self, name: str, description: str, params: Any, seed: int, goal_xy: tuple[float, float]
    ) -> TerrainScene:
        return TerrainScene(
            name=name,
            description=description,
            worldbody_xml="".join(line + "\n" for line in self.lines),
            asset_xml=_ASSETS + "".join(self.assets),
            hfield_data=dict(self.hfields),
            goal_xy=goal_xy,
            params=params,
            seed=seed,
            obstacle_geom_names=tuple(self.obstacles),
            obstacle_boxes=tuple(self.obstacle_boxes),
            _ground=tuple(self.ground),
            span_x=self.span_x,
        )


# ---------------------------------------------------------------------------------------------------------------
# Parameters, one frozen dataclass per terrain family (lengths m, angles deg). Each field carries its allowed range
# (metadata "range", "unit"); constructing Params outside it raises TerrainParamError naming the parameter. The
# allowed ranges are what the generators can build sensibly, wider than the ranges the sweeps measure.


class TerrainParamError(ValueError):
    """A terrain parameter that is unknown, of the wrong type or outside its allowed range; the message names it."""


def _param(default: Any, lo: float, hi: float, unit: str = "m", *, required: bool = False) -> Any:
    """A parameter with its allowed range [lo, hi] in `unit` (for a (min, max) pair: both ends, min ≤ max);
    required: None (the default) is refused."""
    return field(default=default, metadata={"range": (lo, hi), "unit": unit, "required": required})


@dataclass(frozen=True)
class ParamInfo:
    """One parameter of a terrain family: name, kind ("float", "int", "bool", "range", "float | None"), default,
    allowed range (lo, hi) or None, unit."""

    name: str
    kind: str
    default: Any
    range: tuple[float, float] | None
    unit: str
    required: bool = False

    def describe(self) -> str:
        """Gives e.g. ``riser_m (0.02–0.3 m, default 0.15)``."""
        lim = "" if self.range is None else f"{self.range[0]:g}–{self.range[1]:g} {self.unit}".rstrip() + ", "
        default = self.default
        if isinstance(default, bool):
            default = "true" if default else "false"
        elif isinstance(default, tuple):
            default = f"{default[0]:g}..{default[1]:g}"
        elif default is None:
            default = "none: required" if self.required else "auto"
        return f"{self.name} ({lim}default {default})"


_KINDS = {
    "float": "float",
    "int": "int",
    "bool": "bool",
    "tuple[float, float]": "range",
    "float | None": "float | None",
    "str": "str",
}


def _number(family: str, name: str, value: Any, integer: bool) -> float:
    ok = isinstance(value, int | float | np.integer | np.floating) and not isinstance(value, bool | np.bool_)
    if ok and integer and not float(value).is_integer():
        ok = False
    if not ok:
        want = "an integer" if integer else "a number"
        raise TerrainParamError(f"{family}.{name}={value!r}: must be {want}")
    if not np.isfinite(value):
        raise TerrainParamError(f"{family}.{name}={value!r}: must be finite")
    return float(value)


def _check_range(
    family: str, name: str, value: float, rng: tuple[float, float], unit: str, shown: Any
) -> None:
    lo, hi = rng
    if not lo <= value <= hi:
        raise TerrainParamError(
            f"{family}.{name}={shown}: outside the allowed range {lo:g}–{hi:g} {unit}".rstrip()
        )


@dataclass(frozen=True)
class _Params:
    """Base of the families' Params: checks every field against its kind and range when constructed."""

    family: ClassVar[str] = ""

    def __post_init__(self) -> None:
        fam = self.family
        for f in dataclasses.fields(self):
            kind = _KINDS[str(f.type)]
            v = getattr(self, f.name)
            rng = f.metadata.get("range")
            unit = f.metadata.get("unit", "")
            if kind == "str":
                if not isinstance(v, str):
                    raise TerrainParamError(f"{fam}.{f.name}={v!r}: must be text")
            elif kind == "bool":
                if not isinstance(v, bool | np.bool_):
                    raise TerrainParamError(f"{fam}.{f.name}={v!r}: must be true or false")
                object.__setattr__(self, f.name, bool(v))
            elif kind == "range":
                if isinstance(v, str) or not hasattr(v, "__len__") or len(v) != 2:
                    raise TerrainParamError(f"{fam}.{f.name}={v!r}: must be a (min, max) pair, e.g. 0.2..0.3")
                lo, hi = (_number(fam, f.name, x, False) for x in v)
                shown = f"{lo:g}..{hi:g}"
                if lo > hi:
                    raise TerrainParamError(f"{fam}.{f.name}={shown}: min is above max")
                if rng is not None:
                    _check_range(fam, f.name, lo, rng, unit, shown)
                    _check_range(fam, f.name, hi, rng, unit, shown)
                object.__setattr__(self, f.name, (lo, hi))
            elif kind == "float | None" and v is None:
                if f.metadata.get("required"):
                    raise TerrainParamError(f"{fam}.{f.name}: required ({f.metadata.get('unit', '')})")
                continue
            else:
                x = _number(fam, f.name, v, kind == "int")
                if rng is not None:
                    _check_range(fam, f.name, x, rng, unit, f"{x:g}")
                object.__setattr__(self, f.name, int(x) if kind == "int" else x)
        self._check()

    def _check(self) -> None:
        """Checks between fields (each family's own); raises TerrainParamError."""


_GOAL_DOC = "goal_x_m: x of the goal (m); auto (None): 6 m, or 1 m past the terrain if it ends beyond 5 m."


@dataclass(frozen=True)
class FlatParams(_Params):
    """Flat ground. goal_x_m: x of the goal (m)."""

    family: ClassVar[str] = "flat"
    goal_x_m: float | None = _param(None, 0.5, 100.0)


@dataclass(frozen=True)
class StairsParams(_Params):
    """A staircase up then down, with or without railings.

    x_start_m: foot of the first riser (m); n_steps: risers up (and as many down); riser_m, tread_m: step rise and
    run (m); landing_m: length of the top landing (m); width_m: stair width (m); railings: side railings on both
    sides; rail_offset_m: gap between the stair side and the railing (m); rail_height_m: top rail above the tread
    (m); mid_rail_m: middle rail above the tread (m), at body height so the railing is a body obstacle; goal_x_m:
    x of the goal (m), auto: 6 m, or 1 m past the stairs if they end beyond 5 m.
    """

    family: ClassVar[str] = "stairs"
    x_start_m: float = _param(1.0, 0.6, 20.0)
    n_steps: int = _param(4, 1, 12, "steps")
    riser_m: float = _param(0.15, 0.02, 0.30)
    tread_m: float = _param(0.30, 0.15, 0.80)
    landing_m: float = _param(1.2, 0.3, 5.0)
    width_m: float = _param(1.2, 0.6, 5.0)
    railings: bool = True
    rail_offset_m: float = _param(0.05, 0.0, 1.0)
    rail_height_m: float = _param(0.9, 0.3, 1.5)
    mid_rail_m: float = _param(0.45, 0.1, 1.2)
    goal_x_m: float | None = _param(None, 0.5, 100.0)

    def _check(self) -> None:
        if self.railings and self.mid_rail_m >= self.rail_height_m:
            raise TerrainParamError(
                f"stairs.mid_rail_m={self.mid_rail_m:g}: must be below rail_height_m={self.rail_height_m:g}"
            )


@dataclass(frozen=True)
class StonesParams(_Params):
    """Stepping stones over a pit, in rows along x with two stones per row (left and right).

    x_start_m, x_end_m: extent of the pit (m); pit_depth_m: pit floor below the platforms (m); stone_depth_m: range
    of a stone's length along x (m); gap_m: range of the gap between rows (m); stone_width_m: range of a stone's
    width along y (m); center_gap_m: range of the gap between the left and right stones (m); jitter_z_m: largest
    offset of a stone top's height (m); pit_half_width_m: pit half width along y (m); goal_x_m: as for stairs.
    """

    family: ClassVar[str] = "stones"
    x_start_m: float = _param(1.0, 0.6, 20.0)
    x_end_m: float = _param(5.0, 1.0, 40.0)
    pit_depth_m: float = _param(0.3, 0.05, 2.0)
    stone_depth_m: tuple[float, float] = _param((0.30, 0.40), 0.10, 1.0)
    gap_m: tuple[float, float] = _param((0.20, 0.30), 0.0, 0.6)
    stone_width_m: tuple[float, float] = _param((0.40, 0.50), 0.15, 1.5)
    center_gap_m: tuple[float, float] = _param((0.04, 0.10), 0.0, 0.5)
    jitter_z_m: float = _param(0.02, 0.0, 0.15)
    pit_half_width_m: float = _param(1.5, 0.5, 5.0)
    goal_x_m: float | None = _param(None, 0.5, 100.0)

    def _check(self) -> None:
        if self.x_end_m - self.x_start_m < 0.5:
            raise TerrainParamError(
                f"stones.x_end_m={self.x_end_m:g}: must be at least 0.5 m past x_start_m={self.x_start_m:g}"
            )
        need = self.center_gap_m[1] / 2 + 0.03 + self.stone_width_m[1]
        if self.pit_half_width_m < need:
            raise TerrainParamError(
                f"stones.pit_half_width_m={self.pit_half_width_m:g}: must hold the stones, at least {need:.2f} m "
                "(center_gap_m max / 2 + 0.03 + stone_width_m max)"
            )


@dataclass(frozen=True)
class ClutterParams(_Params):
    """Boxes of mixed heights: low ones to step over, a wide low one to step onto, tall ones to go around.

    n_low: number of low boxes (fewer when they do not fit); low_height_m, low_size_m: ranges of their height and
    side (m); n_tall: tall boxes (the first across the straight line, the second off to a side); platform: whether
    the wide low box is there; platform_height_m, platform_size_m: its height and its sides along x, y (m);
    tall_height_m: range of tall boxes' height (m); x_range_m, y_half_m: where low boxes are scattered (m);
    goal_x_m: as for stairs. The layout comes from the scene's seed.
    """

    family: ClassVar[str] = "clutter"
    n_low: int = _param(6, 0, 30, "boxes")
    low_height_m: tuple[float, float] = _param((0.04, 0.10), 0.01, 0.25)
    low_size_m: tuple[float, float] = _param((0.08, 0.20), 0.04, 0.6)
    n_tall: int = _param(2, 0, 2, "boxes")
    platform: bool = True
    platform_height_m: float = _param(0.12, 0.02, 0.30)
    platform_size_m: tuple[float, float] = _param((0.6, 0.7), 0.2, 1.5)
    tall_height_m: tuple[float, float] = _param((0.6, 0.8), 0.3, 2.0)
    x_range_m: tuple[float, float] = _param((1.2, 4.8), 0.6, 20.0)
    y_half_m: float = _param(0.8, 0.2, 5.0)
    goal_x_m: float | None = _param(None, 0.5, 100.0)

    def _check(self) -> None:
        if self.x_range_m[1] - self.x_range_m[0] < 0.2:
            raise TerrainParamError(
                f"clutter.x_range_m={self.x_range_m[0]:g}..{self.x_range_m[1]:g}: spans < 0.2 m"
            )


@dataclass(frozen=True)
class UnderTableParams(_Params):
    """A table across the way; the body passes under it, its legs are obstacles.

    x_center_m: table center (m); length_m, width_m: table top extent along x, y (m); clearance_m: height of the
    top's underside (m) — the robot body (top at ~0.60 m standing) must crouch to ~0.45 m body height; top_m:
    thickness of the top (m); leg_m: side of the square legs (m); goal_x_m: as for stairs.
    """

    family: ClassVar[str] = "under-table"
    x_center_m: float = _param(3.0, 1.5, 20.0)
    length_m: float = _param(1.2, 0.3, 3.0)
    width_m: float = _param(1.4, 0.6, 4.0)
    clearance_m: float = _param(0.60, 0.30, 1.5)
    top_m: float = _param(0.04, 0.01, 0.2)
    leg_m: float = _param(0.05, 0.02, 0.2)
    goal_x_m: float | None = _param(None, 0.5, 100.0)


@dataclass(frozen=True)
class SlopeParams(_Params):
    """A ramp up, a plateau and a ramp down. angle_deg: slope (deg); x_start_m, run_m (along x), plateau_m, width_m
    (m); goal_x_m: as for stairs."""

    family: ClassVar[str] = "slope"
    angle_deg: float = _param(15.0, 1.0, 35.0, "deg")
    x_start_m: float = _param(1.0, 0.6, 20.0)
    run_m: float = _param(1.5, 0.3, 5.0)
    plateau_m: float = _param(1.0, 0.0, 5.0)
    width_m: float = _param(2.4, 0.6, 5.0)
    goal_x_m: float | None = _param(None, 0.5, 100.0)


@dataclass(frozen=True)
class RoughParams(_Params):
    """A random height field. x_range_m, y_half_m: extent (m); amplitude_m: highest bump (m); cell_m: sample
    spacing (m); correlation_m: bump size (m); taper_m: border over which heights fall to zero (m); goal_x_m: as for
    stairs."""

    family: ClassVar[str] = "rough"
    x_range_m: tuple[float, float] = _param((1.0, 5.0), 0.6, 20.0)
    y_half_m: float = _param(1.5, 0.3, 5.0)
    amplitude_m: float = _param(0.08, 0.005, 0.20)
    cell_m: float = _param(0.04, 0.01, 0.2)
    correlation_m: float = _param(0.15, 0.02, 1.0)
    taper_m: float = _param(0.3, 0.0, 2.0)
    goal_x_m: float | None = _param(None, 0.5, 100.0)

    def _check(self) -> None:
        lx = self.x_range_m[1] - self.x_range_m[0]
        if lx < 0.2:
            raise TerrainParamError(
                f"rough.x_range_m={self.x_range_m[0]:g}..{self.x_range_m[1]:g}: spans < 0.2 m"
            )
        cells = (lx / self.cell_m + 1) * (2 * self.y_half_m / self.cell_m + 1)
        if cells > MAX_HFIELD_CELLS:
            raise TerrainParamError(
                f"rough.cell_m={self.cell_m:g}: {cells:.0f} samples over the extent, more than {MAX_HFIELD_CELLS}"
            )


@dataclass(frozen=True)
class MixedParams(_Params):
    """Stairs then stepping stones: a staircase up and down (no railings by default), a stretch of floor, then a
    pit with stepping stones. The stairs' and stones' parameters mean what they mean in stairs and stones;
    floor_m: floor between the stairs' last riser and the pit (m); stones_m: pit length along x (m)."""

    family: ClassVar[str] = "mixed"
    x_start_m: float = _param(1.0, 0.6, 20.0)
    n_steps: int = _param(2, 1, 12, "steps")
    riser_m: float = _param(0.15, 0.02, 0.30)
    tread_m: float = _param(0.30, 0.15, 0.80)
    landing_m: float = _param(0.6, 0.3, 5.0)
    width_m: float = _param(1.2, 0.6, 5.0)
    railings: bool = False
    floor_m: float = _param(0.4, 0.2, 5.0)
    stones_m: float = _param(1.6, 0.5, 20.0)
    pit_depth_m: float = _param(0.3, 0.05, 2.0)
    stone_depth_m: tuple[float, float] = _param((0.30, 0.40), 0.10, 1.0)
    gap_m: tuple[float, float] = _param((0.20, 0.30), 0.0, 0.6)
    stone_width_m: tuple[float, float] = _param((0.40, 0.50), 0.15, 1.5)
    center_gap_m: tuple[float, float] = _param((0.04, 0.10), 0.0, 0.5)
    jitter_z_m: float = _param(0.02, 0.0, 0.15)
    pit_half_width_m: float = _param(1.5, 0.5, 5.0)
    goal_x_m: float | None = _param(None, 0.5, 100.0)

    def stairs(self) -> StairsParams:
        """Gives the staircase part as StairsParams."""
        return StairsParams(
            x_start_m=self.x_start_m,
            n_steps=self.n_steps,
            riser_m=self.riser_m,
            tread_m=self.tread_m,
            landing_m=self.landing_m,
            width_m=self.width_m,
            railings=self.railings,
        )

    def stones(self) -> StonesParams:
        """Gives the stepping-stones part as StonesParams."""
        x0 = _stairs_end(self.stairs()) + self.floor_m
        return StonesParams(
            x_start_m=x0,
            x_end_m=x0 + self.stones_m,
            pit_depth_m=self.pit_depth_m,
            stone_depth_m=self.stone_depth_m,
            gap_m=self.gap_m,
            stone_width_m=self.stone_width_m,
            center_gap_m=self.center_gap_m,
            jitter_z_m=self.jitter_z_m,
            pit_half_width_m=self.pit_half_width_m,
        )

    def _check(self) -> None:
        try:
            self.stones()
        except TerrainParamError as e:
            raise TerrainParamError(str(e).replace("stones.", "mixed.")) from None


MAX_HFIELD_CELLS = 250_000  # samples in one height field (a rough scene's or a user heightmap's)

_PARAMS: dict[str, type] = {
    "flat": FlatParams,
    "stairs": StairsParams,
    "stones": StonesParams,
    "clutter": ClutterParams,
    "under-table": UnderTableParams,
    "slope": SlopeParams,
    "rough": RoughParams,
    "mixed": MixedParams,
}


def param_info(name: str) -> tuple[ParamInfo, ...]:
    """Gives the parameters of terrain family `name` (in declaration order); TerrainParamError for unknown names."""
    return tuple(_info(f) for f in dataclasses.fields(_family(name)))


def _info(f: dataclasses.Field[Any]) -> ParamInfo:
    md = f.metadata
    return ParamInfo(
        f.name, _KINDS[str(f.type)], f.default, md.get("range"), md.get("unit", ""), md.get("required", False)
    )


def _family(name: str) -> type:
    if name not in _PARAMS:
        raise TerrainParamError(f"unknown terrain {name!r}; valid names: {', '.join(TERRAIN_NAMES)}")
    return _PARAMS[name]


# ---------------------------------------------------------------------------------------------------------------
# Generators: each adds its geoms to the builder, sets the terrain's extent along x, and returns a description.


def _flat(p: FlatParams, rng: np.random.Generator, b: _Builder) -> str:
    b.plane("floor", 0.0)
    return "flat ground"


def _stairs_segments(p: StairsParams) -> list[tuple[float, float, float]]:
    """Gives (x0, x1, top z) of every tread and the landing."""
    x = p.x_start_m
    segments: list[tuple[float, float, float]] = []
    for k in range(p.n_steps):
        segments.append((x, x + p.tread_m, (k + 1) * p.riser_m))
        x += p.tread_m
    segments.append((x, x + p.landing_m, p.n_steps * p.riser_m))
    x += p.landing_m
    for k in range(p.n_steps):
        segments.append((x, x + p.tread_m, (p.n_steps - 1 - k) * p.riser_m))
        x += p.tread_m
    return segments


def _stairs_end(p: StairsParams) -> float:
    """Gives the x (m) where the staircase's last tread ends (the floor resumes)."""
    return p.x_start_m + 2 * p.n_steps * p.tread_m + p.landing_m


def _stairs(p: StairsParams, rng: np.random.Generator, b: _Builder) -> str:
    b.plane("floor", 0.0)
    return _staircase(p, b)


def _staircase(p: StairsParams, b: _Builder) -> str:
    half_w = p.width_m / 2
    y = (-half_w, half_w)
    segments = _stairs_segments(p)
    for k, (x0, x1, z_top) in enumerate(segments):
        if z_top > 0:
            b.box(f"stair_{k:02d}", (x0, x1), y, (0.0, z_top), "terrain_step_mat")
    b.span(p.x_start_m, _stairs_end(p))
    rails = ""
    if p.railings:
        _railings(p, segments, b)
        rails = f", railings at y=±{half_w + p.rail_offset_m:.2f} m"
    return (
        f"stairs: {p.n_steps} steps up and {p.n_steps} down, {p.riser_m * 100:.0f} cm risers, "
        f"{p.tread_m * 100:.0f} cm treads, {p.landing_m:.1f} m landing{rails}"
    )


def _railings(p: StairsParams, segments: list[tuple[float, float, float]], b: _Builder) -> None:
    """Adds a post at each segment's start, a top rail and a mid rail (at body height) over each segment."""
    half_w = p.width_m / 2
    t = 0.04
    for side, sign in (("L", 1.0), ("R", -1.0)):
        yc = sign * (half_w + p.rail_offset_m + t / 2)
        yr = (yc - t / 2, yc + t / 2)
        for k, (x0, x1, z_top) in enumerate(segments):
            b.box(
                f"rail_post_{side}{k:02d}",
                (x0, x0 + t),
                yr,
                (0.0, z_top + p.rail_height_m),
                "terrain_obstacle_mat",
                obstacle=True,
            )
            for rail, h in (("top", p.rail_height_m), ("mid", p.mid_rail_m)):
                b.box(
                    f"rail_{rail}_{side}{k:02d}",
                    (x0, x1),
                    yr,
                    (z_top + h - t / 2, z_top + h + t / 2),
                    "terrain_obstacle_mat",
                    obstacle=True,
                )
        x_last = segments[-1][1]
        b.box(
            f"rail_post_{side}{len(segments):02d}",
            (x_last - t, x_last),
            yr,
            (0.0, p.rail_height_m),
            "terrain_obstacle_mat",
            obstacle=True,
        )


def _stones(p: StonesParams, rng: np.random.Generator, b: _Builder) -> str:
    return _stone_field(p, rng, b)


def _stone_field(p: StonesParams, rng: np.random.Generator, b: _Builder) -> str:
    b.plane("pit_floor", -p.pit_depth_m)
    big = 6.0
    b.box(
        "platform_start",
        (p.x_start_m - big, p.x_start_m),
        (-big, big),
        (-p.pit_depth_m, 0.0),
        "terrain_step_mat",
    )
    b.box(
        "platform_end", (p.x_end_m, p.x_end_m + big), (-big, big), (-p.pit_depth_m, 0.0), "terrain_step_mat"
    )
    for side, sign in (("L", 1.0), ("R", -1.0)):
        y_in = p.pit_half_width_m
        y_span = (y_in, y_in + big) if sign > 0 else (-y_in - big, -y_in)
        b.box(f"pit_side_{side}", (p.x_start_m, p.x_end_m), y_span, (-p.pit_depth_m, 0.0), "terrain_step_mat")
    # Gaps are drawn within range; stone depths are then scaled so the rows fill the pit exactly.
    length = p.x_end_m - p.x_start_m
    gap_mid = sum(p.gap_m) / 2
    depth_mid = sum(p.stone_depth_m) / 2
    n_rows = max(1, int(round((length - gap_mid) / (depth_mid + gap_mid))))
    gaps = rng.uniform(*p.gap_m, size=n_rows + 1)
    depths = rng.uniform(*p.stone_depth_m, size=n_rows)
    depths *= (length - gaps.sum()) / depths.sum()
    x = p.x_start_m
    for row in range(n_rows):
        x += float(gaps[row])
        depth = float(depths[row])
        center_gap = float(rng.uniform(*p.center_gap_m))
        y_mid = float(rng.uniform(-0.03, 0.03))
        for side, sign in (("L", 1.0), ("R", -1.0)):
            width = float(rng.uniform(*p.stone_width_m))
            y_inner = y_mid + sign * center_gap / 2
            y_span = (y_inner, y_inner + width) if sign > 0 else (y_inner - width, y_inner)
            z_top = float(rng.uniform(-p.jitter_z_m, p.jitter_z_m))
            b.box(
                f"stone_{row:02d}{side}", (x, x + depth), y_span, (-p.pit_depth_m, z_top), "terrain_stone_mat"
            )
        x += depth
    b.span(p.x_start_m, p.x_end_m)
    return (
        f"stepping stones: {n_rows} rows of two over a {p.pit_depth_m:.2f} m pit, "
        f"gaps {gaps.min():.2f}–{gaps.max():.2f} m"
    )


def _clutter(p: ClutterParams, rng: np.random.Generator, b: _Builder) -> str:
    b.plane("floor", 0.0)
    placed: list[tuple[float, float, float, float]] = []  # (x0, x1, y0, y1) with a clearance margin

    def free(x0: float, x1: float, y0: float, y1: float, margin: float) -> bool:
        return all(
            x1 + margin < a0 or x0 - margin > a1 or y1 + margin < b0 or y0 - margin > b1
            for a0, a1, b0, b1 in placed
        )

    # Tall boxes: one across the straight line (go around), one off to a side. Every draw is made whatever n_tall
    # and platform are, so that a seed's other boxes stay where they are when those change.
    tall = [
        (float(rng.uniform(1.9, 2.2)), float(rng.uniform(-0.1, 0.1)), 0.45, 0.6),
        (
            float(rng.uniform(3.7, 4.0)),
            float(rng.choice([-1.0, 1.0])) * float(rng.uniform(0.8, 0.95)),
            0.4,
            0.5,
        ),
    ]
    for k, (xc, yc, sx, sy) in enumerate(tall):
        box = (xc - sx / 2, xc + sx / 2, yc - sy / 2, yc + sy / 2)
        height = float(rng.uniform(*p.tall_height_m))
        if k >= p.n_tall:
            continue
        b.box(f"box_tall_{k}", box[:2], box[2:], (0.0, height), "terrain_obstacle_mat", obstacle=True)
        placed.append(box)
    # The wide low platform, steppable.
    xc, yc = float(rng.uniform(2.9, 3.2)), float(rng.uniform(-0.15, 0.15))
    sx, sy = p.platform_size_m
    box = (xc - sx / 2, xc + sx / 2, yc - sy / 2, yc + sy / 2)
    if p.platform:
        b.box("box_platform", box[:2], box[2:], (0.0, p.platform_height_m), "terrain_box_mat")
        placed.append(box)
    # Low small boxes, to step over.
    k = 0
    for _ in range(200):
        if k >= p.n_low:
            break
        sx, sy = (float(rng.uniform(*p.low_size_m)) for _ in range(2))
        xc = float(rng.uniform(*p.x_range_m))
        yc = float(rng.uniform(-p.y_half_m, p.y_half_m))
        box = (xc - sx / 2, xc + sx / 2, yc - sy / 2, yc + sy / 2)
        if not free(*box, margin=0.25):
            continue
        b.box(f"box_low_{k}", box[:2], box[2:], (0.0, float(rng.uniform(*p.low_height_m))), "terrain_box_mat")
        placed.append(box)
        k += 1
    half = p.low_size_m[1] / 2
    b.span(p.x_range_m[0] - half, max([p.x_range_m[1] + half, *(bx[1] for bx in b.obstacle_boxes)]))
    parts = [f"{k} low boxes to step over"]
    if p.platform:
        parts.append(f"a {p.platform_height_m:.2f} m platform")
    if p.n_tall:
        parts.append(f"{p.n_tall} tall box{'es' if p.n_tall > 1 else ''} to go around")
    return "clutter: " + ", ".join(parts)


def _under_table(p: UnderTableParams, rng: np.random.Generator, b: _Builder) -> str:
    b.plane("floor", 0.0)
    x0, x1 = p.x_center_m - p.length_m / 2, p.x_center_m + p.length_m / 2
    y0, y1 = -p.width_m / 2, p.width_m / 2
    b.box(
        "table_top",
        (x0, x1),
        (y0, y1),
        (p.clearance_m, p.clearance_m + p.top_m),
        "terrain_obstacle_mat",
        obstacle=True,
    )
    for name, (lx, ly) in {"FL": (x1, y1), "FR": (x1, y0), "RL": (x0, y1), "RR": (x0, y0)}.items():
        sx = -1.0 if lx == x1 else 1.0
        sy = -1.0 if ly == y1 else 1.0
        xs = (lx, lx + sx * p.leg_m)
        ys = (ly, ly + sy * p.leg_m)
        b.box(
            f"table_leg_{name}",
            (min(xs), max(xs)),
            (min(ys), max(ys)),
            (0.0, p.clearance_m),
            "terrain_obstacle_mat",
            obstacle=True,
        )
    b.span(x0, x1)
    return f"a table {p.length_m:.1f}×{p.width_m:.1f} m with its underside at {p.clearance_m:.2f} m"


def _slope(p: SlopeParams, rng: np.random.Generator, b: _Builder) -> str:
    b.plane("floor", 0.0)
    rise = p.run_m * float(np.tan(np.radians(p.angle_deg)))
    y = (-p.width_m / 2, p.width_m / 2)
    x0 = p.x_start_m
    x1 = x0 + p.run_m
    x2 = x1 + p.plateau_m
    x3 = x2 + p.run_m
    b.ramp("ramp_up", (x0, x1), y, (0.0, rise), "terrain_step_mat")
    if p.plateau_m > 0:
        b.box("plateau", (x1, x2), y, (0.0, rise), "terrain_step_mat")
    b.ramp("ramp_down", (x2, x3), y, (rise, 0.0), "terrain_step_mat")
    b.span(x0, x3)
    return f"a {p.angle_deg:.0f}° ramp up to a {rise:.2f} m plateau and down again"


def _rough(p: RoughParams, rng: np.random.Generator, b: _Builder) -> str:
    b.plane("floor", 0.0)
    lx = p.x_range_m[1] - p.x_range_m[0]
    ly = 2 * p.y_half_m
    ncol = int(round(lx / p.cell_m)) + 1
    nrow = int(round(ly / p.cell_m)) + 1
    noise = rng.standard_normal((nrow, ncol))
    # Smooth with a separable Gaussian of the correlation length (circular padding is fine: borders taper).
    sigma = p.correlation_m / p.cell_m
    half = int(np.ceil(3 * sigma))
    k = np.exp(-0.5 * (np.arange(-half, half + 1) / sigma) ** 2)
    k /= k.sum()
    smooth = np.apply_along_axis(lambda r: np.convolve(r, k, mode="same"), 1, noise)
    smooth = np.apply_along_axis(lambda c: np.convolve(c, k, mode="same"), 0, smooth)
    smooth -= smooth.min()
    smooth /= smooth.max()
    xs = np.linspace(0.0, lx, ncol)
    ys = np.linspace(0.0, ly, nrow)
    tx = np.clip(np.minimum(xs, lx - xs) / p.taper_m, 0.0, 1.0) if p.taper_m > 0 else np.ones_like(xs)
    ty = np.clip(np.minimum(ys, ly - ys) / p.taper_m, 0.0, 1.0) if p.taper_m > 0 else np.ones_like(ys)
    taper = np.outer(0.5 - 0.5 * np.cos(np.pi * ty), 0.5 - 0.5 * np.cos(np.pi * tx))
    heights = smooth * taper * p.amplitude_m
    center = ((p.x_range_m[0] + p.x_range_m[1]) / 2, 0.0)
    b.hfield("rough", center, (lx / 2, ly / 2), heights, 0.0, "terrain_rough_mat")
    b.span(*p.x_range_m)
    return f"rough ground: bumps up to {float(heights.max()) * 100:.0f} cm over x {p.x_range_m[0]:.0f}–{p.x_range_m[1]:.0f} m"


def _mixed(p: MixedParams, rng: np.random.Generator, b: _Builder) -> str:
    # No floor plane: the stone field's platforms are the floor (a plane at 0 would fill the pit).
    stairs, stones = p.stairs(), p.stones()
    first = _staircase(stairs, b)
    second = _stone_field(stones, rng, b)
    b.span(stairs.x_start_m, stones.x_end_m)
    return f"{first}; then {second}"


_GENERATORS: dict[str, Callable[[Any, np.random.Generator, _Builder], str]] = {
    "flat": _flat,
    "stairs": _stairs,
    "stones": _stones,
    "clutter": _clutter,
    "under-table": _under_table,
    "slope": _slope,
    "rough": _rough,
    "mixed": _mixed,
}

AUTO_GOAL_X_M = 6.0  # an auto goal's x (m), unless the terrain ends beyond AUTO_GOAL_X_M - AUTO_GOAL_PAST_M
AUTO_GOAL_PAST_M = 1.0  # then the auto goal lies this far past the terrain's end (m)


def terrain_params(name: str, **params: Any) -> Any:
    """Gives the frozen Params of terrain `name` with `params` overriding defaults; TerrainParamError (a ValueError)
    on unknown names or parameters and on values outside their allowed range, naming them."""
    cls = _family(name)
    fields = [f.name for f in dataclasses.fields(cls)]
    unknown = sorted(set(params) - set(fields))
    if unknown:
        raise TerrainParamError(
            f"terrain {name!r}: unknown parameter(s) {', '.join(unknown)}; valid: {', '.join(fields)}"
        )
    return cls(**params)


def build_terrain(name: str, seed: int = 0, **params: Any) -> TerrainScene:
    """Gives the scene `name` generated from `params` (see the terrain's Params class) and `seed`."""
    return build_from_params(terrain_params(name, **params), seed)


def build_from_params(p: Any, seed: int = 0) -> TerrainScene:
    """Gives the scene of a family's Params (StairsParams, ...) generated with `seed`."""
    name = p.family
    rng = np.random.default_rng(seed)
    b = _Builder()
    description = _GENERATORS[name](p, rng, b)
    x_end = b.span_x[1]
    goal_x = p.goal_x_m
    if goal_x is None:
        goal_x = max(AUTO_GOAL_X_M, x_end + AUTO_GOAL_PAST_M)
    return b.scene(name, description, p, seed, (float(goal_x), 0.0))
