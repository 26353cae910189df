"""A rolling voxel map (3 cm) around the robot, with per-voxel statistics, classified ground / obstacle / other.

Statistics per voxel, decayed each scan so the map forgets what is no longer seen: ``hits`` (points that fell in the
voxel), ``misses`` (rays that passed through it: observed free space) and ``sum_z`` (for the mean height of the
points, finer than the voxel). A voxel is *occupied* when it has enough hits and more hits than a share of its misses;
*free* when rays passed through it and it is not occupied; otherwise unknown.

Classification, column by column from the bottom up: an occupied voxel is *supported* when nothing observed free lies
between it and the supported voxel (or the unseen depth) below it; a table top, seen with free space under it, is not.
The lowest supported voxel of a column is *ground*; other occupied voxels are *obstacle* within ``obstacle_top_m``
above the column's ground, *other* above that (well over the robot). Columns reduce to a ``Columns`` summary (ground
height and a 3D obstacle occupancy) that maps.py turns into 2D maps.

Index convention: the maps' arrays are [ix, iy] / [ix, iy, iz]; cell (ix, iy) has its center at origin_xy + (ix, iy) * resolution; layer iz
has its center at z0 + iz * resolution, with z0 chosen so that z = 0 is a layer center.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from planning.terrain.sensor import PointCloud

GROUND: int = 1
OBSTACLE: int = 2
OTHER: int = 3


@dataclass(frozen=True)
class VoxelParams:
    """Voxel map. resolution_m: voxel side (m); half_extent_m: half side of the square map around the robot (m);
    z_below_m, z_above_m: vertical extent below and above the robot's ground (m); recenter_m: robot offset from the
    map center that triggers a shift (m); decay: factor applied to the statistics each scan; min_hits: decayed hits
    for occupancy; hit_miss_ratio: occupancy also needs hits >= ratio * misses; min_misses: decayed misses for free;
    carve_every: carve free space along one ray in this many; carve_margin_m: stop carving this short of a hit (m);
    obstacle_top_m: occupied voxels higher than this above their column's ground are 'other' (m); free_floor_misses:
    decayed misses a voxel needs to bound its column's ground from above (Columns.free_floor_z): more than an outlier
    ray's one (the sensor's gross errors carve a few voxels below the surface they hit)."""

    resolution_m: float = 0.03
    half_extent_m: float = 2.0
    z_below_m: float = 1.0
    z_above_m: float = 1.4
    recenter_m: float = 0.3
    decay: float = 0.85
    min_hits: float = 1.5
    hit_miss_ratio: float = 0.3
    min_misses: float = 0.9
    carve_every: int = 2
    carve_margin_m: float = 0.05
    obstacle_top_m: float = 1.0
    free_floor_misses: float = 3.0


@dataclass(frozen=True, eq=False)
class Columns:
    """What the 2D maps need from 3D data.

    origin_xy: world (x, y) of cell (0, 0)'s center (m); resolution_m: cell side (m); ground_z: (nx, ny) ground
    height (m, world), NaN where unknown; obstacle: (nx, ny, nz) obstacle occupancy; z0_m: center height of layer 0
    (m); dz_m: layer height (m); obstacle_layers: (first, last) layers that may hold an obstacle (none outside them;
    None: any layer may), so the maps need not scan the empty ones; obstacle_voxels: (layer, cell) index arrays of
    every obstacle voxel (cell: the flat column index ix * ny + iy) when the producer lists them (the maps read them
    instead of scanning the occupancy), None when not; free_floor_z: (nx, ny) the bottom (m, world) of each column's
    lowest voxel observed free (rays passed through it, nothing hit it), +inf where none was seen below the highest
    ground layer, None when the producer does not say. A column's ground lies below it: the ground of a column
    nothing was seen on (the shadow behind a stone's far edge or a nosing) is at most this.
    """

    origin_xy: tuple[float, float]
    resolution_m: float
    ground_z: NDArray[np.float64]
    obstacle: NDArray[np.bool_]
    z0_m: float
    dz_m: float
    obstacle_layers: tuple[int, int] | None = None
    obstacle_voxels: tuple[NDArray[np.intp], NDArray[np.intp]] | None = None
    free_floor_z: NDArray[np.float64] | None = None


class VoxelMap:
    """The rolling voxel map; `integrate` a cloud per scan, then `classify()` for the maps.

    Statistics are stored as [iz, ix, iy] (z-major, so a layer is contiguous) and scaled by a running weight instead
    of being decayed in place: scan n adds weight decay**-n, and thresholds are scaled by the same weight.
    """

    def __init__(self, params: VoxelParams | None = None, center_xy: tuple[float, float] = (0.0, 0.0),
                 ground_z_m: float = 0.0) -> None:  # fmt: skip
        self.params = p = params or VoxelParams()
        self.res = p.resolution_m
        self.n_xy = int(round(2 * p.half_extent_m / self.res)) | 1  # odd, so the robot sits on a center cell
        self.n_z = int(round((p.z_below_m + p.z_above_m) / self.res))
        shape = (self.n_z, self.n_xy, self.n_xy)
        self.hits = np.zeros(shape, np.float32)
        self.misses = np.zeros(shape, np.float32)
        self.sum_z = np.zeros(shape, np.float32)
        self._weight = 1.0  # weight of the latest scan (decay**-n)
        self._ix0, self._iy0, self._iz0 = self._lattice(center_xy, ground_z_m)
        self.n_points = 0
        # Layers that may hold hits / misses (first, last); every layer outside is all zero. Hits and misses are never
        # decayed to zero in place, so a band only grows, until a shift moves it or drops layers off the map.
        self._hit_layers: tuple[int, int] | None = None
        self._miss_layers: tuple[int, int] | None = None
        # Per row of voxels (layer, ix), a bound on its largest hits (at least the largest; the same scale as hits):
        # a row under min_hits holds no occupied voxel, so classify reads only the others (a few percent of the
        # band's rows: the surfaces), and skips a layer with none. Raised where a scan adds hits, scaled with them
        # when they are renormalized, moved with a vertical or x shift (a y shift drops voxels: still a bound).
        self._row_max = np.zeros((self.n_z, self.n_xy), np.float32)

    # -- geometry -----------------------------------------------------------------------------------------------

    @property
    def origin_xy(self) -> tuple[float, float]:
        return (self._ix0 * self.res, self._iy0 * self.res)

    @property
    def z0(self) -> float:
        return self._iz0 * self.res

    def _lattice(self, center_xy: tuple[float, float], ground_z: float) -> tuple[int, int, int]:
        half = self.n_xy // 2
        ix0 = int(round(center_xy[0] / self.res)) - half
        iy0 = int(round(center_xy[1] / self.res)) - half
        iz0 = int(round((ground_z - self.params.z_below_m) / self.res))
        return ix0, iy0, iz0

    def recenter(self, center_xy: tuple[float, float], ground_z: float) -> bool:
        """Shifts the map (whole cells) when the robot has moved recenter_m from its center; True if it shifted."""
        half = self.n_xy // 2
        cx = (self._ix0 + half) * self.res
        cy = (self._iy0 + half) * self.res
        cz = self.z0 + self.params.z_below_m
        r = self.params.recenter_m
        if abs(center_xy[0] - cx) < r and abs(center_xy[1] - cy) < r and abs(ground_z - cz) < r:
            return False
        ix0, iy0, iz0 = self._lattice(center_xy, ground_z)
        shift = (self._iz0 - iz0, self._ix0 - ix0, self._iy0 - iy0)
        for a in (self.hits, self.misses, self.sum_z):
            _shift_clear(a, shift)
        self._ix0, self._iy0, self._iz0 = ix0, iy0, iz0
        self._hit_layers = _shift_band(self._hit_layers, shift[0], self.n_z)
        _shift_clear(self._row_max, shift[:2])
        self._miss_layers = _shift_band(self._miss_layers, shift[0], self.n_z)
        return True

    def _flat_index(self, p: NDArray[np.float64]) -> tuple[NDArray[np.intp], NDArray[np.bool_]]:
        return self._flat_index_xyz(p[:, 0], p[:, 1], p[:, 2])

    def _flat_index_xyz(
        self, x: NDArray[np.float64], y: NDArray[np.float64], z: NDArray[np.float64]
    ) -> tuple[NDArray[np.intp], NDArray[np.bool_]]:
        """Gives the flat indices of the points (x, y, z) inside the map, and which points are inside."""
        inv = 1.0 / self.res
        n, nz = self.n_xy, self.n_z
        ix, iy, iz = (
            np.rint(c * inv).astype(np.intp) - i0
            for c, i0 in ((x, self._ix0), (y, self._iy0), (z, self._iz0))
        )
        # One unsigned comparison per axis checks both bounds (a negative index wraps to a huge one).
        ok = (ix.astype(np.uintp) < n) & (iy.astype(np.uintp) < n) & (iz.astype(np.uintp) < nz)
        flat = (iz * n + ix) * n + iy
        return flat[ok], ok

    # -- integration --------------------------------------------------------------------------------------------

    def integrate(self, cloud: PointCloud, center_xy: tuple[float, float], ground_z: float) -> None:
        """Adds one scan: hits at the points, misses along (a share of) the rays up to carve_margin of the hits."""
        p = self.params
        self.recenter(center_xy, ground_z)
        self._weight /= p.decay
        if self._weight > 1e6:  # renormalize before float32 loses the small counts
            for a in (self.hits, self.misses, self.sum_z, self._row_max):
                a /= self._weight
            self._weight = 1.0
        w = np.float32(self._weight)
        pts = cloud.p_world_points
        self.n_points = pts.shape[0]
        flat, ok = self._flat_index(pts)
        np.add.at(self.hits.reshape(-1), flat, w)
        np.add.at(self.sum_z.reshape(-1), flat, (w * pts[:, 2][ok]).astype(np.float32))
        self._hit_layers = _grow_band(self._hit_layers, flat, self.n_xy * self.n_xy)
        np.maximum.at(self._row_max.reshape(-1), flat // self.n_xy, self.hits.reshape(-1)[flat])
        # Free space: sample each carved ray every voxel from its origin to carve_margin short of its hit.
        # The rays as rows per axis (3, rays): an operation on (rays, 3) arrays with a per-axis operand, or between
        # strided ones, loops three elements at a time, several times slower.
        o = cloud.p_world_origins[:: p.carve_every]
        oT = np.ascontiguousarray(o.T)
        dT = np.subtract(pts[:: p.carve_every].T, oT, order="C")
        dd = dT * dT
        length = np.sqrt(dd[0] + dd[1] + dd[2])
        uT = dT / np.maximum(length, 1e-9)
        n_k = np.maximum(np.floor((length - p.carve_margin_m) / self.res - 0.5).astype(np.intp) + 1, 0)
        n_k = np.minimum(n_k, self._samples_inside(oT, uT))
        # In chunks of rays of about _CARVE_CHUNK samples, each from one camera: the passes over a chunk's samples
        # stay in the cache (over a whole scan's ~200k samples they would stream from memory each time), and a
        # chunk's rays share their origin, added as one vector. The same operations on the same samples, in the
        # same order: the same misses.
        ends = np.cumsum(n_k)
        total = int(ends[-1]) if ends.size else 0
        if total == 0:
            return
        cuts = np.searchsorted(ends, np.arange(_CARVE_CHUNK, total, _CARVE_CHUNK), side="right")
        moved = oT[:, 1:] != oT[:, :-1]
        cameras = np.flatnonzero(moved[0] | moved[1] | moved[2]) + 1
        bounds = np.unique(np.concatenate([[0, len(n_k)], cuts, cameras])).tolist()
        misses = self.misses.reshape(-1)
        n, nz = self.n_xy, self.n_z
        # The samples in voxel units from the map's corner voxel: (o / res - i0) + u (k + 1/2) for sample k of a
        # ray (o + u t at t = (k + 1/2) res, as _flat_index_xyz rounds it; the same voxels but where a sample lies
        # within rounding of a voxel face). Indices in int32 (the map has far fewer than 2**31 voxels).
        i0 = np.array([self._ix0, self._iy0, self._iz0], dtype=np.float64)
        o_vox = o[np.minimum(bounds[:-1], len(n_k) - 1)] / self.res - i0  # each chunk's (one camera's) origin
        lim = np.array([[n], [n], [nz]], dtype=np.uint32)
        for c, (a, b) in enumerate(zip(bounds[:-1], bounds[1:], strict=True)):
            nk = n_k[a:b]
            m = int(nk.sum())
            if m == 0:
                continue
            # k + 1/2 (exact: half-integers), the chunk's sample numbers read from a kept ramp, not made anew
            s = np.repeat(0.5 - (np.cumsum(nk) - nk), nk)
            s += _ramp(m)
            xyz = np.repeat(uT[:, a:b], nk, axis=1)
            xyz *= s
            xyz += o_vox[c][:, None]
            np.rint(xyz, out=xyz)
            idx = xyz.astype(np.int32)
            ok = idx.view(np.uint32) < lim  # one unsigned comparison per axis checks both bounds
            inside = ok[0] & ok[1] & ok[2]
            flat_f = idx[2] * np.int32(n)
            flat_f += idx[0]
            flat_f *= np.int32(n)
            flat_f += idx[1]
            if not inside.all():  # (most chunks lie inside the map: no copy)
                flat_f = flat_f[inside]
            np.add.at(misses, flat_f, w)
            self._miss_layers = _grow_band(self._miss_layers, flat_f, n * n)

    def _samples_inside(self, oT: NDArray[np.float64], uT: NDArray[np.float64]) -> NDArray[np.intp]:
        """Gives per ray (origins oT, unit directions uT, (3, rays) each) how many of its carving samples (every voxel
        from half a voxel on) may lie in the map: the rest lie past where the ray leaves the map's box grown by a
        voxel, more than a voxel outside the map, and would be dropped anyway (a large count for a ray that starts
        outside)."""
        res = self.res
        n = np.array([self.n_xy, self.n_xy, self.n_z], dtype=np.float64)
        i0 = np.array([self._ix0, self._iy0, self._iz0], dtype=np.float64)
        lo = ((i0 - 1.5) * res)[:, None]
        hi = ((i0 + n + 0.5) * res)[:, None]
        ok = (oT > lo) & (oT < hi)
        inside = ok[0] & ok[1] & ok[2]
        # Per axis, the distance along the ray to the face it heads for, (hi - o) / u or (lo - o) / u (one quotient
        # per axis, not both), +inf along an axis it does not move on.
        t_axis = np.where(uT > 0, hi, lo)
        t_axis -= oT
        with np.errstate(divide="ignore", invalid="ignore"):
            t_axis /= uT
        if not uT.all():
            t_axis[uT == 0] = np.inf
        t_exit = np.minimum(np.minimum(t_axis[0], t_axis[1]), t_axis[2])
        big = np.iinfo(np.intp).max // 4
        keep = np.floor(np.minimum(t_exit / res + 0.5, big)).astype(np.intp) + 1
        return np.where(inside, np.maximum(keep, 0), big)

    def _recount_row_max(self) -> None:
        """Sets each row's hit bound to its largest hits (for statistics written directly, as tests do)."""
        self._row_max = self.hits.max(axis=2)

    # -- classification -----------------------------------------------------------------------------------------

    def _occupancy(self) -> tuple[NDArray[np.bool_], NDArray[np.bool_]]:
        p = self.params
        w = np.float32(self._weight)
        occ = (self.hits >= p.min_hits * w) & (self.hits >= p.hit_miss_ratio * self.misses)
        free = ~occ & (self.misses >= p.min_misses * w)
        return occ, free

    def classify(self) -> Columns:
        """Gives the column summary: ground heights and obstacle occupancy (every occupied non-ground voxel).

        The same result as the column-by-column rule in the module docstring, from whole-array operations over the
        layers that hold hits: a column's scan from the bottom keeps 'supported' until its first free voxel, so its
        ground is its lowest occupied voxel when no free voxel lies below that one, and none otherwise
        (``_ground_reference`` is the scan itself; the tests hold the two equal)."""
        p = self.params
        nz, n = self.n_z, self.n_xy
        cells = n * n
        obstacle = np.zeros((nz, n, n), dtype=bool)
        ground_z = np.full((n, n), np.nan)
        none = Columns(
            self.origin_xy,
            self.res,
            ground_z,
            np.moveaxis(obstacle, 0, -1),
            self.z0,
            self.res,
            (0, -1),
            _NO_VOXELS,
        )  # the columns of a map holding no occupied voxel
        if self._hit_layers is None:
            return none
        w = np.float32(self._weight)
        # Only the layers whose hits may reach min_hits can hold an occupied voxel (see _row_max); the band
        # trimmed to them gives the same columns (above its top no voxel is occupied, so nothing seen through
        # there can lie under a column's ground).
        lo, hi = self._hit_layers
        can = np.flatnonzero(self._row_max[lo : hi + 1].max(axis=1) >= p.min_hits * w)
        if can.size == 0:
            return none
        lo, hi = lo + int(can[0]), lo + int(can[-1])
        n_band = hi + 1 - lo
        # Occupied: hits >= min_hits w and hits >= ratio misses. The first test picks the few voxels with enough
        # hits (the surfaces), on the rows whose bound reaches min_hits only, the second only on them; the band's
        # occupancy is set from their indices (in the band, layer by layer, ascending), and a column's lowest
        # occupied layer is the least layer among its indices.
        hits_b = self.hits[lo : hi + 1].reshape(-1)
        thr = p.min_hits * w
        rows = np.flatnonzero(self._row_max[lo : hi + 1].reshape(-1) >= thr)  # (layer - lo) * n + ix
        sel = np.flatnonzero(hits_b.reshape(-1, n)[rows] >= thr)  # (flat: np.nonzero in 2D is ~10× slower)
        r_i = sel // n
        cand = rows[r_i] * n + (sel - r_i * n)
        occ_i = cand[hits_b[cand] >= p.hit_miss_ratio * self.misses[lo : hi + 1].reshape(-1)[cand]]
        # (the obstacles are the occupied voxels but the ground ones, cleared below)
        occ = obstacle[lo : hi + 1]
        occ.reshape(-1)[occ_i] = True
        first_occ = np.full(cells, n_band, dtype=np.intp)
        occ_k = occ_i // cells
        occ_c = occ_i - occ_k * cells
        np.minimum.at(first_occ, occ_c, occ_k)
        # Occupied layers lie in [lo, hi]; the lowest occupied layer of each column, and whether it has one.
        any_occ = first_occ <= hi - lo
        first_occ = np.minimum(first_occ, hi - lo)
        col = np.arange(cells)
        k_ground = first_occ + lo
        # A free voxel below it (free: not occupied, seen through): only layers below hi can matter. Below a
        # column's lowest occupied voxel nothing is occupied, so there 'free' is just 'seen through': the ground
        # stands when the lowest seen-through voxel is not below it. Only layers below the highest ground can hold
        # one under a ground: the layers from there up are not read.
        has_ground = any_occ.copy()
        free_floor = np.full(cells, np.inf)
        if self._miss_layers is not None:
            mlo, mhi = self._miss_layers
            top = min(mhi, hi, int(k_ground.max(where=any_occ, initial=lo)) - 1)
            if mlo <= top:
                band_m = self.misses[mlo : top + 1].reshape(top + 1 - mlo, cells)
                first_seen = _first_true(band_m >= p.min_misses * w)
                has_ground &= (first_seen == top + 1 - mlo) | (first_seen + mlo >= k_ground)
                # A column with no occupied voxel below its lowest voxel seen through by free_floor_misses (more
                # than the one outlier ray a scan may carve below a surface): that voxel is free, and the column's
                # ground (if any) lies below its bottom.
                # (over the whole band: a column subset's gather costs several times the band's compare)
                first_many = _first_true(band_m >= p.free_floor_misses * w)
                below = ~has_ground & (first_many < top + 1 - mlo)
                below &= ~any_occ | (first_many + mlo < k_ground)
                b = np.flatnonzero(below)  # (one search for the gather and the scatter, not one each)
                free_floor[b] = self.z0 + (first_many.take(b) + mlo - 0.5) * self.res
        # Ground height: mean z of the points in the ground voxel and, for a thin surface, the one above it (thin:
        # the voxel above is occupied and the one above that is not).
        occ_flat = occ.reshape(-1)
        top_rel = hi - lo
        k1 = np.minimum(first_occ + 1, top_rel)
        k2 = np.minimum(first_occ + 2, top_rel)
        thin = has_ground & (k_ground + 2 < nz) & (first_occ + 1 <= top_rel)
        thin &= occ_flat[k1 * cells + col] & ~np.where(
            first_occ + 2 <= top_rel, occ_flat[k2 * cells + col], False
        )
        hits_flat = self.hits.reshape(-1)
        sumz_flat = self.sum_z.reshape(-1)
        i0 = k_ground * cells + col
        i1 = np.minimum(k_ground + 1, nz - 1) * cells + col
        h0 = hits_flat[i0]
        z0s = sumz_flat[i0]
        h1 = np.where(thin, hits_flat[i1], 0.0)
        z1s = np.where(thin, sumz_flat[i1], 0.0)
        ground_z = np.where(has_ground, (z0s + z1s) / np.maximum(h0 + h1, 1e-12), np.nan).astype(np.float64)
        # Obstacles: every occupied voxel but the ground voxel (and the one above it on a thin surface).
        band = occ.reshape(hi + 1 - lo, cells)
        g = np.flatnonzero(has_ground)
        band[first_occ[g], g] = False
        t = np.flatnonzero(thin)
        band[first_occ[t] + 1, t] = False
        # The same obstacle voxels as a list (a few thousand of the band's million voxels; the maps read it).
        fo = first_occ[occ_c]
        kept = ~(has_ground[occ_c] & ((occ_k == fo) | (thin[occ_c] & (occ_k == fo + 1))))
        return Columns(
            self.origin_xy, self.res, ground_z.reshape(n, n), np.moveaxis(obstacle, 0, -1), self.z0, self.res,
            (lo, hi), (occ_k[kept] + lo, occ_c[kept]), free_floor.reshape(n, n),
        )  # fmt: skip

    def _ground_reference(
        self, occ: NDArray[np.bool_], free: NDArray[np.bool_]
    ) -> tuple[NDArray[np.float64], NDArray[np.intp], NDArray[np.bool_], NDArray[np.bool_]]:
        nz = occ.shape[0]
        supported = np.zeros_like(occ)
        s = np.ones(occ.shape[1:], dtype=bool)
        for k in range(nz):
            o_k = occ[k]
            sup_k = o_k & s
            supported[k] = sup_k
            s = np.where(o_k, sup_k, s & ~free[k])
        has_ground = supported.any(axis=0)
        k_ground = np.argmax(supported, axis=0)
        # Ground height: mean z of the points in the ground voxel and, for a thin surface, the one above it.
        kk = k_ground[None]
        k1 = np.minimum(kk + 1, nz - 1)
        k2 = np.minimum(kk + 2, nz - 1)
        thin = (np.take_along_axis(supported, k1, 0) & ~np.take_along_axis(supported, k2, 0))[0] & has_ground
        thin &= k_ground + 1 < nz
        h0 = np.take_along_axis(self.hits, kk, 0)[0]
        z0s = np.take_along_axis(self.sum_z, kk, 0)[0]
        h1 = np.where(thin, np.take_along_axis(self.hits, k1, 0)[0], 0.0)
        z1s = np.where(thin, np.take_along_axis(self.sum_z, k1, 0)[0], 0.0)
        ground_z = np.where(has_ground, (z0s + z1s) / np.maximum(h0 + h1, 1e-12), np.nan).astype(np.float64)
        return (
            ground_z,
            k_ground.astype(np.intp),
            np.asarray(has_ground, dtype=bool),
            np.asarray(thin, dtype=bool),
        )

    def labels(self) -> NDArray[np.uint8]:
        """Gives every voxel's class, (nx, ny, nz): 0 free or unknown, GROUND, OBSTACLE, OTHER (for views, tests)."""
        p = self.params
        occ, free = self._occupancy()
        _, k_ground, has_ground, thin = self._ground_reference(occ, free)
        layer = np.arange(occ.shape[0])[:, None, None]
        kk = k_ground[None]
        is_ground = ((layer == kk) | ((layer == kk + 1) & thin[None])) & has_ground[None]
        high = ((layer - kk) * self.res > p.obstacle_top_m) & has_ground[None]
        labels = np.zeros(occ.shape, np.uint8)
        labels[occ] = OBSTACLE
        labels[occ & high] = OTHER
        labels[is_ground] = GROUND
        return np.moveaxis(labels, 0, -1)


_CARVE_CHUNK = 32768
_RAMP: list[NDArray[np.float64]] = [np.zeros(0)]


def _ramp(m: int) -> NDArray[np.float64]:
    """Gives np.arange(m, dtype=float64) (read-only; one kept array, grown when a longer one is asked for)."""
    ramp = _RAMP[0]
    if ramp.size < m:
        ramp = np.arange(max(m, 2 * ramp.size), dtype=np.float64)
        ramp.flags.writeable = False
        _RAMP[0] = ramp
    return ramp[:m]


_NO_VOXELS = (np.zeros(0, np.intp), np.zeros(0, np.intp))


def _first_true(a: NDArray[np.bool_]) -> NDArray[np.intp]:
    """Gives per column of a (rows, cols) the first row that is True, rows where none is (the same as argmax over
    rows, where it finds one). A minimum over rows of the row numbers: a whole-row operation per row, where argmax
    over the first axis goes column by column."""
    rows = a.shape[0]
    if rows < 256:
        # rows - row where True, 0 where not, in one byte (half the bytes of int16 to write and reduce)
        # (the bools read as bytes: a uint8 product, where a bool × uint8 one casts every element first)
        k8 = np.multiply(a.view(np.uint8), np.arange(rows, 0, -1, dtype=np.uint8)[:, None])
        return rows - np.asarray(k8.max(axis=0), dtype=np.intp)
    dtype = np.int16 if rows < 2**15 else np.int64
    # row - rows where True, 0 where not (a product: several times faster than np.where with a broadcast row index)
    k = np.multiply(a, (np.arange(rows, dtype=dtype) - rows)[:, None], dtype=dtype)
    return np.asarray(k.min(axis=0), dtype=np.intp) + rows


def _grow_band(
    band: tuple[int, int] | None, flat: NDArray[np.intp], layer_cells: int
) -> tuple[int, int] | None:
    """Gives the layer band (first, last) grown to hold the layers of the flat voxel indices `flat`."""
    if flat.size == 0:
        return band
    lo, hi = int(flat.min()) // layer_cells, int(flat.max()) // layer_cells
    if band is None:
        return lo, hi
    return min(band[0], lo), max(band[1], hi)


def _shift_band(band: tuple[int, int] | None, shift: int, nz: int) -> tuple[int, int] | None:
    """Gives the layer band after the layers moved by `shift` (new = old + shift); None when it left the map."""
    if band is None:
        return None
    lo, hi = max(band[0] + shift, 0), min(band[1] + shift, nz - 1)
    return (lo, hi) if lo <= hi else None


def _shift_clear(a: NDArray[np.float32], shift: tuple[int, ...]) -> None:
    """Moves the content of `a` by `shift` cells (new[i] = old[i - shift]); cells that come in are zeroed. One copy
    of the part that stays, whatever the number of axes shifted."""
    if not any(shift):
        return
    src: list[slice] = []
    dst: list[slice] = []
    for n, s in zip(a.shape, shift, strict=True):
        if abs(s) >= n:
            a.fill(0)
            return
        src.append(slice(0, n - s) if s >= 0 else slice(-s, n))
        dst.append(slice(s, n) if s >= 0 else slice(0, n + s))
    kept = a[tuple(src)].copy()
    a.fill(0)
    a[tuple(dst)] = kept
