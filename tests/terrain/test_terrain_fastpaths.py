"""The perception's whole-array fast paths against simple reference implementations on random inputs: the min / max
filters (gridops.py) against scipy.ndimage, the voxel carving and classification against a ray-by-ray and a
column-by-column version, the SDF, the ground fill, the nearest known cell and the first-true search against their
plain forms."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import ndimage

from planning.terrain.gridops import (
    disk_filter,
    disk_filters,
    distance_transform,
    pad2,
    square_filter,
    window_1d,
)
from planning.terrain.maps import _disk, _fill_ground, _nearest_known, signed_distance
from planning.terrain.sensor import PointCloud
from planning.terrain.voxels import VoxelMap, VoxelParams, _first_true

_SMALL = VoxelParams(resolution_m=0.1, half_extent_m=0.5, z_below_m=0.5, z_above_m=0.5, recenter_m=0.1)


def _grid(seed: int, bool_: bool = False) -> np.ndarray:
    rng = np.random.default_rng(seed)
    shape = tuple(int(v) for v in rng.integers(1, 25, 2))
    if bool_:
        return np.asarray(rng.random(shape) < rng.uniform(0.05, 0.7))
    # Few distinct values, so ties (where a wrong window edge would show) are common.
    return rng.integers(-5, 5, shape).astype(np.float64) * 0.25


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**31), st.integers(0, 7), st.floats(0.5, 6.0))
def test_min_max_filters_equal_ndimage(seed: int, half: int, radius: float) -> None:
    """Squares, rows and disks, min and max, edge values repeated (mode "nearest") or a constant beyond the grid."""
    a = _grid(seed)
    size = 2 * half + 1
    fp = _disk(radius)
    for op, nd in ((np.minimum, ndimage.minimum_filter), (np.maximum, ndimage.maximum_filter)):
        np.testing.assert_array_equal(square_filter(a, size, op), nd(a, size=size, mode="nearest"))
        np.testing.assert_array_equal(window_1d(a, size, 1, op), nd(a, size=(1, size), mode="nearest"))
        np.testing.assert_array_equal(disk_filter(a, fp, op), nd(a, footprint=fp, mode="nearest"))
        np.testing.assert_array_equal(
            disk_filter(a, fp, op, cval=-9.0), nd(a, footprint=fp, mode="constant", cval=-9.0)
        )


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**31), st.floats(0.5, 6.0))
def test_boolean_disk_filters_equal_binary_morphology(seed: int, radius: float) -> None:
    m = _grid(seed, bool_=True)
    fp = _disk(radius)
    dil = disk_filter(m, fp, np.maximum, False)
    np.testing.assert_array_equal(dil, ndimage.binary_dilation(m, structure=fp))
    np.testing.assert_array_equal(
        disk_filter(m, fp, np.minimum, False), ndimage.binary_erosion(m, structure=fp)
    )
    np.testing.assert_array_equal(
        disk_filter(dil, fp, np.minimum, False), ndimage.binary_closing(m, structure=fp)
    )


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**31))
def test_distance_transform_equals_ndimage(seed: int) -> None:
    """The distances from the feature transform, summed in integers, equal ndimage's exactly (masks of any density,
    one row or column, one cell)."""
    m = _grid(seed, bool_=True)
    np.testing.assert_array_equal(distance_transform(m), ndimage.distance_transform_edt(m))
    np.testing.assert_array_equal(distance_transform(~m), ndimage.distance_transform_edt(~m))


@settings(max_examples=200, deadline=None)
@given(st.integers(0, 2**31))
def test_distance_transform_either_way_round_and_with_the_edge_equals_ndimage(seed: int) -> None:
    """Lines of False cells along either axis (the transform then runs on the grid or on its transpose), and the
    edge as False cells: the same distances as ndimage's on the grid, and on the grid padded by a False cell."""
    rng = np.random.default_rng(seed)
    m = _grid(seed, bool_=True) | (rng.random() < 0.5)
    n0, n1 = m.shape
    if seed % 3 == 0:
        m[rng.integers(0, n0, int(rng.integers(1, 4))), :] = False
    elif seed % 3 == 1:
        m[:, rng.integers(0, n1, int(rng.integers(1, 4)))] = False
    np.testing.assert_array_equal(distance_transform(m), ndimage.distance_transform_edt(m))
    padded = ndimage.distance_transform_edt(pad2(m, 1, False))[1:-1, 1:-1]
    np.testing.assert_array_equal(distance_transform(m, edge=True), padded)


@pytest.mark.parametrize("shape", [(1, 1), (2, 1), (1, 3), (5, 4)])
def test_distance_transform_of_a_mask_with_no_false_cell_equals_ndimage(shape: tuple[int, int]) -> None:
    # The case a random mask hits now and then (found by the property test above on a clean clone): all True.
    m = np.ones(shape, bool)
    np.testing.assert_array_equal(distance_transform(m), ndimage.distance_transform_edt(m))
    np.testing.assert_array_equal(distance_transform(~m), ndimage.distance_transform_edt(~m))
    padded = ndimage.distance_transform_edt(pad2(m, 1, False))[1:-1, 1:-1]
    np.testing.assert_array_equal(distance_transform(m, edge=True), padded)


def test_disk_filter_refuses_a_footprint_it_cannot_split_into_rows() -> None:
    ring = np.ones((3, 3), bool)
    ring[1, 1] = False
    try:
        disk_filter(np.zeros((4, 4)), ring, np.maximum)
    except ValueError as e:
        assert "centred on the middle column" in str(e)
    else:
        raise AssertionError("a ring footprint was accepted")


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**31))
def test_signed_distance_equals_the_two_full_distance_transforms(seed: int) -> None:
    """The inside distances come from the obstacles' bounding box only; the same as over the whole map."""
    mask = _grid(seed, bool_=True)
    res = 0.03
    got = signed_distance(mask, res)
    if mask.any() and not mask.all():
        d_out = ndimage.distance_transform_edt(~mask)
        d_in = ndimage.distance_transform_edt(mask)
        np.testing.assert_array_equal(got, np.where(mask, -(d_in - 0.5), d_out - 0.5) * res)
    else:
        assert np.all(np.abs(got) == np.hypot(*mask.shape) * res)


def _fill_reference(ground_z: np.ndarray, rounds: int, default_z: float) -> np.ndarray:
    """The ground fill as first written: each round an unknown cell with a known 3 × 3 neighbour takes the lowest;
    then the nearest known value."""
    h = ground_z.copy()
    known = np.isfinite(h)
    if not known.any():
        return np.full(h.shape, default_z)
    for _ in range(rounds):
        if known.all():
            break
        m = ndimage.minimum_filter(np.where(known, h, np.inf), size=3, mode="nearest")
        new = ~known & np.isfinite(m)
        if not new.any():
            break
        h[new] = m[new]
        known |= new
    if not known.all():
        _, (ix, iy) = ndimage.distance_transform_edt(~known, return_indices=True)
        h = h[ix, iy]
    return h


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**31), st.integers(0, 6))
def test_ground_fill_equals_the_round_by_round_reference(seed: int, rounds: int) -> None:
    rng = np.random.default_rng(seed)
    g = _grid(seed)
    g[rng.random(g.shape) < rng.uniform(0.0, 1.0)] = np.nan
    np.testing.assert_array_equal(_fill_ground(g, rounds, -1.0)[0], _fill_reference(g, rounds, -1.0))


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**31), st.lists(st.floats(0.5, 6.0), min_size=1, max_size=4))
def test_several_disk_filters_at_once_equal_each_alone(seed: int, radii: list[float]) -> None:
    """Footprints sharing one set of row windows give what each gives alone, edges repeated or a constant."""
    a = _grid(seed)
    fps = tuple(_disk(r) for r in radii)
    for op, cval in ((np.minimum, None), (np.maximum, None), (np.minimum, np.inf), (np.maximum, -1.0)):
        for got, fp in zip(disk_filters(a, fps, op, cval), fps, strict=True):
            np.testing.assert_array_equal(got, disk_filter(a, fp, op, cval))
            if cval is None:
                nd = ndimage.minimum_filter if op is np.minimum else ndimage.maximum_filter
                np.testing.assert_array_equal(got, nd(a, footprint=fp, mode="nearest"))


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**31), st.integers(0, 6), st.booleans())
def test_padding_equals_numpy_pad(seed: int, r: int, boolean: bool) -> None:
    """Edge values (corners included) or a constant around a grid, as np.pad gives them."""
    a = _grid(seed, boolean)
    cval = False if boolean else 7.5
    np.testing.assert_array_equal(pad2(a, r), np.pad(a, r, mode="edge"))
    np.testing.assert_array_equal(pad2(a, r, cval), np.pad(a, r, constant_values=cval))


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**31))
def test_first_true_equals_argmax_where_any(seed: int) -> None:
    rng = np.random.default_rng(seed)
    rows = (
        int(rng.integers(1, 40)) if seed % 3 else int(rng.integers(250, 300))
    )  # (one byte per row number or two)
    a = rng.random((rows, int(rng.integers(1, 30)))) < rng.uniform(0.0, 0.3)
    got = _first_true(a)
    np.testing.assert_array_equal(got, np.where(a.any(axis=0), np.argmax(a, axis=0), a.shape[0]))


def _random_cloud(rng: np.random.Generator, center: np.ndarray) -> PointCloud:
    """Rays from two or three 'cameras' near the center (one sometimes off the map), some hits far off the map."""
    pts, origins = [], []
    for _ in range(int(rng.integers(2, 4))):
        o = center + rng.uniform(-0.3, 0.3, 3) + np.array([0.0, 0.0, 0.3])
        if rng.random() < 0.15:
            o[int(rng.integers(0, 3))] += rng.choice([-1.5, 1.5])
        n = int(rng.integers(5, 60))
        d = rng.normal(size=(n, 3))
        d[:, 2] = -np.abs(d[:, 2]) * rng.uniform(0.2, 2.0)
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        r = rng.uniform(0.0, 1.5, n)
        pts.append(o + d * r[:, None])
        origins.append(np.broadcast_to(o, (n, 3)))
    return PointCloud(np.concatenate(pts), np.concatenate(origins), 0.0)


def _misses_reference(vm: VoxelMap, cloud: PointCloud, misses: np.ndarray, w: np.float32) -> None:
    """Adds one scan's misses ray by ray: every voxel from half a voxel on, to carve_margin short of the hit."""
    p, res = vm.params, vm.res
    for o, q in zip(
        cloud.p_world_origins[:: p.carve_every], cloud.p_world_points[:: p.carve_every], strict=True
    ):
        d = q - o
        length = float(np.linalg.norm(d))
        u = d / max(length, 1e-9)
        n = max(int(np.floor((length - p.carve_margin_m) / res - 0.5)) + 1, 0)
        t = (np.arange(n) + 0.5) * res
        s = [u[c] * t + o[c] for c in range(3)]
        flat, _ = vm._flat_index_xyz(*s)
        np.add.at(misses.reshape(-1), flat, w)


def _integrate_reference(vm: VoxelMap, cloud: PointCloud, center: np.ndarray) -> None:
    """One scan into vm as first written: hits and heights per point, then the misses ray by ray."""
    vm.recenter((float(center[0]), float(center[1])), float(center[2]))
    vm._weight /= vm.params.decay
    w = np.float32(vm._weight)
    pts = cloud.p_world_points
    flat, ok = vm._flat_index(pts)
    np.add.at(vm.hits.reshape(-1), flat, w)
    np.add.at(vm.sum_z.reshape(-1), flat, (w * pts[ok, 2]).astype(np.float32))
    _misses_reference(vm, cloud, vm.misses, w)


@settings(max_examples=25, deadline=None)
@given(st.integers(0, 2**31), st.sampled_from([1, 2]))
def test_voxel_carving_and_classification_equal_the_ray_and_column_references(seed: int, every: int) -> None:
    """Scans from a moving center (the map shifts): the statistics equal a ray-by-ray carving of every ray to its
    end (no clipping at the map's box, no chunks), and the columns equal the column-by-column scan from the bottom
    (voxels.py's rule) over all layers (no bands)."""
    rng = np.random.default_rng(seed)
    params = VoxelParams(**{**_SMALL.__dict__, "carve_every": every})
    fast, ref = VoxelMap(params), VoxelMap(params)
    center = np.zeros(3)
    for _ in range(int(rng.integers(1, 6))):
        center = center + np.append(rng.uniform(-0.25, 0.25, 2), rng.uniform(-0.15, 0.15))
        cloud = _random_cloud(rng, center)
        fast.integrate(cloud, (float(center[0]), float(center[1])), float(center[2]))
        _integrate_reference(ref, cloud, center)
        for name in ("hits", "misses", "sum_z"):
            np.testing.assert_array_equal(getattr(fast, name), getattr(ref, name), err_msg=name)
        # each row's hit bound (which classify reads the band's rows and trims it by) is at least its largest hits
        assert (fast._row_max >= fast.hits.max(axis=2)).all()
        _check_classification(fast)


def _check_classification(vm: VoxelMap) -> None:
    occ, free = vm._occupancy()
    ground_z, k_ground, has_ground, thin = vm._ground_reference(occ, free)
    obstacle = occ.copy()
    ii, jj = np.nonzero(has_ground)
    kg = k_ground[ii, jj]
    obstacle[kg, ii, jj] = False
    th = thin[ii, jj]
    obstacle[kg[th] + 1, ii[th], jj[th]] = False
    cols = vm.classify()
    np.testing.assert_array_equal(cols.ground_z, ground_z)
    np.testing.assert_array_equal(cols.obstacle, np.moveaxis(obstacle, 0, -1))
    # the same obstacle voxels as a list (layer, flat column)
    assert cols.obstacle_voxels is not None
    kk, ii, jj = np.nonzero(obstacle)
    got = sorted(zip(cols.obstacle_voxels[0].tolist(), cols.obstacle_voxels[1].tolist(), strict=True))
    assert got == sorted(zip(kk.tolist(), (ii * vm.n_xy + jj).tolist(), strict=True))
    if cols.obstacle_layers is not None:
        lo, hi = cols.obstacle_layers
        outside = np.ones(vm.n_z, bool)
        outside[max(lo, 0) : hi + 1] = False
        assert not cols.obstacle[..., outside].any()


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**31))
def test_classification_equals_the_column_reference_on_random_statistics(seed: int) -> None:
    """Hits and misses drawn at random in layer bands of their own (misses all below the hits, all above, or
    overlapping them; sparse or dense), the bands given as the map keeps them: the columns equal the reference."""
    rng = np.random.default_rng(seed)
    vm = VoxelMap(_SMALL)
    nz = vm.n_z
    h0, h1 = sorted(int(v) for v in rng.integers(0, nz, 2))
    m0, m1 = sorted(int(v) for v in rng.integers(0, nz, 2))
    vm._weight = float(rng.uniform(1.0, 5.0))
    dense = rng.uniform(0.05, 0.9)
    hits = np.where(rng.random(vm.hits.shape) < dense, rng.uniform(0.0, 4.0, vm.hits.shape), 0.0)
    misses = np.where(rng.random(vm.misses.shape) < dense, rng.uniform(0.0, 6.0, vm.misses.shape), 0.0)
    hits[:h0] = hits[h1 + 1 :] = 0.0
    misses[:m0] = misses[m1 + 1 :] = 0.0
    vm.hits[...] = hits
    vm.misses[...] = misses
    vm.sum_z[...] = hits * rng.uniform(-0.5, 0.5, hits.shape)
    vm._hit_layers, vm._miss_layers = (h0, h1), (m0, m1)
    vm._recount_row_max()
    _check_classification(vm)


def test_ground_above_every_seen_through_layer_stands() -> None:
    """A column whose lowest occupied voxel lies above every layer any ray passed through has ground there."""
    vm = VoxelMap(_SMALL)
    vm.hits[8, 3, 3] = vm.sum_z[8, 3, 3] = 5.0
    vm.misses[1, 5, 5] = 5.0
    vm._hit_layers, vm._miss_layers = (8, 8), (1, 1)
    vm._recount_row_max()
    cols = vm.classify()
    assert cols.ground_z[3, 3] == 1.0
    _check_classification(vm)


@settings(max_examples=20, deadline=None)
@given(st.integers(0, 2**31))
def test_one_point_lookups_equal_the_array_lookups(seed: int) -> None:
    """The maps' one-point lookups (Python floats: the planners' many single queries) give what the array path
    gives: points on the map, on half-cell boundaries (rounding half to even), at its border and off it."""
    from planning.terrain.maps import maps_from_grids

    rng = np.random.default_rng(seed)
    nx, ny = int(rng.integers(3, 12)), int(rng.integers(3, 12))
    res = float(rng.choice([0.03, 0.05, 0.1]))
    origin = (float(rng.uniform(-1, 1)), float(rng.uniform(-1, 1)))
    maps = maps_from_grids(origin, res, rng.normal(size=(nx, ny)), rng.random((nx, ny)) < 0.4)
    k = rng.integers(-2, max(nx, ny) + 2, (40, 2)) + rng.choice([0.0, 0.5, -0.5, 0.3, 0.49], (40, 2))
    for fx, fy in k:
        x, y = origin[0] + float(fx) * res, origin[1] + float(fy) * res
        for f in (maps.no_step, maps.no_body, maps.clearance_at, maps.height_at, maps.sdf_step):
            one, arr = f(x, y), f(np.array([x]), np.array([y]))[0]
            assert one == arr and type(one) is type(arr.item()), (f.__name__, x, y, one, arr)


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**31))
def test_obstacle_layers_between_heights_equal_a_direct_count(seed: int) -> None:
    """Whether an obstacle layer's centre lies in [z_lo, z_hi], voxel by voxel from the obstacle list, equals a
    direct count per column: spans below, across, above the occupied band and the grid, empty and inverted spans,
    layer centres exactly on a bound."""
    from planning.terrain.maps import _any_between, _obstacle_voxels
    from planning.terrain.voxels import Columns

    rng = np.random.default_rng(seed)
    nx, ny, nz = (int(v) for v in rng.integers(1, 9, 3))
    obstacle = rng.random((nx, ny, nz)) < rng.uniform(0.0, 0.6)
    z0, dz = float(rng.uniform(-1, 1)), 0.05
    columns = Columns((0.0, 0.0), 0.05, np.zeros((nx, ny)), obstacle, z0, dz)
    vox = _obstacle_voxels(columns)
    zc = z0 + dz * np.arange(nz)
    z_lo = z0 + dz * rng.integers(-3, nz + 3, (nx, ny)) + rng.choice([0.0, 0.02, -0.02], (nx, ny))
    z_hi = z_lo + dz * rng.integers(-2, nz + 2, (nx, ny)) + rng.choice([0.0, 0.03], (nx, ny))
    got = _any_between(vox, z0, dz, z_lo, z_hi)
    inside = (zc >= z_lo[..., None] - 1e-9 * dz) & (zc <= z_hi[..., None] + 1e-9 * dz)
    np.testing.assert_array_equal(got, np.count_nonzero(obstacle & inside, axis=2) > 0)


@settings(max_examples=300, deadline=None)
@given(st.integers(0, 2**31))
def test_nearest_known_equals_feature_transform(seed: int) -> None:
    """The ground fill's nearest known cell, by its direct search (few unknown cells) or not: the same cell as
    ndimage's feature transform of the unknown cells, ties included (blocks of unknown cells and few known ones make
    equidistant cells common)."""
    rng = np.random.default_rng(seed)
    nx, ny = (int(v) for v in rng.integers(1, 50, 2))
    known = rng.random((nx, ny)) < rng.uniform(0.0, 1.0)
    if seed % 2:
        i0, j0 = int(rng.integers(0, nx)), int(rng.integers(0, ny))
        known[i0 : i0 + int(rng.integers(1, 25)), j0 : j0 + int(rng.integers(1, 25))] = False
    if seed % 5 == 0:
        known[:] = True
        known[rng.integers(0, nx, 3), rng.integers(0, ny, 3)] = False
    if not known.any():
        known[int(rng.integers(0, nx)), int(rng.integers(0, ny))] = True
    ft = np.empty((2, nx, ny), np.int32)
    ndimage.distance_transform_edt(~known, return_distances=False, return_indices=True, indices=ft)
    np.testing.assert_array_equal(_nearest_known(known), ft[0] * ny + ft[1])


def _fill_capped_reference(
    ground_z: np.ndarray, rounds: int, cap: np.ndarray, drop_m: float
) -> tuple[np.ndarray, np.ndarray]:
    """The ground fill under a cap as first written: each round an unknown cell with a known 3 × 3 neighbour takes
    the first lowest one's value (in row-major order around it), capped, and is a drop where the cap lies more than
    drop_m below that value or where that neighbour is a drop; then the nearest known cell's."""
    nx, ny = ground_z.shape
    h = np.where(np.isfinite(ground_z), ground_z, np.inf)
    known = np.isfinite(ground_z)
    drop = np.zeros((nx, ny), bool)
    for _ in range(rounds):
        new_h, new_drop, new = h.copy(), drop.copy(), np.zeros_like(known)
        for i in range(nx):
            for j in range(ny):
                if known[i, j]:
                    continue
                around = [
                    (a, b)
                    for a in (i - 1, i, i + 1)
                    for b in (j - 1, j, j + 1)
                    if 0 <= a < nx and 0 <= b < ny
                ]
                seen = [(a, b) for a, b in around if known[a, b]]
                if not seen:
                    continue
                # (argmin over the framed 3 x 3 window: unknown and off-grid cells hold +inf)
                vals = [h[a, b] if known[a, b] else np.inf for a, b in around]
                a, b = around[int(np.argmin(vals))]
                new_h[i, j] = np.minimum(h[a, b], cap[i, j])
                new_drop[i, j] = bool(cap[i, j] < h[a, b] - drop_m) or bool(drop[a, b])
                new[i, j] = True
        h, drop, known = new_h, new_drop, known | new
    if not known.all() and known.any():
        _, (ix, iy) = ndimage.distance_transform_edt(~known, return_indices=True)
        far = ~known
        src_h, src_drop = h[ix, iy], drop[ix, iy]
        drop = np.where(far, src_drop | (cap < src_h - drop_m), drop)
        h = np.where(far, np.minimum(src_h, cap), src_h)
    return h, drop


@settings(max_examples=80, deadline=None)
@given(st.integers(0, 2**31), st.integers(0, 5))
def test_ground_fill_under_a_cap_equals_the_round_by_round_reference(seed: int, rounds: int) -> None:
    """Values with ties and signed zeros, caps some of which make drops: the same heights, bit for bit, and drops."""
    rng = np.random.default_rng(seed)
    g = _grid(seed)
    g[rng.random(g.shape) < 0.2] = -0.0
    g[rng.random(g.shape) < rng.uniform(0.0, 1.0)] = np.nan
    if np.isfinite(g).all() or not np.isfinite(g).any():
        return
    cap = np.where(rng.random(g.shape) < 0.3, rng.integers(-6, 4, g.shape) * 0.25, np.inf)
    cap[rng.random(g.shape) < 0.1] = -0.0
    h, drop = _fill_ground(g, rounds, -1.0, cap, 0.1)
    want_h, want_drop = _fill_capped_reference(g, rounds, cap, 0.1)
    np.testing.assert_array_equal(h.view(np.int64), want_h.view(np.int64))
    np.testing.assert_array_equal(drop, want_drop)
