"""2D terrain maps from column data: ground height, body obstacles, step obstacles and their signed distance fields.

From a ``Columns`` summary (voxels.py, or ``columns_from_scene`` for ground truth):

- ground height: the column's ground (the floor under a table, not its top); unknown cells are filled from their
  neighbors, pessimistically (the lowest neighbor first, so an unseen hole stays a hole), then by nearest value;
- body obstacles (where the body may not go): obstacle voxels in the body's height band above the cell's ground or
  above the highest ground nearby (a railing beside a stair), and the foot of a wall too high to pass over (the
  sides of a tall box); then spurious specks removed, gaps closed, dense step obstacles promoted;
- step obstacles (where a foot may not touch down): edges and steep cells, cells too high above the ground nearby,
  obstacles at leg height, cells where a knee would hit something tall nearby, cells near body obstacles; specks
  removed, small gaps closed;
- signed distance fields (m) of both: positive in free cells (distance to the nearest obstacle cell's edge),
  negative inside (distance to the nearest free cell's edge), with their gradients;
- clearance: free height above the ground under an overhang (a table top), +inf where nothing hangs.

Arrays are [ix, iy] with cell (ix, iy) centered at origin_xy + (ix, iy) * resolution_m (world frame, m).
"""

from __future__ import annotations

import dataclasses
import functools
import math
from dataclasses import dataclass
from typing import Any, cast

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import ndimage

from planning.terrain.gridops import disk_filter, disk_filters, distance_transform, pad2, square_filter
from planning.terrain.scenes import TerrainScene
from planning.terrain.voxels import Columns


@dataclass(frozen=True)
class MapParams:
    """Map building (heights above the cell's ground, m; radii, m).

    body_band_m: obstacles within this height band make a body obstacle (robot body bottom crouched .. body top
    crouched as low as the walk goes, with its head margin: the decision's min_height_m + body_top_m +
    head_margin_m; a table underside above the top is passable crouched, so the body path goes under it, not
    around); body_ref_radius_m: radius for the highest
    ground nearby that the band is also measured from; body_above_ground_m: the band measured from a cell's own
    ground starts at least this far above that highest ground nearby (None: not; with it a stone's top edge seen
    from the pit beside it is ground-level, not a body obstacle); body_step_m: ground higher than the lowest ground
    within wall_radius_m higher by more than this makes a cell a body obstacle (the foot of a wall); low_radius_m,
    max_step_height_m: ground higher than the lowest ground within low_radius_m by more than this is a step
    obstacle; edge_radius_m,
    edge_height_m: a height spread above edge_height_m within edge_radius_m is an edge; leg_band_m: obstacles at
    these heights are step obstacles; min_support_m: steppable patches narrower than this are no-step; knee_radius_m, knee_height_m: a cell with ground higher by knee_height_m within
    knee_radius_m is a step obstacle (the knee would hit); near_body_m: step obstacles around body obstacles;
    dense_radius_m, dense_fraction: where step obstacles cover more than this share of the disk, the area becomes a
    body obstacle (dense_counts_high False: cells that are step obstacles only for standing higher than
    max_step_height_m above the lowest ground nearby do not count: a stone's top beside a pit is no obstacle to the
    body above it); high_is_step: cells higher than max_step_height_m above the lowest ground within low_radius_m
    are step obstacles (False: not; a foothold chooser that bounds each step's rise from the leg's own last
    foothold, as the regions pipeline does, needs no such rule, and with it the side of a flight above the floor
    beside it, a stone above its pit, lost a band low_radius_m wide from the ground a foot may stand on); speck_cells: obstacle components smaller than this are removed; close_cells: body-map closing
    radius (cells); fill_min_cells: unknown cells within this many cells of known ones take the lowest neighbor;
    ceiling_above_m: overhangs at least this high count for clearance; fill_low_radius_m: an unknown cell's ground is
    at most the lowest observed ground within this radius (None: not; the shadow behind a stone's far edge then
    reads as the pit it most likely is, not as more stone); band_from_support: the body band's lower end is also at
    least its lower bound above the ground the robot stands on (build_maps' default_ground_z: the body's height
    less its standing height), so a cell below the feet's ground (the pit between two stones) does not read the
    stones' top edges beside it as a body obstacle, while ground at or above the feet's keeps its own band;
    fill_below_free: an unknown cell's fill is at most the bottom of the lowest voxel seen free in its column
    (Columns.free_floor_z), and the cells filled from it carry that on: the shadow behind a stone's far edge or a
    nosing, whose ground no ray reached but where rays passed below the top, reads as the drop it is, not as more
    top (False: the fill alone); free_drop_m: such a cell is a drop, a step obstacle, where its bound lies more than
    this below what its neighbours give it, and so is a cell filled from a drop (a grazing ray passes through the
    voxel of the floor it is about to hit, so one voxel's evidence is not a drop).
    """

    body_band_m: tuple[float, float] = (0.30, 0.52)
    body_ref_radius_m: float = 0.3
    body_above_ground_m: float | None = None
    body_step_m: float = 0.4
    wall_radius_m: float = 0.06
    low_radius_m: float = 0.3
    max_step_height_m: float = 0.32
    edge_radius_m: float = 0.03
    edge_height_m: float = 0.04
    min_support_m: float = 0.16
    leg_band_m: tuple[float, float] = (0.05, 0.30)
    knee_radius_m: float = 0.12
    knee_height_m: float = 0.25
    near_body_m: float = 0.08
    dense_radius_m: float = 0.3
    dense_fraction: float = 0.85
    dense_counts_high: bool = True
    high_is_step: bool = True
    speck_cells: int = 3
    close_cells: int = 2
    fill_min_cells: int = 12
    ceiling_above_m: float = 0.30
    fill_low_radius_m: float | None = None
    band_from_support: bool = False
    fill_below_free: bool = True
    free_drop_m: float = 0.02


@dataclass(frozen=True, eq=False)
class TerrainMaps:
    """The maps of one moment (all arrays (nx, ny), world frame, meters); see the module docstring."""

    origin_xy: tuple[float, float]
    resolution_m: float
    ground_height: NDArray[np.float64]
    observed: NDArray[np.bool_]
    body_obstacle: NDArray[np.bool_]
    step_obstacle: NDArray[np.bool_]
    sdf_body_m: NDArray[np.float64]
    sdf_step_m: NDArray[np.float64]
    grad_sdf_body: NDArray[np.float64]  # (nx, ny, 2)
    grad_sdf_step: NDArray[np.float64]  # (nx, ny, 2)
    clearance_m: NDArray[np.float64]
    t_s: float = 0.0
    drop_only: NDArray[np.bool_] | None = None

    @property
    def shape(self) -> tuple[int, int]:
        return (int(self.ground_height.shape[0]), int(self.ground_height.shape[1]))

    def cell_centers(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Gives world x (nx,) and y (ny,) of the cell centers (m)."""
        nx, ny = self.shape
        xs = self.origin_xy[0] + np.arange(nx, dtype=np.float64) * self.resolution_m
        ys = self.origin_xy[1] + np.arange(ny, dtype=np.float64) * self.resolution_m
        return xs.astype(np.float64), ys.astype(np.float64)

    def in_map(self, x: ArrayLike, y: ArrayLike) -> Any:
        """Gives whether world (x, y) lies on the map."""
        fx, fy = self._frac(x, y)
        nx, ny = self.shape
        return (fx >= -0.5) & (fx <= nx - 0.5) & (fy >= -0.5) & (fy <= ny - 0.5)

    def _frac(self, x: ArrayLike, y: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        return (
            (np.asarray(x, dtype=np.float64) - self.origin_xy[0]) / self.resolution_m,
            (np.asarray(y, dtype=np.float64) - self.origin_xy[1]) / self.resolution_m,
        )

    def _nearest(self, grid: NDArray[Any], x: ArrayLike, y: ArrayLike, outside: Any) -> Any:
        if isinstance(x, float) and isinstance(y, float) and math.isfinite(x + y):
            # One point: the same cell on Python floats (round() rounds half to even, as np.rint).
            nx, ny = grid.shape[:2]
            i = round((x - self.origin_xy[0]) / self.resolution_m)
            j = round((y - self.origin_xy[1]) / self.resolution_m)
            return grid.item(i, j) if 0 <= i < nx and 0 <= j < ny else outside
        fx, fy = self._frac(x, y)
        nx, ny = self.shape
        ix = np.rint(fx).astype(np.intp)
        iy = np.rint(fy).astype(np.intp)
        inside = (ix >= 0) & (ix < nx) & (iy >= 0) & (iy < ny)
        # (np.clip's values on the integer indices, without its dispatch cost)
        v = np.where(
            inside,
            grid[np.minimum(np.maximum(ix, 0), nx - 1), np.minimum(np.maximum(iy, 0), ny - 1)],
            outside,
        )
        return v.item() if v.ndim == 0 else v

    def _bilinear(self, grid: NDArray[np.float64], x: ArrayLike, y: ArrayLike) -> Any:
        if isinstance(x, float) and isinstance(y, float) and grid.ndim == 2 and math.isfinite(x + y):
            # One point (the planners ask for many, one at a time): the same arithmetic on Python floats.
            nx, ny = grid.shape
            fx = min(max((x - self.origin_xy[0]) / self.resolution_m, 0.0), nx - 1.000001)
            fy = min(max((y - self.origin_xy[1]) / self.resolution_m, 0.0), ny - 1.000001)
            i, j = math.floor(fx), math.floor(fy)
            ax, ay = fx - i, fy - j
            g = grid[i : i + 2, j : j + 2].tolist()
            return (g[0][0] * (1 - ax) + g[1][0] * ax) * (1 - ay) + (g[0][1] * (1 - ax) + g[1][1] * ax) * ay
        fx, fy = self._frac(x, y)
        nx, ny = self.shape
        fx = np.minimum(np.maximum(fx, 0.0), nx - 1.000001)  # np.clip, without its dispatch cost
        fy = np.minimum(np.maximum(fy, 0.0), ny - 1.000001)
        if grid.ndim == 2 and grid.flags.c_contiguous:
            # gathers from the flat grid by one index (four 1-D takes cost about half of four 2-D fancy indexings);
            # the same cells and the same arithmetic
            ixf, iyf = np.floor(fx), np.floor(fy)
            ax, ay = fx - ixf, fy - iyf
            k = (ixf * ny + iyf).astype(np.intp)
            flat = grid.ravel()
            bx = 1 - ax
            v = (flat.take(k) * bx + flat.take(k + ny) * ax) * (1 - ay) + (
                flat.take(k + 1) * bx + flat.take(k + (ny + 1)) * ax
            ) * ay
            return float(v) if v.ndim == 0 else v
        ix = np.floor(fx).astype(np.intp)
        iy = np.floor(fy).astype(np.intp)
        ax = (fx - ix)[..., None] if grid.ndim == 3 else fx - ix
        ay = (fy - iy)[..., None] if grid.ndim == 3 else fy - iy
        v = (grid[ix, iy] * (1 - ax) + grid[ix + 1, iy] * ax) * (1 - ay) + (
            grid[ix, iy + 1] * (1 - ax) + grid[ix + 1, iy + 1] * ax
        ) * ay
        if v.ndim == 0:
            return float(v)
        return v

    def height_at(self, x: ArrayLike, y: ArrayLike) -> Any:
        """Gives the ground height (m) at world (x, y), bilinear; the nearest border value off the map."""
        return self._bilinear(self.ground_height, x, y)

    def no_step(self, x: ArrayLike, y: ArrayLike) -> Any:
        """Gives whether a foot may not touch down at world (x, y) (False off the map)."""
        return self._nearest(self.step_obstacle, x, y, False)

    def no_body(self, x: ArrayLike, y: ArrayLike) -> Any:
        """Gives whether the body may not be over world (x, y) (False off the map)."""
        return self._nearest(self.body_obstacle, x, y, False)

    def sdf_step(self, x: ArrayLike, y: ArrayLike) -> Any:
        """Gives the signed distance (m) to the step obstacles at world (x, y), bilinear (border value off the map)."""
        return self._bilinear(self.sdf_step_m, x, y)

    def sdf_body(self, x: ArrayLike, y: ArrayLike) -> Any:
        """Gives the signed distance (m) to the body obstacles at world (x, y), bilinear (border value off the map)."""
        return self._bilinear(self.sdf_body_m, x, y)

    def sdf_step_grad(self, x: ArrayLike, y: ArrayLike) -> NDArray[np.float64]:
        """Gives the gradient (.., 2) of the step SDF at world (x, y) (points away from step obstacles)."""
        return np.asarray(self._bilinear(self.grad_sdf_step, x, y))

    def sdf_body_grad(self, x: ArrayLike, y: ArrayLike) -> NDArray[np.float64]:
        """Gives the gradient (.., 2) of the body SDF at world (x, y) (points away from body obstacles)."""
        return np.asarray(self._bilinear(self.grad_sdf_body, x, y))

    def _collide_sdf(self) -> NDArray[np.float64] | None:
        """The SDF (m) of the body obstacles less drop_only (the edges of drops below the body's band), made on first
        use; None where no drop is marked (sdf_body is that SDF then)."""
        d = self.__dict__
        if "_collide_sdf_m" not in d:
            drop = self.drop_only
            sdf = None
            if drop is not None and bool(np.any(drop & self.body_obstacle)):
                sdf = signed_distance(self.body_obstacle & ~drop, self.resolution_m)
            object.__setattr__(self, "_collide_sdf_m", sdf)
        return cast("NDArray[np.float64] | None", d["_collide_sdf_m"])

    def sdf_collide(self, x: ArrayLike, y: ArrayLike) -> Any:
        """Gives the signed distance (m) at world (x, y) to the body obstacles the body can hit (sdf_body less the
        edges of drops lower than the body's band: the open side of a landing the robot stands on), bilinear."""
        sdf = self._collide_sdf()
        return self._bilinear(self.sdf_body_m if sdf is None else sdf, x, y)

    def sdf_collide_grad(self, x: ArrayLike, y: ArrayLike) -> NDArray[np.float64]:
        """Gives the gradient (.., 2) of sdf_collide at world (x, y) (points away from the obstacles it reads)."""
        sdf = self._collide_sdf()
        if sdf is None:
            return self.sdf_body_grad(x, y)
        d = self.__dict__
        if "_collide_grad" not in d:
            object.__setattr__(self, "_collide_grad", _gradient(sdf, self.resolution_m))
        return np.asarray(self._bilinear(d["_collide_grad"], x, y))

    def clearance_at(self, x: ArrayLike, y: ArrayLike) -> Any:
        """Gives the free height (m) above the ground under an overhang at world (x, y); +inf where none."""
        return self._nearest(self.clearance_m, x, y, np.inf)


# -------------------------------------------------------------------------------------------------------------------


def signed_distance(mask: NDArray[np.bool_], resolution_m: float) -> NDArray[np.float64]:
    """Gives the signed distance field (m) of an obstacle mask: + outside, - inside, 0 on cell edges between them.

    Distances are center-to-center Euclidean distances to the nearest cell of the other kind, minus half a cell, so
    the zero level lies on the boundary between an obstacle cell and a free one. With no obstacle at all, every value
    is the map's diagonal (no obstacle within the map); with no free cell, minus the diagonal.
    """
    far = float(np.hypot(*mask.shape)) * resolution_m
    if not mask.any():
        return np.full(mask.shape, far)
    if mask.all():
        return np.full(mask.shape, -far)
    d_out = distance_transform(~mask)
    # Inside: only on the obstacles' bounding box grown by a cell (clipped to the map), whose ring is free: a free
    # cell beyond it is never nearer than the ring cell it projects to, so the distances are the same.
    rows = np.flatnonzero(mask.any(axis=1))
    cols = np.flatnonzero(mask.any(axis=0))
    i0, i1 = max(int(rows[0]) - 1, 0), min(int(rows[-1]) + 2, mask.shape[0])
    j0, j1 = max(int(cols[0]) - 1, 0), min(int(cols[-1]) + 2, mask.shape[1])
    sub = mask[i0:i1, j0:j1]
    d_in = distance_transform(sub)
    np.negative(d_in, out=d_in)
    np.copyto(d_out[i0:i1, j0:j1], d_in, where=sub)
    # Now d_out holds +d outside and -d inside (center to center); the zero level is half a cell from either.
    d_out -= np.where(mask, -0.5, 0.5)
    d_out *= resolution_m
    return d_out


@functools.lru_cache(maxsize=64)
def _disk_cached(radius_cells: float) -> NDArray[np.bool_]:
    r = int(np.floor(radius_cells))
    i = np.arange(-r, r + 1)
    d = (i[:, None] ** 2 + i[None, :] ** 2) <= radius_cells**2 + 1e-9
    d.flags.writeable = False
    return d


def _disk(radius_cells: float) -> NDArray[np.bool_]:
    """Gives the disk footprint of that radius (cells; read-only, made once per radius)."""
    return _disk_cached(float(radius_cells))


def _closing(mask: NDArray[np.bool_], footprint: NDArray[np.bool_]) -> NDArray[np.bool_]:
    """Gives ndimage.binary_closing(mask, structure=footprint): a dilation then an erosion, False beyond the grid."""
    return disk_filter(disk_filter(mask, footprint, np.maximum, False), footprint, np.minimum, False)


def _remove_specks(mask: NDArray[np.bool_], min_cells: int) -> NDArray[np.bool_]:
    """Gives the mask without its 8-connected components of fewer than min_cells cells."""
    if min_cells <= 1 or not mask.any():
        return mask
    if min_cells <= 3:
        speck = _small_components(mask, min_cells)
        return mask & ~speck if speck.any() else mask
    labels, n = ndimage.label(mask, structure=np.ones((3, 3), bool))
    sizes = np.bincount(labels.ravel(), minlength=n + 1)
    if sizes[1:].min() >= min_cells:
        return mask  # no speck (the same cells, without the gather)
    keep = sizes >= min_cells
    keep[0] = False
    return keep[labels]


def _box3_count(mask: NDArray[np.bool_]) -> NDArray[np.uint8]:
    """Gives per cell the number of mask cells in its 3 × 3 neighbourhood, itself included (none beyond the grid)."""
    nx, ny = mask.shape
    framed = np.zeros((nx + 2, ny + 2), np.uint8)
    framed[1:-1, 1:-1] = mask
    rows = framed[:, :-2] + framed[:, 1:-1]
    rows += framed[:, 2:]
    box = rows[:-2] + rows[1:-1]
    box += rows[2:]
    return box


def _small_components(mask: NDArray[np.bool_], min_cells: int) -> NDArray[np.bool_]:
    """Gives the cells of the mask's 8-connected components of fewer than min_cells (2 or 3) cells, from neighbour
    counts alone (no labelling): a lone cell has no neighbour; the two cells of a pair have one each, the other."""
    box = _box3_count(mask)
    speck = mask & (box == 1)
    if min_cells >= 3:
        one = mask & (box == 2)  # exactly one neighbour: a pair when that neighbour has exactly one too
        speck |= one & (_box3_count(one) >= 2)
    return speck


def _fill_ground(
    ground_z: NDArray[np.float64],
    fill_min_cells: int,
    default_z: float,
    cap: NDArray[np.float64] | None = None,
    drop_m: float = 0.0,
) -> tuple[NDArray[np.float64], NDArray[np.bool_] | None]:
    """Gives the ground with its unknown (NaN) cells filled, and which of them are drops (None without cap): those
    within fill_min_cells of known ones each round from the lowest of their 3 × 3 neighbours filled so far, the rest
    from the nearest filled cell (default_z when nothing is known). cap: (nx, ny) the most an unknown cell's fill
    may be (m; +inf: no bound), the free space seen in its column (Columns.free_floor_z). A cell whose cap lies more
    than drop_m below what its neighbours give it is a drop (no surface there: the one beside it ends), and so is a
    cell filled from a drop: its value is a bound, not a surface."""
    known = np.isfinite(ground_z)
    if not known.any():
        if cap is None:
            return np.full(ground_z.shape, default_z), None
        return np.minimum(default_z, cap), cap < default_z - drop_m
    # Each round an unknown cell with a known 3 × 3 neighbour takes their lowest value (infinite: unknown), on a grid
    # framed by +inf (the same as repeating the edge cells: they are in the window already). Only the round's
    # frontier (unknown cells beside known ones) changes: its cells' 3 × 3 minima are gathered from the flat framed
    # grid, the rest is not touched (the grid's 3 × 3 minimum each round costs several times more).
    nx, ny = ground_z.shape
    w = ny + 2
    framed = np.full((nx + 2, w), np.inf)
    h = framed[1:-1, 1:-1]
    np.copyto(h, ground_z, where=known)
    flat = framed.reshape(-1)
    known_f = np.zeros((nx + 2, w), dtype=bool)
    known_f[1:-1, 1:-1] = known
    known = known_f[1:-1, 1:-1]
    front_f = np.zeros((nx + 2, w), dtype=bool)
    around = _around_offsets(w)
    cap_f = drop_f = None
    any_drop = False  # whether drop_f holds a drop yet
    if cap is not None:
        cap_f = np.full((nx + 2, w), np.inf)
        cap_f[1:-1, 1:-1] = cap
        cap_f = cap_f.reshape(-1)
        drop_f = np.zeros((nx + 2) * w, dtype=bool)
    # The first round's frontier from the whole grid; after it, the cells left unknown (a fraction of them: the holes
    # wider than a cell or two) are listed once, and each round's frontier is those with a known 3 × 3 neighbour.
    known_flat = known_f.reshape(-1)
    unknown = None  # after the first round: the unknown cells (flat framed), in order
    for _ in range(fill_min_cells):
        if unknown is None:
            rows = known_f[:, :-2] | known_f[:, 1:-1]
            rows |= known_f[:, 2:]
            near = rows[:-2] | rows[1:-1]
            near |= rows[2:]
            np.greater(near, known, out=front_f[1:-1, 1:-1])  # near and not known
            idx = np.flatnonzero(front_f)
        else:
            beside = known_flat.take(around + unknown).any(axis=0)
            idx = unknown[beside]
            unknown = unknown[~beside]
        if idx.size == 0:  # all known
            break
        if cap_f is None or drop_f is None:
            flat[idx] = flat.take(around + idx).min(axis=0)
        else:
            at = around + idx
            around_vals = flat.take(at)
            c = cap_f[idx]
            vals = None
            if not any_drop:
                # No cell is a drop yet, so none passes one on: the lowest value alone, not which cell holds it
                # (the value of argmin's cell, bit for bit, unless it is a zero or NaN, whose ties can differ in
                # their bits: then argmin's, below). Most of a fill's cells are filled in its first round.
                vals = around_vals.min(axis=0)
                if not (np.abs(vals) > 0.0).all():
                    vals = None
            if vals is None:
                src = at[around_vals.argmin(axis=0), np.arange(idx.size)]
                vals = flat[src]
                new_drop = (c < vals - drop_m) | drop_f[src]
            else:
                new_drop = c < vals - drop_m
            drop_f[idx] = new_drop
            any_drop = any_drop or bool(new_drop.any())
            flat[idx] = np.minimum(vals, c)
        known_flat[idx] = True
        if unknown is None:
            np.logical_not(known, out=front_f[1:-1, 1:-1])  # (the frame stays False)
            unknown = np.flatnonzero(front_f)
    h = np.ascontiguousarray(h)
    drop = None if drop_f is None else drop_f.reshape(nx + 2, w)[1:-1, 1:-1].copy()
    if not known.all():
        # the nearest known cell's value (and drop), as a flat index per cell
        flat = _nearest_known(known)
        h = h.reshape(-1).take(flat)
        if cap is not None and drop is not None:
            far = ~known
            src_drop = drop.reshape(-1).take(flat)
            drop = np.where(far, src_drop | (cap < h - drop_m), drop)
            np.copyto(h, np.minimum(h, cap), where=far)
    return h, drop


# _nearest_known's direct search: at most this many unknown cells, and unknown × candidate pairs
_NEAREST_CELLS = 2048
_NEAREST_PAIRS = 1 << 16
_AROUND_DI = np.array([-1, -1, -1, 0, 0, 1, 1, 1], dtype=np.intp)
_AROUND_DJ = np.array([-1, 0, 1, -1, 1, -1, 0, 1], dtype=np.intp)


def _nearest_known(known: NDArray[np.bool_]) -> NDArray[np.integer]:
    """Gives per cell of the grid the flat index of its nearest known cell (itself where known), the same as
    ndimage's feature transform of ~known: of several nearest ones, the one in the lowest column, then row.

    The few unknown cells a fill leaves (past fill_min_cells of any seen cell: a map's far corner) are matched
    directly against the known cells beside an unknown one, the only ones that can be nearest (a known cell whose 8
    neighbours are all known has one nearer to any unknown cell: its neighbour towards it), by their exact squared
    distances and then (column, row) as the transform's ties fall (Maurer's algorithm as ndimage runs it: along
    axis 0 a tie goes to the lower row, then along axis 1 to the lower column). Many unknown cells: the transform."""
    nx, ny = known.shape
    unknown = np.flatnonzero(~known)
    if unknown.size <= _NEAREST_CELLS:
        ui, uj = np.divmod(unknown, ny)
        ni = (ui[:, None] + _AROUND_DI).reshape(-1)
        nj = (uj[:, None] + _AROUND_DJ).reshape(-1)
        on = (ni.astype(np.uintp) < nx) & (nj.astype(np.uintp) < ny)
        cand = np.unique(ni[on] * ny + nj[on])
        cand = cand[known.reshape(-1).take(cand)]
        if cand.size and unknown.size * cand.size <= _NEAREST_PAIRS:
            ci, cj = np.divmod(cand, ny)
            key = np.square(ui[:, None] - ci)
            key += np.square(uj[:, None] - cj)
            key *= nx * ny  # (squared distance, column, row), as one integer
            key += cj * nx + ci
            flat = np.arange(nx * ny)
            flat[unknown] = cand.take(key.argmin(axis=1))
            return flat.reshape(nx, ny)
    # its indices in int32 (ndimage's own are int64), as one flat index
    ft = np.empty((2, nx, ny), np.int32)
    ndimage.distance_transform_edt(~known, return_distances=False, return_indices=True, indices=ft)
    flat32 = ft[0]
    flat32 *= ny
    flat32 += ft[1]
    return flat32


_AROUND: dict[int, NDArray[np.intp]] = {}


def _around_offsets(width: int) -> NDArray[np.intp]:
    """Gives the flat offsets of a cell's 3 × 3 neighbourhood (itself included) in a grid `width` cells wide, as a
    column (9, 1); made once per width."""
    a = _AROUND.get(width)
    if a is None:
        a = _AROUND[width] = (
            (np.arange(-1, 2)[:, None] * width + np.arange(-1, 2)).reshape(9, 1).astype(np.intp)
        )
        a.flags.writeable = False
    return a


@dataclass(frozen=True, eq=False)
class _ObstacleVoxels:
    """The obstacle voxels of a column summary as a list (they are few: ~1-2 thousand of ~1 million voxels a scan):
    layer (m,) and cell (m,) of each (cell: the flat column index ix * ny + iy), intp; shape: (nx, ny)."""

    layer: NDArray[np.intp]
    cell: NDArray[np.intp]
    shape: tuple[int, int]


def _obstacle_voxels(columns: Columns) -> _ObstacleVoxels:
    """Gives the columns' obstacle voxels: their own list (columns.obstacle_voxels), else found in the occupancy
    over the band of layers that may hold them (layer-major order)."""
    nx, ny = columns.ground_z.shape
    if columns.obstacle_voxels is not None:
        k, c = columns.obstacle_voxels
        return _ObstacleVoxels(np.asarray(k, np.intp), np.asarray(c, np.intp), (nx, ny))
    obs = np.moveaxis(columns.obstacle, 2, 0)
    nz = obs.shape[0]
    lo, hi = columns.obstacle_layers if columns.obstacle_layers is not None else (0, nz - 1)
    lo, hi = max(lo, 0), min(hi, nz - 1)
    f = np.flatnonzero(obs[lo : hi + 1]) if hi >= lo else np.zeros(0, np.intp)
    cells = nx * ny
    k = f // cells
    return _ObstacleVoxels(k + lo, f - k * cells, (nx, ny))


def _any_between(
    vox: _ObstacleVoxels, z0: float, dz: float, z_lo: NDArray[np.float64], z_hi: NDArray[np.float64]
) -> NDArray[np.bool_]:
    """Gives per column (nx, ny) whether an obstacle layer's center lies in [z_lo, z_hi] (layers ceil((z_lo - z0) /
    dz) .. floor((z_hi - z0) / dz), within 1e-9 of a layer): each voxel tested against its own column's span."""
    out = np.zeros(vox.shape, dtype=bool)
    c = vox.cell
    if c.size:
        k_lo = np.ceil((z_lo.reshape(-1).take(c) - z0) / dz - 1e-9)
        k_hi = np.floor((z_hi.reshape(-1).take(c) - z0) / dz + 1e-9)
        k = vox.layer
        out.reshape(-1)[c[(k >= k_lo) & (k <= k_hi)]] = True
    return out


def _clearance(
    vox: _ObstacleVoxels, z0: float, dz: float, nz: int, h: NDArray[np.float64], above_m: float
) -> NDArray[np.float64]:
    """Gives per column the height of the lowest obstacle layer's underside at least above_m over the ground h
    (the first layer k >= ceil((h + above_m - z0) / dz), clipped to the grid's layers, above the ground: its center
    less half a layer, less h); +inf where no obstacle hangs that high."""
    clearance = np.full(h.shape, np.inf)
    c = vox.cell
    if c.size == 0:
        return clearance
    hc = h.reshape(-1).take(c)
    k_c = np.clip(np.ceil((hc + above_m - z0) / dz).astype(np.intp), 0, nz)
    over = vox.layer >= k_c
    if not over.any():
        return clearance
    cells = h.size
    k_first = np.full(cells, nz, dtype=np.intp)
    np.minimum.at(k_first, c[over], vox.layer[over])
    cols = np.flatnonzero(k_first < nz)
    z_c = z0 + k_first[cols] * dz - dz / 2
    clearance.reshape(-1)[cols] = z_c - h.reshape(-1)[cols]
    return clearance


def _disk_count(mask: NDArray[np.bool_], footprint: NDArray[np.bool_]) -> NDArray[np.int32]:
    """Gives per cell the number of mask cells under a centered, symmetric footprint (edge cells repeat beyond the
    map, as ndimage's mode="nearest"): one prefix sum, one difference per distinct row span (a disk's rows come
    in equal pairs and runs), one add per footprint row."""
    r = footprint.shape[0] // 2
    padded = pad2(mask, r)
    prefix = np.zeros(
        (padded.shape[0], padded.shape[1] + 1), np.int32
    )  # counts: int32 is exact and half the bytes
    np.cumsum(padded, axis=1, out=prefix[:, 1:])
    nx, ny = mask.shape
    count = np.zeros(mask.shape, np.int32)
    for (a, b), rows in _row_spans(footprint):
        # Row i spans padded columns y + a .. y + b - 1 around cell y (b - a cells), for every padded row at once.
        span = prefix[:, b : b + ny] - prefix[:, a : a + ny]
        for i in rows:
            count += span[i : i + nx]
    return count


_SPANS: dict[tuple[tuple[int, ...], bytes], tuple[tuple[tuple[int, int], tuple[int, ...]], ...]] = {}


def _row_spans(footprint: NDArray[np.bool_]) -> tuple[tuple[tuple[int, int], tuple[int, ...]], ...]:
    """Gives a footprint's row spans ((first, last + 1) of each row's cells, rows without any left out), each with
    the rows that have it; made once per footprint."""
    key = (footprint.shape, np.asarray(footprint, dtype=bool).tobytes())
    spans = _SPANS.get(key)
    if spans is None:
        by_span: dict[tuple[int, int], list[int]] = {}
        for i in range(footprint.shape[0]):
            row = np.flatnonzero(footprint[i])
            if row.size:
                by_span.setdefault((int(row[0]), int(row[-1]) + 1), []).append(i)
        spans = _SPANS[key] = tuple((ab, tuple(rows)) for ab, rows in by_span.items())
    return spans


def build_maps(
    columns: Columns, params: MapParams | None = None, default_ground_z: float = 0.0, t_s: float = 0.0
) -> TerrainMaps:
    """Gives the 2D maps (ground height, body and step obstacles, SDFs, clearance) of a column summary."""
    p = params or MapParams()
    res = columns.resolution_m
    observed = np.isfinite(columns.ground_z)
    cap = columns.free_floor_z if p.fill_below_free else None
    if cap is not None and not np.isfinite(cap).any():
        cap = None
    # (drop_unknown: unknown cells whose column was seen free more than free_drop_m below the height the fill gives
    # them, and those filled from them: the surface beside them, a stone's top or a landing, provably ends there)
    h, drop_unknown = _fill_ground(columns.ground_z, p.fill_min_cells, default_ground_z, cap, p.free_drop_m)
    if p.fill_low_radius_m is not None and not observed.all():
        low = disk_filter(
            np.where(observed, columns.ground_z, np.inf), _disk(p.fill_low_radius_m / res), np.minimum
        )
        h = np.where(~observed & np.isfinite(low), np.minimum(h, low), h)
    vox = _obstacle_voxels(columns)
    z0, dz = columns.z0_m, columns.dz_m

    def size(radius_m: float) -> int:
        return 2 * int(round(radius_m / res)) + 1

    h_low = square_filter(h, size(p.low_radius_m), np.minimum)
    h_ref = square_filter(h, size(p.body_ref_radius_m), np.maximum)
    lo, hi = p.body_band_m
    z_lo = h + lo if p.body_above_ground_m is None else np.maximum(h + lo, h_ref + p.body_above_ground_m)
    if p.band_from_support:
        z_lo = np.maximum(z_lo, default_ground_z + lo)
    body = _any_between(vox, z0, dz, z_lo, h + hi) | _any_between(vox, z0, dz, h_ref + lo, h_ref + hi)
    # A wall rising right beside a cell (higher than the body can pass over) blocks the body there.
    # The same on the top side: the rim of something tall (a rail or box seen from above with nothing seen under it).
    # The ground's max and min filters this needs (the wall's, the edge's, the knee's), each op's from one set of
    # row windows.
    wall_fp, edge_fp, knee_fp = (
        _disk(r_m / res) for r_m in (p.wall_radius_m, p.edge_radius_m, p.knee_radius_m)
    )
    wall_max, edge_max, knee_max = disk_filters(h, (wall_fp, edge_fp, knee_fp), np.maximum)
    wall_min, edge_min = disk_filters(h, (wall_fp, edge_fp), np.minimum)
    wall = wall_max - h > p.body_step_m
    rim = h - wall_min > p.body_step_m
    drop = None
    if p.band_from_support and (wall.any() or rim.any()):
        # The foot of a wall and the rim of a drop whose top lies below the body's band over the ground the robot
        # stands on (the floor beside a landing, the landing's open edge, seen from the landing): edges the body
        # path keeps off, but nothing the body can hit (drop_only; the barrier and the turn's room read the SDF
        # without them). Real ones (a wall, a box, a step rising into the band) are body obstacles either way.
        top = default_ground_z + lo
        low_wall, low_rim = wall & (wall_max < top), rim & (h < top)
        real = body | (wall & ~low_wall) | (rim & ~low_rim)
        drop = (low_wall | low_rim) & ~real
    body |= wall | rim
    body = _remove_specks(body, p.speck_cells)
    if p.close_cells > 0 and body.any():
        st = _disk(p.close_cells)
        padded = pad2(body, p.close_cells)
        body = _closing(padded, st)[p.close_cells : -p.close_cells, p.close_cells : -p.close_cells]
    if drop is not None and drop.any():
        # (what the closing added beside a drop's edge is the drop's too; real cells stay)
        c = max(p.close_cells, 1)
        drop = disk_filter(drop, _disk(c), np.maximum, False) & ~real

    spread = edge_max - edge_min
    step = spread > p.edge_height_m
    step |= _any_between(vox, z0, dz, h + p.leg_band_m[0], h + p.leg_band_m[1])
    knee = knee_max - h
    step |= knee > p.knee_height_m
    high = (h - h_low > p.max_step_height_m) if p.high_is_step else np.zeros(h.shape, dtype=bool)
    low_only = None if p.dense_counts_high else _remove_specks(step, p.speck_cells)
    step = _remove_specks(step | high, p.speck_cells)
    if drop_unknown is not None:
        step |= drop_unknown
    dense_src = step if low_only is None else low_only
    # Dense step obstacles become body obstacles.
    if dense_src.any():
        disk = _disk(p.dense_radius_m / res)
        body |= _disk_count(dense_src, disk) / np.count_nonzero(disk) > p.dense_fraction
    if body.any():
        step |= disk_filter(body, _disk(p.near_body_m / res), np.maximum, False)
    # Steppable patches narrower than min_support_m (a small box top, a sliver between obstacles) become no-step.
    r = max(int(round(p.min_support_m / 2 / res)), 1)
    step = _closing(pad2(step, r), _disk(r))[r:-r, r:-r]

    # Clearance under overhangs: the lowest obstacle layer at least ceiling_above_m above the ground.
    clearance = _clearance(vox, z0, dz, columns.obstacle.shape[2], h, p.ceiling_above_m)

    sdf_body = signed_distance(body, res)
    # (the step SDF on first use: see _StepSDFOnUse)
    return _StepSDFOnUse.made(
        origin_xy=columns.origin_xy,
        resolution_m=res,
        ground_height=h,
        observed=observed,
        body_obstacle=body,
        step_obstacle=step,
        sdf_body_m=sdf_body,
        clearance_m=clearance,
        t_s=t_s,
        drop_only=drop,
    )


class _StepSDFOnUse(TerrainMaps):
    """The maps build_maps gives: the step SDF and its gradient are computed when first read (the unified terrain
    pipeline never reads them: its footholds keep to the steppable regions), and so is the body SDF's gradient (read
    only near body obstacles), the same values as computed at once. Every other field is set when built;
    dataclasses.replace passes every field on (the lazy ones read)."""

    _LAZY = ("sdf_step_m", "grad_sdf_step", "grad_sdf_body")

    def __getattr__(self, name: str) -> Any:
        # (only for attributes not set: the lazy fields before their first read)
        if name == "grad_sdf_body":
            object.__setattr__(self, name, _gradient(self.sdf_body_m, self.resolution_m))
            return object.__getattribute__(self, name)
        if name in _StepSDFOnUse._LAZY:
            sdf = signed_distance(self.step_obstacle, self.resolution_m)
            object.__setattr__(self, "sdf_step_m", sdf)
            object.__setattr__(self, "grad_sdf_step", _gradient(sdf, self.resolution_m))
            return object.__getattribute__(self, name)
        raise AttributeError(f"{type(self).__name__!r} object has no attribute {name!r}")

    @staticmethod
    def made(**fields: Any) -> TerrainMaps:
        """Gives maps with these fields (all of TerrainMaps' but the lazy ones)."""
        if fields.keys() != _EAGER_FIELDS:
            raise TypeError(
                f"_StepSDFOnUse.made: needs the fields {sorted(_EAGER_FIELDS)}, got {sorted(fields)}"
            )
        maps = object.__new__(_StepSDFOnUse)
        for name, value in fields.items():
            object.__setattr__(maps, name, value)
        return maps


_EAGER_FIELDS = {f.name for f in dataclasses.fields(TerrainMaps)} - set(_StepSDFOnUse._LAZY)


def _gradient(sdf: NDArray[np.float64], res: float) -> NDArray[np.float64]:
    if not np.isfinite(sdf).all() or min(sdf.shape) < 2:
        return np.zeros((*sdf.shape, 2))
    gx, gy = np.gradient(sdf, res)
    return np.stack([gx, gy], axis=-1)


def columns_from_scene(
    scene: TerrainScene,
    center_xy: tuple[float, float] = (0.0, 0.0),
    half_extent_m: float = 2.0,
    resolution_m: float = 0.03,
    z_range_m: tuple[float, float] = (-1.0, 1.6),
) -> Columns:
    """Gives ground-truth columns of a scene (its true ground and its obstacle boxes), for tests and planning
    without perception; the grid is aligned like a VoxelMap's (cell centers on multiples of resolution_m)."""
    n = int(round(2 * half_extent_m / resolution_m)) | 1
    half = n // 2
    ix0 = int(round(center_xy[0] / resolution_m)) - half
    iy0 = int(round(center_xy[1] / resolution_m)) - half
    iz0 = int(round(z_range_m[0] / resolution_m))
    nz = int(round((z_range_m[1] - z_range_m[0]) / resolution_m))
    xs = (ix0 + np.arange(n)) * resolution_m
    ys = (iy0 + np.arange(n)) * resolution_m
    zs = (iz0 + np.arange(nz)) * resolution_m
    ground = np.asarray(scene.ground_height(xs[:, None], ys[None, :]), dtype=np.float64)
    obstacle = np.zeros((n, n, nz), dtype=bool)
    hr = resolution_m / 2
    for x0, x1, y0, y1, z0, z1 in scene.obstacle_boxes:
        ix = (xs + hr > x0) & (xs - hr < x1)
        iy = (ys + hr > y0) & (ys - hr < y1)
        iz = (zs + hr > z0) & (zs - hr < z1)
        obstacle |= ix[:, None, None] & iy[None, :, None] & iz[None, None, :]
    return Columns((xs[0], ys[0]), resolution_m, ground, obstacle, float(zs[0]), resolution_m)


def maps_from_scene(
    scene: TerrainScene,
    center_xy: tuple[float, float] = (0.0, 0.0),
    half_extent_m: float = 2.0,
    resolution_m: float = 0.03,
    params: MapParams | None = None,
) -> TerrainMaps:
    """Gives the maps of a scene's ground truth (perfect perception) around center_xy."""
    return build_maps(columns_from_scene(scene, center_xy, half_extent_m, resolution_m), params)


def maps_from_grids(
    origin_xy: tuple[float, float],
    resolution_m: float,
    ground_height: NDArray[np.float64],
    step_obstacle: NDArray[np.bool_],
    body_obstacle: NDArray[np.bool_] | None = None,
    t_s: float = 0.0,
) -> TerrainMaps:
    """Gives maps made directly from grids (for tests, synthetic scenes and user-drawn keep-out areas)."""
    h = np.asarray(ground_height, dtype=np.float64)
    step = np.asarray(step_obstacle, dtype=bool)
    body = np.zeros_like(step) if body_obstacle is None else np.asarray(body_obstacle, dtype=bool)
    if h.shape != step.shape or body.shape != step.shape:
        raise ValueError(
            f"maps_from_grids: shapes differ: ground {h.shape}, step {step.shape}, body {body.shape}"
        )
    sdf_body = signed_distance(body, resolution_m)
    sdf_step = signed_distance(step, resolution_m)
    return TerrainMaps(
        origin_xy=(float(origin_xy[0]), float(origin_xy[1])),
        resolution_m=resolution_m,
        ground_height=h,
        observed=np.ones(h.shape, dtype=bool),
        body_obstacle=body,
        step_obstacle=step,
        sdf_body_m=sdf_body,
        sdf_step_m=sdf_step,
        grad_sdf_body=_gradient(sdf_body, resolution_m),
        grad_sdf_step=_gradient(sdf_step, resolution_m),
        clearance_m=np.full(h.shape, np.inf),
        t_s=t_s,
    )
