"""Maps: known scenes give known cells; signed distance fields match brute force."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from scipy import ndimage

from planning.terrain.maps import (
    MapParams,
    TerrainMaps,
    _clearance,
    _disk,
    _disk_count,
    _obstacle_voxels,
    _remove_specks,
    build_maps,
    maps_from_grids,
    maps_from_scene,
    signed_distance,
)
from planning.terrain.scenes import build_terrain
from planning.terrain.voxels import Columns


def test_clutter_box_tops_are_steppable_only_when_low_and_wide() -> None:
    scene = build_terrain("clutter", seed=0)
    maps = maps_from_scene(scene, center_xy=(3.0, 0.0), half_extent_m=2.2)
    boxes = {}
    for line in scene.worldbody_xml.splitlines():
        if 'type="box"' in line:
            name = line.split('name="')[1].split('"')[0]
            pos = [float(v) for v in line.split('pos="')[1].split('"')[0].split()]
            size = [float(v) for v in line.split('size="')[1].split('"')[0].split()]
            boxes[name] = (pos, size)
    # The wide low platform: its middle is ground for steps, at its top height.
    (px, py, pz), (sx, sy, sz) = boxes["terrain_box_platform"]
    assert not maps.no_step(px, py)
    assert maps.height_at(px, py) == pytest.approx(2 * sz, abs=1e-6)
    assert not maps.no_body(px, py)
    # Small low boxes: a foot may not land on them (edges all around), the body passes over them.
    low = [v for k, v in boxes.items() if k.startswith("terrain_box_low_")]
    assert low
    for (x, y, _), _ in low:
        if maps.in_map(x, y):
            assert maps.no_step(x, y)
            assert not maps.no_body(x, y)
    # Tall boxes are body obstacles.
    (x, y, _), _ = boxes["terrain_obstacle_box_tall_0"]
    assert maps.no_body(x, y) and maps.no_step(x, y)


def test_table_top_is_not_ground_and_its_legs_are_body_obstacles() -> None:
    scene = build_terrain("under-table")
    p = scene.params
    maps = maps_from_scene(scene, center_xy=(p.x_center_m, 0.0))
    assert maps.height_at(p.x_center_m, 0.0) == pytest.approx(0.0, abs=1e-9)
    assert not maps.no_body(p.x_center_m, 0.0)
    assert not maps.no_step(p.x_center_m, 0.0)
    assert maps.clearance_at(p.x_center_m, 0.0) == pytest.approx(p.clearance_m, abs=0.03)
    leg_x = p.x_center_m + p.length_m / 2 - p.leg_m / 2
    leg_y = p.width_m / 2 - p.leg_m / 2
    assert maps.no_body(leg_x, leg_y) and maps.no_body(leg_x, -leg_y)
    assert maps.clearance_at(0.0, 0.0) == np.inf


def test_stairs_rails_are_body_obstacles_and_treads_are_steppable() -> None:
    scene = build_terrain("stairs")
    p = scene.params
    maps = maps_from_scene(scene, center_xy=(2.0, 0.0))
    rail_y = p.width_m / 2 + p.rail_offset_m + 0.02
    for x in (1.2, 1.6, 2.5, 3.0):
        assert maps.no_body(x, rail_y) and maps.no_body(x, -rail_y)
        assert not maps.no_body(x, 0.0)
    for k in range(p.n_steps):
        x_mid = p.x_start_m + (k + 0.5) * p.tread_m
        assert not maps.no_step(x_mid, 0.0)
        assert maps.height_at(x_mid, 0.0) == pytest.approx((k + 1) * p.riser_m)
        assert maps.no_step(p.x_start_m + k * p.tread_m, 0.0)  # the riser's edge


def test_stones_gaps_are_no_step() -> None:
    scene = build_terrain("stones", seed=2)
    maps = maps_from_scene(scene, center_xy=(3.0, 0.0), half_extent_m=2.2)
    xs = np.arange(1.0, 5.0, 0.01)
    ys = np.full_like(xs, 0.25)
    pit = np.asarray(scene.ground_height(xs, ys)) < -0.2
    no_step = np.asarray(maps.no_step(xs, ys))
    assert np.all(no_step[pit])
    assert np.any(~no_step[~pit])


def brute_force_sdf(mask: np.ndarray, res: float) -> np.ndarray:
    ii, jj = np.indices(mask.shape)
    cells = np.stack([ii.ravel(), jj.ravel()], axis=1).astype(float)
    m = mask.ravel()
    d = np.linalg.norm(cells[:, None, :] - cells[None, :, :], axis=2)
    out = np.empty(m.shape)
    for c in range(cells.shape[0]):
        other = ~m if m[c] else m
        dist = d[c, other].min() - 0.5
        out[c] = -dist if m[c] else dist
    return out.reshape(mask.shape) * res


@settings(max_examples=40, deadline=None)
@given(
    arrays(np.bool_, st.tuples(st.integers(2, 12), st.integers(2, 12))), st.sampled_from([0.03, 0.05, 0.1])
)
def test_signed_distance_matches_brute_force(mask: np.ndarray, res: float) -> None:
    if not mask.any() or mask.all():
        sdf = signed_distance(mask, res)
        assert np.all(np.sign(sdf) == (-1 if mask.all() else 1))
        return
    np.testing.assert_allclose(signed_distance(mask, res), brute_force_sdf(mask, res), atol=1e-9)


def test_sdf_queries_interpolate_and_gradient_points_away() -> None:
    step = np.zeros((40, 40), dtype=bool)
    step[20:, :] = True  # no-step for x >= 20 cells
    maps = maps_from_grids((0.0, 0.0), 0.05, np.zeros((40, 40)), step)
    boundary_x = 19.5 * 0.05
    assert maps.sdf_step(boundary_x, 1.0) == pytest.approx(0.0, abs=1e-9)
    assert maps.sdf_step(boundary_x - 0.2, 1.0) == pytest.approx(0.2, abs=1e-9)
    assert maps.sdf_step(boundary_x + 0.2, 1.0) == pytest.approx(-0.2, abs=1e-9)
    g = maps.sdf_step_grad(boundary_x - 0.2, 1.0)
    assert g[0] < -0.9 and abs(g[1]) < 1e-9
    assert maps.no_step(1.5, 1.0) and not maps.no_step(0.5, 1.0)
    assert not maps.no_step(100.0, 1.0)  # off the map
    assert maps.sdf_step(np.array([0.1, 1.5]), np.array([0.2, 0.2])).shape == (2,)


@settings(max_examples=40, deadline=None)
@given(
    arrays(np.bool_, st.tuples(st.integers(1, 30), st.integers(1, 30))),
    st.floats(0.5, 10.5, allow_nan=False),
)
def test_disk_count_matches_a_brute_force_correlation(mask: np.ndarray, radius_cells: float) -> None:
    """The dense-area rule counts step cells under a disk by row prefix sums; the count is the correlation's, edge
    cells repeating beyond the map (mode "nearest"), the disk wider than the map included."""
    disk = _disk(radius_cells)
    want = ndimage.correlate(mask.astype(np.int64), disk.astype(np.int64), mode="nearest")
    np.testing.assert_array_equal(_disk_count(mask, disk), want)


@settings(max_examples=60, deadline=None)
@given(
    arrays(np.bool_, st.tuples(st.integers(1, 6), st.integers(1, 6), st.integers(1, 20))),
    st.booleans(),
    st.integers(0, 2**31),
)
def test_clearance_is_the_lowest_obstacle_layer_high_enough_above_the_ground(
    obstacle: np.ndarray, give_band: bool, seed: int
) -> None:
    """The obstacle voxels are found in the occupancy (over the band the columns give, or all layers) or taken from
    the columns' own list; the clearance from them is, per column, the underside of the lowest obstacle layer whose
    index is at least ceil((h + above - z0) / dz) (clipped to the grid), less the ground: a direct scan's."""
    nx, ny, nz = obstacle.shape
    band = None
    if give_band:
        k = np.flatnonzero(obstacle.any(axis=(0, 1)))
        band = (int(k[0]), int(k[-1])) if k.size else (0, -1)
    rng = np.random.default_rng(seed)
    z0, dz = float(rng.uniform(-1, 1)), 0.05
    h = z0 + dz * rng.integers(-3, nz + 3, (nx, ny)) + rng.choice([0.0, 0.01, -0.02], (nx, ny))
    columns = Columns((0.0, 0.0), 0.05, np.zeros((nx, ny)), obstacle, z0, dz, band)
    vox = _obstacle_voxels(columns)
    ii, jj, kk = np.nonzero(obstacle)
    want_vox = sorted(zip(kk.tolist(), (ii * ny + jj).tolist(), strict=True))
    assert sorted(zip(vox.layer.tolist(), vox.cell.tolist(), strict=True)) == want_vox
    listed = _obstacle_voxels(dataclasses.replace(columns, obstacle_voxels=(kk, ii * ny + jj)))
    got = _clearance(vox, z0, dz, nz, h, 0.3)
    np.testing.assert_array_equal(_clearance(listed, z0, dz, nz, h, 0.3), got)
    want = np.full((nx, ny), np.inf)
    for i in range(nx):
        for j in range(ny):
            k_c = min(max(int(np.ceil((h[i, j] + 0.3 - z0) / dz)), 0), nz)
            ks = [k for k in range(k_c, nz) if obstacle[i, j, k]]
            if ks:
                want[i, j] = z0 + ks[0] * dz - dz / 2 - h[i, j]
    np.testing.assert_array_equal(got, want)


@settings(max_examples=100, deadline=None)
@given(
    arrays(np.bool_, st.tuples(st.integers(1, 12), st.integers(1, 12)), elements=st.booleans()),
    st.integers(1, 5),
)
def test_speck_removal_drops_exactly_the_small_8_connected_components(
    mask: np.ndarray, min_cells: int
) -> None:
    """Components of fewer than min_cells cells (8-connected) go, the rest stay: counted from neighbours for 2 and
    3 cells, by labelling beyond; both equal a labelling's sizes."""
    labels, n = ndimage.label(mask, structure=np.ones((3, 3), bool))
    sizes = np.bincount(labels.ravel(), minlength=n + 1)
    keep = sizes >= min_cells
    keep[0] = False
    np.testing.assert_array_equal(_remove_specks(mask, min_cells), keep[labels])


def test_a_stone_too_high_above_its_pit_is_no_body_obstacle_when_dense_counts_high_is_off() -> None:
    """A wide block standing just over max_step_height_m above the pit around it is a step obstacle cell by cell (too
    high to step onto from the pit); counted by the dense rule it becomes a body obstacle, which the regions pipeline
    does not want (the body passes over a stone); dense_counts_high=False leaves it a step obstacle only."""
    n, res = 60, 0.03
    p = MapParams()
    ground = np.full((n, n), -0.30)
    ground[18:42, 18:42] = (
        -0.30 + p.max_step_height_m + 0.005
    )  # 0.72 m wide, every cell within low_radius_m of the pit
    columns = Columns((0.0, 0.0), res, ground, np.zeros((n, n, 4), dtype=bool), -0.3, 0.05, (0, -1))
    shipped = build_maps(columns, p)
    counted_low = build_maps(columns, dataclasses.replace(p, dense_counts_high=False))
    assert shipped.body_obstacle[30, 30] and shipped.step_obstacle[30, 30]
    assert counted_low.step_obstacle[18:42, 18:42].all() and not counted_low.body_obstacle.any()


def test_the_body_band_from_the_support_keeps_stone_edges_over_a_pit_slot_out_and_a_tall_box_in() -> None:
    """A 6 cm slot of pit between two stones holds the stones' top-edge returns 0.3 m above the pit floor: inside the
    body band measured from the slot's own ground (a body obstacle the body path swerves around), not with the band
    also measured from the ground the robot stands on (band_from_support; the stones' tops, default_ground_z 0).
    A box 0.45 m tall on the floor the robot stands on stays a body obstacle either way."""
    n, res, dz = 40, 0.03, 0.03
    z0 = -0.30
    nz = 40
    p = MapParams()
    ground = np.zeros((n, n))
    ground[:, 19:21] = -0.30  # the slot between the left and right stones
    occ = np.zeros((n, n, nz), dtype=bool)
    k_top = int(round((0.0 - z0) / dz))  # the stones' top edges seen in the slot's columns
    occ[:, 19:21, k_top] = True
    columns = Columns((0.0, 0.0), res, ground, occ, z0, dz)
    shipped = build_maps(columns, p, default_ground_z=0.0)
    support = build_maps(columns, dataclasses.replace(p, band_from_support=True), default_ground_z=0.0)
    assert shipped.body_obstacle[:, 19:21].any()
    assert not support.body_obstacle.any()
    # A tall box on the floor: its sides are in the band above the floor the robot stands on.
    floor = np.zeros((n, n))
    occ_box = np.zeros((n, n, nz), dtype=bool)
    k_lo, k_hi = int(round((0.0 - z0) / dz)), int(round((0.45 - z0) / dz))
    occ_box[18:22, 18:22, k_lo : k_hi + 1] = True
    box = Columns((0.0, 0.0), res, floor, occ_box, z0, dz)
    for params in (p, dataclasses.replace(p, band_from_support=True)):
        assert build_maps(box, params, default_ground_z=0.0).body_obstacle[18:22, 18:22].all()


def test_the_open_edge_of_a_landing_the_robot_stands_on_is_a_body_obstacle_it_cannot_hit() -> None:
    """A landing 0.6 m above the floor, its side open: from the landing (band_from_support, default_ground_z the
    landing's top) its edge and the floor's cells at its foot stay body obstacles (the body path keeps off the drop)
    but are drop_only, and the collide SDF reads them free; a box 0.45 m tall on the landing stays in both. From
    the floor the landing's side is a wall the body can hit: nothing is drop_only there."""
    n, res, dz, z0, nz = 60, 0.03, 0.03, -0.1, 40
    p = dataclasses.replace(MapParams(), band_from_support=True)
    ground = np.zeros((n, n))
    ground[:, :30] = 0.6  # the landing: y < 0.9 m; the floor beyond its open side
    occ = np.zeros((n, n, nz), dtype=bool)
    k_lo, k_hi = int(round((0.6 - z0) / dz)), int(round((1.05 - z0) / dz))
    occ[10:14, 10:14, k_lo : k_hi + 1] = True  # a tall box on the landing
    columns = Columns((0.0, 0.0), res, ground, occ, z0, dz)
    top = build_maps(columns, p, default_ground_z=0.6)
    assert top.drop_only is not None
    edge = top.body_obstacle[:, 27:33].any(axis=1)
    assert edge[20:40].all()  # the edge is a body obstacle
    assert top.drop_only[20:40, 27:33][top.body_obstacle[20:40, 27:33]].all()  # ... and only a drop
    assert top.body_obstacle[10:14, 10:14].all() and not top.drop_only[10:14, 10:14].any()
    # The collide SDF: the edge is free, 0.45 m from it on the landing; the box is still an obstacle.
    x, y_edge = 30 * res, 29.5 * res
    assert top.sdf_body(x, y_edge - 0.15) < 0.2
    assert top.sdf_collide(x, y_edge - 0.15) > 0.5
    assert top.sdf_collide(12 * res, 12 * res) < 0.0
    g = top.sdf_collide_grad(12 * res, 17 * res)
    assert g[1] > 0.5  # away from the box
    floor = build_maps(columns, p, default_ground_z=0.0)
    assert floor.body_obstacle[20:40, 27:33].any(axis=1).all()
    assert floor.drop_only is not None and not (floor.drop_only & floor.body_obstacle)[:, 20:].any()
    assert floor.sdf_collide(x, y_edge + 0.15) == pytest.approx(floor.sdf_body(x, y_edge + 0.15))
    # Without band_from_support (the shipped default settings) no drop is told apart.
    assert build_maps(columns, MapParams(), default_ground_z=0.6).drop_only is None


def test_the_step_sdf_computed_on_first_read_equals_the_one_computed_at_once() -> None:
    """build_maps leaves the step SDF and its gradient, and the body SDF's gradient, to their first read: the same
    values; replace, pickling and a missing attribute behave as for plain maps."""
    import pickle

    from planning.terrain.maps import _gradient, columns_from_scene

    maps = build_maps(columns_from_scene(build_terrain("stairs"), (1.0, 0.0), 1.5))
    assert isinstance(maps, TerrainMaps)
    assert "sdf_step_m" not in vars(maps) and "grad_sdf_body" not in vars(maps)
    again = pickle.loads(pickle.dumps(maps))  # pickled before the first read: still computed on use
    sdf = signed_distance(maps.step_obstacle, maps.resolution_m)
    np.testing.assert_array_equal(maps.sdf_step_m, sdf)
    np.testing.assert_array_equal(maps.grad_sdf_step, _gradient(sdf, maps.resolution_m))
    assert maps.sdf_step_m is maps.sdf_step_m  # computed once
    np.testing.assert_array_equal(maps.grad_sdf_body, _gradient(maps.sdf_body_m, maps.resolution_m))
    assert maps.grad_sdf_body is maps.grad_sdf_body
    np.testing.assert_array_equal(again.grad_sdf_body, maps.grad_sdf_body)
    np.testing.assert_array_equal(again.grad_sdf_step, maps.grad_sdf_step)
    assert maps.sdf_step(1.0, 0.2) == again.sdf_step(1.0, 0.2)
    plain = dataclasses.replace(maps, t_s=1.0)
    assert "sdf_step_m" in vars(plain)  # every field passed on
    np.testing.assert_array_equal(plain.sdf_step_m, sdf)
    with pytest.raises(AttributeError):
        _ = maps.no_such_map  # type: ignore[attr-defined]


def test_free_space_seen_in_an_unknown_column_makes_the_shadow_past_an_edge_a_drop() -> None:
    """A stone's top (0 m) over a pit, the 3 rows past its far edge never hit (the sensor's shadow). Filled from
    their lowest neighbour they read as more stone. Where rays were seen passing through those columns well below
    the top (Columns.free_floor_z), the fill is bounded by it and the cells are step obstacles (the top provably
    ends there); a column seen free only within the top's own voxel (a grazing ray) is left as it was."""
    n, res = 40, 0.03
    ground = np.full((n, n), np.nan)
    ground[:20, :] = 0.0  # the stone, seen
    free = np.full((n, n), np.inf)
    free[20:23, :20] = -0.075  # rays passed 7.5 cm under the top here (left half)
    free[20:23, 20:] = -0.015  # only through the top's own voxel here (right half)
    columns = Columns(
        (0.0, 0.0), res, ground, np.zeros((n, n, 4), dtype=bool), -0.3, 0.03, (0, -1), None, free
    )
    off = build_maps(columns, MapParams(fill_below_free=False))
    on = build_maps(columns, MapParams())
    assert not off.step_obstacle[20:23].any() and np.allclose(off.ground_height[20:23], 0.0)
    assert on.step_obstacle[20:23, :20].all()
    assert np.all(on.ground_height[20:23, :20] <= -0.075 + 1e-9)
    # the right half: bounded by -0.015 (within free_drop_m of the top): no drop, no step obstacle from it
    assert not on.step_obstacle[20:23, 25:].any()
    # the cells filled beyond the bounded ones carry the bound on
    assert np.all(on.ground_height[23:, :15] <= -0.075 + 1e-9)
    # the seen stone is untouched
    assert np.allclose(on.ground_height[:19], 0.0) and not on.step_obstacle[:18].any()
