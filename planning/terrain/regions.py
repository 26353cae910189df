"""Steppable regions: the ground-height map segmented into planar regions, each covered by convex polygons.

From a ``TerrainMaps`` (maps.py):

- a cell is steppable when it is not a step obstacle, its slope (one-sided differences) is at most
  ``max_slope_deg`` and no 4-neighbour rises above it by more than ``max_jump_m`` (the foot of a riser or of a
  stone's side), so a stair tread, a stone's top, the floor between boxes and a slope each come out as one
  connected region;
- each region gets a least-squares plane (normal, height at a point) and its RMS residual (its roughness);
- the region is inset by the foot's radius (``RobotModel.foot_radius_m``) plus ``edge_margin_m``: a foot centred
  in the inset keeps its whole sole on the region;
- the inset is covered by convex polygons grown greedily around its deepest cells: from a seed, the nearest cell
  outside the inset cuts the plane with a half-plane facing the seed, the cells beyond it are dropped, and so on
  until none is left (``convex_around`` does the same around any point, for a foothold).

Everything is numpy over the whole grid except the polygon growth, whose loop runs once per half-plane over the
outside cells that border one region. Arrays are [ix, iy] like the maps'. A polygon's half-planes ``A p <= b``
(world xy, m) are what the step QP takes as hard constraints.
"""

from __future__ import annotations

import functools
import math
import time
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage

from planning.terrain.gridops import disk_filter, distance_transform, square_filter
from planning.terrain.maps import TerrainMaps

_CROSS = ndimage.generate_binary_structure(2, 1)
_SQUARE3 = np.ones((3, 3), dtype=bool)


@dataclass(frozen=True)
class RegionParams:
    """Region segmentation (lengths m, angles deg).

    foot_radius_m: the foot's radius (from RobotModel; the inset's first part); edge_margin_m: kept between the
    foot's rim and a region's edge (tracking error, the map's cell); max_slope_deg: steeper cells are not
    steppable; max_jump_m: a cell with a 4-neighbour higher by more than this is an edge's foot (a riser, a stone's
    side) and not steppable; min_inset_cells: a region whose inset has fewer cells is dropped (no room for a foot);
    max_polygons: convex polygons per region at most; cover_fraction: a region stops getting polygons once this
    share of its inset is covered; max_planes: half-planes grown per polygon at most (a polygon that needs more is
    shrunk about its seed until it excludes what is left); require_observed: cells the sensor never saw (filled in)
    are not steppable; inset_from_shadow: the inset is also measured from the sensor's shadows (see shadow_cells:
    never-seen cells beyond seen ground as seen from the sensor, as behind a stone's far edge or a stair's nosing,
    whose fill from the seen side reads as more of it), on the occluder's side only (see shadow_depth): a cell is
    inset from a shadow cell that lies beyond it as seen from the sensor, so a stone's or a tread's far edge is
    inset while the floor seen beyond a box's shadow keeps its footholds (the shadow's own cells likewise: a cell
    with more shadow beyond it is inset from it); they stay steppable and keep their region (labels and planes as
    without it). Needs the sensor's position (segment_regions' view_xy); without it, off. shadow_cone_deg: a
    shadow cell counts for a cell when the direction from the cell to it is within this angle of the view
    direction (from the sensor through the cell); 90 is the half-plane beyond the cell, 180 every direction (the
    session-12 rule, which also inset the floor behind every box); shadow_drop_m, shadow_drop_radius_m: a shadow
    starts only behind a seen cell higher by more than shadow_drop_m than the lowest seen ground within
    shadow_drop_radius_m (a square window; a drop edge: a stone's top, a nosing, a box top), not behind level
    ground beside a patch the cameras missed, as the ragged never-seen patch under and behind the moving body
    (None: behind any seen cell, the session-12 rule). Off by default: the clutter quick spec 6 of 12 against
    main's 10 (terrain notes, session 13).
    """

    foot_radius_m: float = 0.02
    edge_margin_m: float = 0.02
    max_slope_deg: float = 35.0
    max_jump_m: float = 0.04
    min_inset_cells: int = 2
    max_polygons: int = 6
    cover_fraction: float = 0.9
    max_planes: int = 12
    require_observed: bool = False
    inset_from_shadow: bool = False
    shadow_cone_deg: float = 60.0
    shadow_drop_m: float | None = 0.04
    shadow_drop_radius_m: float = 0.3

    @staticmethod
    def from_robot(robot: object, **overrides: float | int | bool) -> RegionParams:
        """Gives the parameters with the foot radius of `robot` (a RobotModel)."""
        return RegionParams(foot_radius_m=float(robot.foot_radius_m), **overrides)  # type: ignore[attr-defined, arg-type]

    @property
    def inset_m(self) -> float:
        return self.foot_radius_m + self.edge_margin_m


@dataclass(frozen=True, eq=False)
class ConvexRegion:
    """A convex polygon of steppable ground (world xy, m) on one planar region.

    label: the region's label; A (m, 2), b (m,): the polygon is A p <= b (unit outward normals); vertices (v, 2),
    counter-clockwise; seed (2,): the point it was grown around; normal (3,), z0, xy0 (2,): the region's plane
    (height z0 at xy0); area_m2."""

    label: int
    A: NDArray[np.float64]
    b: NDArray[np.float64]
    vertices: NDArray[np.float64]
    seed: NDArray[np.float64]
    normal: NDArray[np.float64]
    z0: float
    xy0: NDArray[np.float64]
    area_m2: float

    def contains(self, xy: NDArray[np.float64], tol_m: float = 1e-9) -> NDArray[np.bool_]:
        """Gives whether points (.., 2) lie in the polygon (within tol_m)."""
        p = np.asarray(xy, dtype=np.float64)
        return np.all(p @ self.A.T <= self.b + tol_m, axis=-1)

    def distance(self, xy: NDArray[np.float64]) -> float:
        """Gives the distance (m) from a point to the polygon (0 inside)."""
        p = np.asarray(xy, dtype=np.float64).reshape(2)
        if bool(self.contains(p)):
            return 0.0
        v = self.vertices
        w = np.roll(v, -1, axis=0)
        e = w - v
        t = np.clip(np.sum((p - v) * e, axis=1) / np.maximum(np.sum(e * e, axis=1), 1e-18), 0.0, 1.0)
        return float(np.min(np.hypot(*(v + t[:, None] * e - p).T)))

    def project(self, xy: NDArray[np.float64]) -> NDArray[np.float64]:
        """Gives the point of the polygon nearest to xy (2,).

        On Python floats (the footholds ask for one point at a time): the same arithmetic as the edge-by-edge
        projection over arrays, several times faster for a dozen edges."""
        p = np.asarray(xy, dtype=np.float64).reshape(2)
        px, py = float(p[0]), float(p[1])
        inside = True
        for (ax, ay), bi in self._planes:
            if ax * px + ay * py > bi + 1e-9:
                inside = False
                break
        if inside:
            return p.copy()
        best = math.inf
        qx = qy = 0.0
        verts = self._verts
        for k, (vx, vy) in enumerate(verts):
            wx, wy = verts[k + 1] if k + 1 < len(verts) else verts[0]
            ex, ey = wx - vx, wy - vy
            t = ((px - vx) * ex + (py - vy) * ey) / max(ex * ex + ey * ey, 1e-18)
            t = min(max(t, 0.0), 1.0)
            cx, cy = vx + t * ex, vy + t * ey
            d2 = (cx - px) ** 2 + (cy - py) ** 2
            if d2 < best:
                best, qx, qy = d2, cx, cy
        return np.array([qx, qy])

    @functools.cached_property
    def _planes(self) -> list[tuple[tuple[float, float], float]]:
        return list(zip(map(tuple, self.A.tolist()), self.b.tolist(), strict=True))

    @functools.cached_property
    def _verts(self) -> list[tuple[float, float]]:
        return [(float(x), float(y)) for x, y in self.vertices.tolist()]

    def height_at(self, xy: NDArray[np.float64]) -> NDArray[np.float64]:
        """Gives the plane's height (m) at points (.., 2)."""
        n = self.normal
        p = np.asarray(xy, dtype=np.float64)
        if p.shape == (2,):
            # one point (the footholds ask for one at a time): the same arithmetic on Python floats
            (px, py), (x0, y0), (n0, n1, n2) = p.tolist(), self.xy0.tolist(), n.tolist()
            return np.asarray(self.z0 - ((px - x0) * n0 + (py - y0) * n1) / n2, dtype=np.float64)
        d = p - self.xy0
        return np.asarray(self.z0 - (d @ n[:2]) / n[2], dtype=np.float64)


@dataclass(frozen=True, eq=False)
class SteppableRegions:
    """The steppable regions of one set of maps (arrays (nx, ny) like the maps').

    labels: region label per cell (0: not steppable; 1..n_regions); inset: cells a foot's centre may take (its sole
    stays on its region); depth_m: distance from each steppable cell's centre to its region's edge (0 elsewhere);
    normals (n + 1, 3), z0 (n + 1,), xy0 (n + 1, 2): each label's least-squares plane (row 0 unused); roughness_m
    (n + 1,): its RMS residual; area_m2 (n + 1,): its area; polygons: the convex polygons covering the insets;
    elapsed_ms: the time segment_regions took."""

    origin_xy: tuple[float, float]
    resolution_m: float
    labels: NDArray[np.int32]
    inset: NDArray[np.bool_]
    depth_m: NDArray[np.float64]
    normals: NDArray[np.float64]
    z0: NDArray[np.float64]
    xy0: NDArray[np.float64]
    roughness_m: NDArray[np.float64]
    area_m2: NDArray[np.float64]
    polygons: tuple[ConvexRegion, ...]
    params: RegionParams
    elapsed_ms: float = 0.0

    @property
    def n_regions(self) -> int:
        return int(self.normals.shape[0] - 1)

    def label_at(self, x: float, y: float) -> int:
        """Gives the region label of the cell at world (x, y) (0: none or off the map)."""
        ix, iy = self._cell(x, y)
        nx, ny = self.labels.shape
        if 0 <= ix < nx and 0 <= iy < ny:
            return int(self.labels[ix, iy])
        return 0

    def slope_deg(self, label: int) -> float:
        """Gives the slope (deg) of a region's plane."""
        return float(np.degrees(np.arccos(np.clip(self.normals[label, 2], -1.0, 1.0))))

    def polygons_of(self, label: int) -> tuple[ConvexRegion, ...]:
        return tuple(p for p in self.polygons if p.label == label)

    @functools.cached_property
    def inset_labels(self) -> NDArray[np.int32]:
        """The labels of the inset cells (0 elsewhere), computed once per regions object (the footholds' region
        choice reads it eight times a step-plan tick)."""
        return np.where(self.inset, self.labels, 0).astype(np.int32, copy=False)

    def _cell(self, x: float, y: float) -> tuple[int, int]:
        return (
            int(round((x - self.origin_xy[0]) / self.resolution_m)),
            int(round((y - self.origin_xy[1]) / self.resolution_m)),
        )


# -------------------------------------------------------------------------------------------------------------------


def steppable_cells(maps: TerrainMaps, params: RegionParams) -> NDArray[np.bool_]:
    """Gives the cells a foot may stand on (see the module docstring): free, flat enough, not at a riser's foot.

    The slope along each axis is the gentler of the two one-sided differences, so the cell on either side of an
    edge keeps the slope of its own side; the edge itself is cut at the lower cell (one with a 4-neighbour higher by
    more than max_jump_m), whose centre is where the riser's face begins: the upper cell keeps its true distance to
    the edge, and the regions on either side come out apart."""
    h = maps.ground_height
    res = maps.resolution_m
    ok = ~maps.step_obstacle
    if params.require_observed:
        ok &= maps.observed
    # Differences to the next cell along each axis (beyond the map's edge the edge cell repeats: 0 there).
    d0 = h[1:] - h[:-1]
    d1 = h[:, 1:] - h[:, :-1]
    # Slope: along each axis the gentler of the two one-sided differences (0 at the map's edge), squared.
    a0, a1 = np.abs(d0), np.abs(d1)
    g = np.zeros(h.shape)
    np.minimum(a0[:-1], a0[1:], out=g[1:-1])
    g *= g
    gy = np.zeros(h.shape)
    np.minimum(a1[:, :-1], a1[:, 1:], out=gy[:, 1:-1])
    gy *= gy
    g += gy
    ok &= g <= (math.tan(math.radians(params.max_slope_deg)) * res) ** 2
    # An edge's foot: a 4-neighbour higher by more than max_jump_m.
    jump = params.max_jump_m
    if jump < 0.0:
        ok[...] = False
    ok[:-1] &= d0 <= jump
    ok[1:] &= d0 >= -jump
    ok[:, :-1] &= d1 <= jump
    ok[:, 1:] &= d1 >= -jump
    return np.asarray(ok, dtype=bool)


def shadow_cells(
    maps: TerrainMaps,
    view_xy: tuple[float, float],
    depth_cells: int,
    drop_m: float | None = None,
    drop_radius_m: float = 0.3,
) -> NDArray[np.bool_]:
    """Gives the cells in the sensor's shadow, up to depth_cells deep: never-seen cells (not maps.observed) whose
    neighbour one cell toward view_xy (the sensor, world m; the 8-neighbour nearest that direction) is an occluder
    or in the shadow. A ray from view_xy passed over such a cell to hit ground beyond it, so it lies behind what was
    seen (the pit behind a stone's far edge, the tread below a nosing); the never-seen patch under the robot itself
    (seen cells around it, none between it and the sensor) is not a shadow. An occluder: a seen cell (drop_m None),
    or a seen cell higher by more than drop_m than the lowest seen ground within drop_radius_m (square window): a
    drop edge, as a stone's top, a nosing or a box top is, not level ground beside a patch the cameras missed (the
    ragged never-seen patch under and behind the moving body)."""
    seen = np.asarray(maps.observed, dtype=bool)
    out = np.zeros(seen.shape, dtype=bool)
    if depth_cells <= 0 or seen.all():
        return out
    res = maps.resolution_m
    occluder = seen
    if drop_m is not None:
        low = square_filter(
            np.where(seen, maps.ground_height, np.inf), 2 * int(round(drop_radius_m / res)) + 1, np.minimum
        )
        occluder = seen & (maps.ground_height > low + drop_m)
        if not occluder.any():
            return out
    xs, ys = maps.cell_centers()
    dx = (xs - float(view_xy[0]))[:, None]
    dy = (ys - float(view_xy[1]))[None, :]
    r = np.sqrt(dx * dx + dy * dy)
    far = r > 0.5 * res
    rs = np.where(far, r, 1.0)
    # the neighbour toward the sensor: the unit vector back to it, each component rounded to -1, 0 or 1
    di = np.where(far, -np.rint(dx / rs), 0).astype(np.intp)
    dj = np.where(far, -np.rint(dy / rs), 0).astype(np.intp)
    nx, ny = seen.shape
    ii = np.clip(np.arange(nx)[:, None] + di, 0, nx - 1)
    jj = np.clip(np.arange(ny)[None, :] + dj, 0, ny - 1)
    unseen = ~seen & far
    lit = occluder.copy()
    for _ in range(depth_cells):
        nxt = unseen & lit[ii, jj]
        if np.array_equal(nxt, out):
            break
        out = nxt
        lit = occluder | out
    return out


def shadow_depth(
    shadow: NDArray[np.bool_],
    origin_xy: tuple[float, float],
    res: float,
    view_xy: tuple[float, float],
    reach_m: float,
    cone_deg: float,
) -> NDArray[np.float64]:
    """Gives each cell's distance (m) to the edge of the nearest shadow cell beyond it as seen from view_xy: from
    the cell's centre to the shadow cell's centre less half a cell (as the inset's distance transform measures
    edges), counting only shadow cells whose direction from the cell is within cone_deg of the view direction
    (view_xy to the cell); +inf where none lies within reach_m, and at the cell under view_xy (no direction). So the
    seen top before a shadow (a stone's far edge, a nosing, a box top's far side: the occluder) is near it, and the
    seen ground beyond the shadow (the floor behind a box) is not. Pure function of its inputs; arrays [ix, iy]."""
    out = np.full(shadow.shape, np.inf)
    if not shadow.any() or reach_m <= 0.0:
        return out
    nx, ny = shadow.shape
    xs = origin_xy[0] + np.arange(nx, dtype=np.float64) * res
    ys = origin_xy[1] + np.arange(ny, dtype=np.float64) * res
    dx = (xs - float(view_xy[0]))[:, None]
    dy = (ys - float(view_xy[1]))[None, :]
    r = np.sqrt(dx * dx + dy * dy)
    far = r > 0.5 * res
    rs = np.where(far, r, 1.0)
    ux = np.where(far, dx / rs, 0.0)
    uy = np.where(far, dy / rs, 0.0)
    cos_cone = math.cos(math.radians(min(max(cone_deg, 0.0), 180.0)))
    k = int(math.floor(reach_m / res + 0.5))
    for a in range(-k, k + 1):
        for b in range(-k, k + 1):
            norm = math.hypot(a, b)
            d = norm * res - 0.5 * res
            if norm == 0.0 or d > reach_m:
                continue
            # the shadow at cell + (a, b), within the cone about the view direction
            sh = np.zeros(shadow.shape, dtype=bool)
            sh[max(0, -a) : nx - max(0, a), max(0, -b) : ny - max(0, b)] = shadow[
                max(0, a) : nx - max(0, -a), max(0, b) : ny - max(0, -b)
            ]
            hit = sh & far & (a * ux + b * uy >= cos_cone * norm - 1e-9)
            out[hit] = np.minimum(out[hit], d)
    return out


def segment_regions(
    maps: TerrainMaps,
    params: RegionParams | None = None,
    cover: bool = True,
    view_xy: tuple[float, float] | None = None,
) -> SteppableRegions:
    """Gives the steppable regions of the maps: labels, planes, insets and (cover: True) the convex polygons that
    cover them; the loop leaves cover off and grows a polygon where a foot goes (convex_around), which costs a
    fraction of covering every region. view_xy: where the sensor scanned from (world m; for inset_from_shadow)."""
    t0 = time.perf_counter()
    p = params or RegionParams()
    res = maps.resolution_m
    h = maps.ground_height
    ok = steppable_cells(maps, p)
    labels, n = ndimage.label(ok, structure=_CROSS)
    # Distance from a cell's centre to the nearest non-steppable cell's centre, less half a cell: to the edge.
    # (the map's border counts as an edge: nothing is known beyond it)
    edt = distance_transform(ok, edge=True) if n else np.zeros(h.shape)
    depth = np.where(ok, edt * res - 0.5 * res, 0.0)
    # (inset_from_shadow: the distance to the shadow beyond a cell counts too, the shadow's own cells included;
    # the labels as without it)
    if p.inset_from_shadow and view_xy is not None and n:
        shadow = shadow_cells(
            maps, view_xy, int(math.ceil(p.inset_m / res)) + 1, p.shadow_drop_m, p.shadow_drop_radius_m
        )
        if shadow.any():
            beyond = shadow_depth(shadow, maps.origin_xy, res, view_xy, p.inset_m + res, p.shadow_cone_deg)
            depth = np.where(ok, np.minimum(depth, beyond), 0.0)
    inset = ok & (depth >= p.inset_m - 1e-9)
    # Regions with too little room for a foot are dropped; the others are numbered 1..n in label order.
    if n:
        inset_count = np.bincount(labels[inset], minlength=n + 1)
        keep = inset_count >= p.min_inset_cells
        keep[0] = False
        relabel = np.zeros(n + 1, dtype=np.int32)
        relabel[keep] = np.arange(1, int(keep.sum()) + 1, dtype=np.int32)
        labels = relabel.take(labels)
        n = int(keep.sum())
    labels = labels.astype(np.int32)
    inset &= labels > 0
    depth = np.where(labels > 0, depth, 0.0)
    xs, ys = maps.cell_centers()
    X = np.broadcast_to(xs[:, None], h.shape)
    Y = np.broadcast_to(ys[None, :], h.shape)
    normals, z0, xy0, rough, area = _fit_planes(labels, n, X, Y, h, res)
    polygons: list[ConvexRegion] = []
    if n and cover:
        polygons = _cover(labels, inset, depth, n, xs, ys, p, normals, z0, xy0)
    return SteppableRegions(
        origin_xy=maps.origin_xy,
        resolution_m=res,
        labels=labels,
        inset=inset,
        depth_m=depth,
        normals=normals,
        z0=z0,
        xy0=xy0,
        roughness_m=rough,
        area_m2=area,
        polygons=tuple(polygons),
        params=p,
        elapsed_ms=(time.perf_counter() - t0) * 1e3,
    )


def _fit_planes(
    labels: NDArray[np.int32],
    n: int,
    X: NDArray[np.float64],
    Y: NDArray[np.float64],
    h: NDArray[np.float64],
    res: float,
) -> tuple[NDArray[np.float64], ...]:
    """Gives each label's least-squares plane z = a (x - x̄) + b (y - ȳ) + z̄ as (normals, z̄, (x̄, ȳ)), its RMS
    residual and its area.

    From per-label moments, summed by bincount. x depends on the cell's row only and y on its column only, so the
    sums over x (y) come from per-(label, row) ((label, column)) counts and height sums times the rows' x: six
    bincounts and a few small products, no per-cell gathers. The moments are taken about the map's centre and the
    mean height (well conditioned), then centred per label; a region one cell wide has its spread along that axis
    set to exactly zero (true spreads are 0 or at least half a cell squared), so a flat strip gets no slope across
    itself."""
    nx, ny = labels.shape
    L = n + 1
    xs = np.asarray(X[:, 0], dtype=np.float64)
    ys = np.asarray(Y[0, :], dtype=np.float64)
    cx, cy = 0.5 * (float(xs[0]) + float(xs[-1])), 0.5 * (float(ys[0]) + float(ys[-1]))
    u, v = xs - cx, ys - cy
    zr = float(h.mean())
    # (bincount's own index type: converted once, not in each of the bincounts)
    m = labels.reshape(-1).astype(np.intp)
    rows, cols = _row_col_index(nx, ny)
    key_r = m * nx
    key_r += rows
    key_c = m * ny
    key_c += cols
    hz = (h - zr).reshape(-1)
    c_r = np.bincount(key_r, minlength=L * nx).reshape(L, nx).astype(np.float64)
    c_c = np.bincount(key_c, minlength=L * ny).reshape(L, ny).astype(np.float64)
    h_r = np.bincount(key_r, weights=hz, minlength=L * nx).reshape(L, nx)
    h_c = np.bincount(key_c, weights=hz, minlength=L * ny).reshape(L, ny)
    v_r = np.bincount(key_r, weights=np.broadcast_to(v, (nx, ny)).reshape(-1), minlength=L * nx).reshape(
        L, nx
    )
    s_zz = np.bincount(m, weights=hz * hz, minlength=L)
    w = c_r.sum(axis=1)
    safe = np.maximum(w, 1.0)
    mu, mv, mz = (c_r @ u) / safe, (c_c @ v) / safe, h_r.sum(axis=1) / safe
    sxx = c_r @ (u * u) - w * mu * mu
    syy = c_c @ (v * v) - w * mv * mv
    sxy = v_r @ u - w * mu * mv
    sxz = h_r @ u - w * mu * mz
    syz = h_c @ v - w * mv * mz
    szz = s_zz - w * mz * mz
    # A spread is 0 (one row / column) or at least res² / 2; what is below a thousandth of that is rounding.
    tiny = 1e-3 * res * res
    flat_x, flat_y = sxx < tiny, syy < tiny
    sxx[flat_x] = 0.0
    syy[flat_y] = 0.0
    sxy[flat_x | flat_y] = 0.0
    sxz[flat_x] = 0.0
    syz[flat_y] = 0.0
    det = sxx * syy - sxy * sxy
    good = det > 1e-12 * np.maximum(sxx * syy, 1e-30)
    a = np.where(good, (syy * sxz - sxy * syz) / np.where(good, det, 1.0), 0.0)
    b = np.where(good, (sxx * syz - sxy * sxz) / np.where(good, det, 1.0), 0.0)
    normals = np.stack([-a, -b, np.ones_like(a)], axis=1)
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    # Sum of squared residuals from the moments: szz - 2 a sxz - 2 b syz + a² sxx + 2 a b sxy + b² syy.
    ss = szz - 2 * a * sxz - 2 * b * syz + a * a * sxx + 2 * a * b * sxy + b * b * syy
    rough = np.sqrt(np.maximum(ss, 0.0) / safe)
    rough[0] = 0.0
    area = w * res * res
    area[0] = 0.0
    has = w > 0
    z0 = np.where(has, mz + zr, 0.0)
    xy0 = np.stack([np.where(has, mu + cx, 0.0), np.where(has, mv + cy, 0.0)], axis=1)
    return normals, z0, xy0, rough, area


_ROW_COL: dict[tuple[int, int], tuple[NDArray[np.intp], NDArray[np.intp]]] = {}


def _row_col_index(nx: int, ny: int) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
    """Gives each cell's row and column of an (nx, ny) grid, flat (read-only, made once per shape)."""
    rc = _ROW_COL.get((nx, ny))
    if rc is None:
        r = np.repeat(np.arange(nx, dtype=np.intp), ny)
        c = np.tile(np.arange(ny, dtype=np.intp), nx)
        r.flags.writeable = False
        c.flags.writeable = False
        rc = _ROW_COL[(nx, ny)] = (r, c)
    return rc


def _cover(
    labels: NDArray[np.int32],
    inset: NDArray[np.bool_],
    depth: NDArray[np.float64],
    n: int,
    xs: NDArray[np.float64],
    ys: NDArray[np.float64],
    p: RegionParams,
    normals: NDArray[np.float64],
    z0: NDArray[np.float64],
    xy0: NDArray[np.float64],
) -> list[ConvexRegion]:
    """Gives convex polygons covering each region's inset, grown around its deepest uncovered cells."""
    out: list[ConvexRegion] = []
    objs = ndimage.find_objects(np.where(inset, labels, 0), max_label=n)
    nx, ny = labels.shape
    for lab in range(1, n + 1):
        sl = objs[lab - 1]
        if sl is None:
            continue
        i0, i1 = max(sl[0].start - 1, 0), min(sl[0].stop + 1, nx)
        j0, j1 = max(sl[1].start - 1, 0), min(sl[1].stop + 1, ny)
        mine = inset[i0:i1, j0:j1] & (labels[i0:i1, j0:j1] == lab)
        outside = _border_points(mine, xs[i0:i1], ys[j0:j1], depth[i0:i1, j0:j1])
        ci, cj = np.nonzero(mine)
        cells = np.column_stack([xs[i0:i1][ci], ys[j0:j1][cj]])
        d = depth[i0:i1, j0:j1][ci, cj]
        covered = np.zeros(len(cells), dtype=bool)
        box = _box_of(cells, 0.5 * (xs[1] - xs[0]) if len(xs) > 1 else 0.0)
        for _ in range(p.max_polygons):
            left = ~covered
            if np.count_nonzero(left) < max(p.min_inset_cells, 1):
                break
            seed = cells[int(np.argmax(np.where(left, d, -np.inf)))]
            poly = _grow(seed, outside, box, p.max_planes, p.inset_m, lab, normals, z0, xy0)
            if poly is None:
                covered[int(np.argmax(np.where(left, d, -np.inf)))] = True
                continue
            covered |= poly.contains(cells, 1e-6)
            out.append(poly)
            if np.mean(covered) >= p.cover_fraction:
                break
    return out


def _border_points(
    mine: NDArray[np.bool_], xs: NDArray[np.float64], ys: NDArray[np.float64], depth: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Gives the centres (m, 2) of the cells outside `mine` that touch it (8-neighbours) and their depth (m)."""
    grown = disk_filter(mine, _SQUARE3, np.maximum, False)  # binary_dilation by the 3 × 3 square
    bi, bj = np.nonzero(grown & ~mine)
    return np.column_stack([xs[bi], ys[bj]]), depth[bi, bj]


def _box_of(cells: NDArray[np.float64], grow_m: float = 0.0) -> tuple[float, float, float, float]:
    lo = cells.min(axis=0) - grow_m
    hi = cells.max(axis=0) + grow_m
    return float(lo[0]), float(hi[0]), float(lo[1]), float(hi[1])


def _grow(
    seed: NDArray[np.float64],
    outside: tuple[NDArray[np.float64], NDArray[np.float64]],
    box: tuple[float, float, float, float],
    max_planes: int,
    inset_m: float,
    label: int,
    normals: NDArray[np.float64],
    z0: NDArray[np.float64],
    xy0: NDArray[np.float64],
) -> ConvexRegion | None:
    """Gives the convex polygon grown around seed that keeps inset_m from the region's edge, within box (None: empty).

    outside: the centres of the cells around the inset and their distance to the region's edge (m). Each round the
    outside point nearest the seed adds a half-plane facing the seed (its normal along seed → point), moved from
    the point toward the seed by what its cell lacks of inset_m (on a straight edge the plane then lies inset_m
    from it), and the points beyond it drop out; after max_planes rounds the polygon is shrunk about the seed
    until the points still inside are out."""
    pts, depth = outside
    rel = pts - seed
    d2 = np.einsum("ij,ij->i", rel, rel)
    A: list[NDArray[np.float64]] = []
    b: list[float] = []
    # The points still inside, in their order (the dropped ones taken out each round, so the nearest is the first
    # of least distance, as among all points with the dropped ones at infinity).
    for _ in range(max_planes):
        if not rel.shape[0]:
            break
        i = int(np.argmin(d2))
        dist = math.sqrt(float(d2[i]))
        if dist < 1e-9:
            return None
        nrm = rel[i] / dist
        off = dist - max(inset_m - float(depth[i]), 0.0)
        if off < 1e-6:
            return None
        A.append(nrm)
        b.append(off)
        keep = rel @ nrm < off - 1e-12
        rel, d2, depth = rel[keep], d2[keep], depth[keep]
    # The box (relative to the seed).
    x0, x1, y0, y1 = box
    A += [np.array([1.0, 0.0]), np.array([-1.0, 0.0]), np.array([0.0, 1.0]), np.array([0.0, -1.0])]
    b += [x1 - seed[0], seed[0] - x0, y1 - seed[1], seed[1] - y0]
    Am = np.asarray(A)
    bm = np.asarray(b)
    if rel.shape[0]:
        # Gauge of each point still inside: the polygon scaled by it about the seed passes through the point.
        g = np.max((rel @ Am.T) / np.maximum(bm, 1e-12), axis=1)
        scale = 0.999 * float(np.min(g))
        if scale <= 1e-6:
            return None
        bm = bm * scale
    verts = _clip_box(Am, bm)
    if verts is None:
        return None
    # The polygon's own edges (the planes that touch it), as A p <= b in world coordinates.
    nxt = np.concatenate((verts[1:], verts[:1]))  # (np.roll's values, without its dispatch)
    e = nxt - verts
    length = np.hypot(e[:, 0], e[:, 1])
    keep = length > 1e-9
    verts, e, length = verts[keep], e[keep], length[keep]
    if len(verts) < 3:
        return None
    An = np.column_stack([e[:, 1], -e[:, 0]]) / length[:, None]  # outward for a counter-clockwise polygon
    vw = verts + seed
    bn = np.einsum("ij,ij->i", An, vw)
    nxt = np.concatenate((verts[1:], verts[:1]))
    area = 0.5 * float((verts[:, 0] * nxt[:, 1] - nxt[:, 0] * verts[:, 1]).sum())
    return ConvexRegion(
        label=label,
        A=An,
        b=bn,
        vertices=vw,
        seed=np.asarray(seed, dtype=np.float64).copy(),
        normal=normals[label].copy(),
        z0=float(z0[label]),
        xy0=xy0[label].copy(),
        area_m2=area,
    )


def _clip_box(A: NDArray[np.float64], b: NDArray[np.float64]) -> NDArray[np.float64] | None:
    """Gives the counter-clockwise vertices of {p: A p <= b} (bounded: A holds a box), by clipping a large square
    one half-plane at a time (Sutherland–Hodgman); None when empty."""
    big = float(np.max(np.abs(b))) * 4.0 + 1.0
    poly = [(-big, -big), (big, -big), (big, big), (-big, big)]
    for (ax, ay), bi in zip(A.tolist(), b.tolist(), strict=True):
        out: list[tuple[float, float]] = []
        m = len(poly)
        for k in range(m):
            px, py = poly[k]
            qx, qy = poly[(k + 1) % m]
            fp = ax * px + ay * py - bi
            fq = ax * qx + ay * qy - bi
            if fp <= 0.0:
                out.append((px, py))
            if (fp < 0.0 < fq) or (fq < 0.0 < fp):
                t = fp / (fp - fq)
                out.append((px + t * (qx - px), py + t * (qy - py)))
        poly = out
        if len(poly) < 3:
            return None
    return np.asarray(poly, dtype=np.float64)


def convex_around(
    regions: SteppableRegions, label: int, xy: NDArray[np.float64], window_m: float = 0.6
) -> ConvexRegion | None:
    """Gives a convex polygon of region `label`'s inset grown around its inset cell nearest to xy (world, m),
    from the cells within window_m of that cell; None when the region has no inset cell in the window."""
    res = regions.resolution_m
    nx, ny = regions.labels.shape
    ox, oy = regions.origin_xy
    w = int(math.ceil(window_m / res))
    cx = int(round((float(xy[0]) - ox) / res))
    cy = int(round((float(xy[1]) - oy) / res))
    i0, i1 = max(cx - w, 0), min(cx + w + 1, nx)
    j0, j1 = max(cy - w, 0), min(cy + w + 1, ny)
    if i0 >= i1 or j0 >= j1:
        return None
    if label <= 0:
        return None  # (no region: no inset cell carries label 0)
    mine = regions.inset_labels[i0:i1, j0:j1] == label
    ci, cj = np.nonzero(mine)
    if ci.size == 0:
        return None
    xs = ox + np.arange(i0, i1) * res
    ys = oy + np.arange(j0, j1) * res
    cells = np.column_stack([xs[ci], ys[cj]])
    d2 = np.sum((cells - np.asarray(xy, dtype=np.float64)[:2]) ** 2, axis=1)
    # The seed: near xy, but a cell or two deeper when one is (a seed on the inset's rim grows a sliver).
    depth = regions.depth_m[i0:i1, j0:j1][ci, cj]
    score = np.sqrt(d2) - np.minimum(depth - regions.params.inset_m, 2.0 * res)
    seed = cells[int(np.argmin(score))]
    outside = _border_points(mine, xs, ys, regions.depth_m[i0:i1, j0:j1])
    # Cells of the region beyond the window are not known to be free of edges: the window bounds the polygon (half
    # a cell past the inset cells' centres, as in the cover: the inset's own bound lies between cells).
    # (xs and ys grow with the index, and nonzero gives the rows in order: the cells' extremes without a reduction
    # over them; the same values as _box_of(cells, 0.5 * res))
    g = 0.5 * res
    box = (float(xs[ci[0]]) - g, float(xs[ci[-1]]) + g, float(ys[cj.min()]) - g, float(ys[cj.max()]) + g)
    return _grow(
        seed,
        outside,
        box,
        regions.params.max_planes,
        regions.params.inset_m,
        label,
        regions.normals,
        regions.z0,
        regions.xy0,
    )
