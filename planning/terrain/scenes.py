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
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

TERRAIN_NAMES: tuple[str, ...] = ("flat", "stairs", "stones", "clutter", "under-table", "slope", "rough")

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
    _ground: tuple[_GroundPiece, ...] = field(repr=False)

    def ground_height(self, x: ArrayLike, y: ArrayLike) -> Any:
        """Gives the true support height (m) at world (x, y): a float for scalars, an array for arrays."""
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
        self._names: set[str] = set()

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
        )


# ---------------------------------------------------------------------------------------------------------------
# Parameters, one frozen dataclass per terrain (lengths m, angles deg).


@dataclass(frozen=True)
class FlatParams:
    """Flat ground. goal_x_m: x of the goal (m)."""

    goal_x_m: float = 6.0


@dataclass(frozen=True)
class StairsParams:
    """A staircase up then down with railings.

    x_start_m: foot of the first riser (m); n_steps: risers up (and as many down); riser_m, tread_m: step rise and
    run (m); landing_m: length of the top landing (m); width_m: stair width (m); rail_offset_m: gap between the
    stair side and the railing (m); rail_height_m: top rail above the tread (m); mid_rail_m: middle rail above the
    tread (m), which is at body height so the railing is a body obstacle.
    """

    x_start_m: float = 1.0
    n_steps: int = 4
    riser_m: float = 0.15
    tread_m: float = 0.30
    landing_m: float = 1.2
    width_m: float = 1.2
    rail_offset_m: float = 0.05
    rail_height_m: float = 0.9
    mid_rail_m: float = 0.45
    goal_x_m: float = 6.0


@dataclass(frozen=True)
class StonesParams:
    """Stepping stones over a pit, in rows along x with two stones per row (left and right).

    x_start_m, x_end_m: extent of the pit (m); pit_depth_m: pit floor below the platforms (m); stone_depth_m: range
    of a stone's length along x (m); gap_m: range of the gap between rows (m); stone_width_m: range of a stone's
    width along y (m); center_gap_m: range of the gap between the left and right stones (m); jitter_z_m: range of
    a stone top's height offset (m); pit_half_width_m: pit half width along y (m).
    """

    x_start_m: float = 1.0
    x_end_m: float = 5.0
    pit_depth_m: float = 0.3
    stone_depth_m: tuple[float, float] = (0.30, 0.40)
    gap_m: tuple[float, float] = (0.20, 0.30)
    stone_width_m: tuple[float, float] = (0.40, 0.50)
    center_gap_m: tuple[float, float] = (0.04, 0.10)
    jitter_z_m: float = 0.02
    pit_half_width_m: float = 1.5
    goal_x_m: float = 6.0


@dataclass(frozen=True)
class ClutterParams:
    """Boxes of mixed heights: low ones to step over, a wide low one to step onto, tall ones to go around.

    n_low: number of low boxes; low_height_m, low_size_m: ranges of their height and side (m); platform_height_m,
    platform_size_m: the wide low box whose top is steppable (m); tall_height_m: range of tall boxes' height (m);
    x_range_m, y_half_m: where boxes are scattered (m).
    """

    n_low: int = 6
    low_height_m: tuple[float, float] = (0.04, 0.10)
    low_size_m: tuple[float, float] = (0.08, 0.20)
    platform_height_m: float = 0.12
    platform_size_m: tuple[float, float] = (0.6, 0.7)
    tall_height_m: tuple[float, float] = (0.6, 0.8)
    x_range_m: tuple[float, float] = (1.2, 4.8)
    y_half_m: float = 0.8
    goal_x_m: float = 6.0


@dataclass(frozen=True)
class UnderTableParams:
    """A table across the way; the body passes under it, its legs are obstacles.

    x_center_m: table center (m); length_m, width_m: table top extent along x, y (m); clearance_m: height of the
    top's underside (m) — the robot body (top at ~0.60 m standing) must crouch to ~0.45 m body height; top_m:
    thickness of the top (m); leg_m: side of the square legs (m).
    """

    x_center_m: float = 3.0
    length_m: float = 1.2
    width_m: float = 1.4
    clearance_m: float = 0.60
    top_m: float = 0.04
    leg_m: float = 0.05
    goal_x_m: float = 6.0


@dataclass(frozen=True)
class SlopeParams:
    """A ramp up, a plateau and a ramp down. angle_deg: slope (deg); x_start_m, run_m, plateau_m, width_m (m)."""

    angle_deg: float = 15.0
    x_start_m: float = 1.0
    run_m: float = 1.5
    plateau_m: float = 1.0
    width_m: float = 2.4
    goal_x_m: float = 6.0


@dataclass(frozen=True)
class RoughParams:
    """A random height field. x_range_m, y_half_m: extent (m); amplitude_m: highest bump (m); cell_m: sample
    spacing (m); correlation_m: bump size (m); taper_m: border over which heights fall to zero (m)."""

    x_range_m: tuple[float, float] = (1.0, 5.0)
    y_half_m: float = 1.5
    amplitude_m: float = 0.08
    cell_m: float = 0.04
    correlation_m: float = 0.15
    taper_m: float = 0.3
    goal_x_m: float = 6.0


_PARAMS: dict[str, type] = {
    "flat": FlatParams,
    "stairs": StairsParams,
    "stones": StonesParams,
    "clutter": ClutterParams,
    "under-table": UnderTableParams,
    "slope": SlopeParams,
    "rough": RoughParams,
}


# ---------------------------------------------------------------------------------------------------------------
# Generators.


def _flat(p: FlatParams, rng: np.random.Generator, b: _Builder) -> str:
    b.plane("floor", 0.0)
    return "flat ground"


def _stairs(p: StairsParams, rng: np.random.Generator, b: _Builder) -> str:
    b.plane("floor", 0.0)
    half_w = p.width_m / 2
    y = (-half_w, half_w)
    x = p.x_start_m
    segments: list[tuple[float, float, float]] = []  # (x0, x1, top z) of every tread and the landing
    for k in range(p.n_steps):
        segments.append((x, x + p.tread_m, (k + 1) * p.riser_m))
        x += p.tread_m
    segments.append((x, x + p.landing_m, p.n_steps * p.riser_m))
    x += p.landing_m
    for k in range(p.n_steps):
        segments.append((x, x + p.tread_m, (p.n_steps - 1 - k) * p.riser_m))
        x += p.tread_m
    for k, (x0, x1, z_top) in enumerate(segments):
        if z_top > 0:
            b.box(f"stair_{k:02d}", (x0, x1), y, (0.0, z_top), "terrain_step_mat")
    # Railings: a post at each segment's start, a top rail and a mid rail (at body height) over each segment.
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
    return (
        f"stairs: {p.n_steps} steps up and {p.n_steps} down, {p.riser_m * 100:.0f} cm risers, "
        f"{p.tread_m * 100:.0f} cm treads, {p.landing_m:.1f} m landing, railings at y=±{half_w + p.rail_offset_m:.2f} m"
    )


def _stones(p: StonesParams, rng: np.random.Generator, b: _Builder) -> str:
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

    # Tall boxes: one across the straight line (go around), one off to a side.
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
        b.box(
            f"box_tall_{k}",
            box[:2],
            box[2:],
            (0.0, float(rng.uniform(*p.tall_height_m))),
            "terrain_obstacle_mat",
            obstacle=True,
        )
        placed.append(box)
    # The wide low platform, steppable.
    xc, yc = float(rng.uniform(2.9, 3.2)), float(rng.uniform(-0.15, 0.15))
    sx, sy = p.platform_size_m
    box = (xc - sx / 2, xc + sx / 2, yc - sy / 2, yc + sy / 2)
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
    return f"clutter: {k} low boxes to step over, a {p.platform_height_m:.2f} m platform, 2 tall boxes to go around"


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
    b.box("plateau", (x1, x2), y, (0.0, rise), "terrain_step_mat")
    b.ramp("ramp_down", (x2, x3), y, (rise, 0.0), "terrain_step_mat")
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
    tx = np.clip(np.minimum(xs, lx - xs) / p.taper_m, 0.0, 1.0)
    ty = np.clip(np.minimum(ys, ly - ys) / p.taper_m, 0.0, 1.0)
    taper = np.outer(0.5 - 0.5 * np.cos(np.pi * ty), 0.5 - 0.5 * np.cos(np.pi * tx))
    heights = smooth * taper * p.amplitude_m
    center = ((p.x_range_m[0] + p.x_range_m[1]) / 2, 0.0)
    b.hfield("rough", center, (lx / 2, ly / 2), heights, 0.0, "terrain_rough_mat")
    return f"rough ground: bumps up to {float(heights.max()) * 100:.0f} cm over x {p.x_range_m[0]:.0f}–{p.x_range_m[1]:.0f} m"


_GENERATORS: dict[str, Callable[[Any, np.random.Generator, _Builder], str]] = {
    "flat": _flat,
    "stairs": _stairs,
    "stones": _stones,
    "clutter": _clutter,
    "under-table": _under_table,
    "slope": _slope,
    "rough": _rough,
}


def terrain_params(name: str, **params: Any) -> Any:
    """Gives the frozen Params of terrain `name` with `params` overriding defaults; ValueError on unknown names."""
    if name not in _PARAMS:
        raise ValueError(f"unknown terrain {name!r}; valid names: {', '.join(TERRAIN_NAMES)}")
    cls = _PARAMS[name]
    fields = {f.name for f in dataclasses.fields(cls)}
    unknown = sorted(set(params) - fields)
    if unknown:
        raise ValueError(
            f"terrain {name!r}: unknown parameter(s) {', '.join(unknown)}; valid: {', '.join(sorted(fields))}"
        )
    return cls(**params)


def build_terrain(name: str, seed: int = 0, **params: Any) -> TerrainScene:
    """Gives the scene `name` generated from `params` (see the terrain's Params class) and `seed`."""
    p = terrain_params(name, **params)
    rng = np.random.default_rng(seed)
    b = _Builder()
    description = _GENERATORS[name](p, rng, b)
    return b.scene(name, description, p, seed, (float(p.goal_x_m), 0.0))
