"""Steppable regions: a stair tread, a stone's top, the floor between boxes and a slope each come out as one planar
region, covered by convex polygons that keep a foot's sole on it."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from planning.robot import load_robot
from planning.terrain.maps import TerrainMaps, maps_from_grids, maps_from_scene
from planning.terrain.regions import (
    ConvexRegion,
    RegionParams,
    SteppableRegions,
    convex_around,
    segment_regions,
    shadow_cells,
    shadow_depth,
)
from planning.terrain.scenes import build_terrain

RES = 0.03
PARAMS = RegionParams(foot_radius_m=0.02, edge_margin_m=0.02)


def _grid(nx: int, ny: int, origin: tuple[float, float] = (0.0, 0.0)) -> tuple[np.ndarray, np.ndarray]:
    xs = origin[0] + np.arange(nx) * RES
    ys = origin[1] + np.arange(ny) * RES
    return np.broadcast_to(xs[:, None], (nx, ny)), np.broadcast_to(ys[None, :], (nx, ny))


def _maps(h: np.ndarray, step: np.ndarray | None = None) -> TerrainMaps:
    return maps_from_grids((0.0, 0.0), RES, h, np.zeros(h.shape, bool) if step is None else step)


def _assert_polygons_inside(regions: SteppableRegions, maps: TerrainMaps) -> None:
    """Every polygon's vertices (and points inside) lie on its own region, inset from its edge: a foot centred
    anywhere in it keeps its sole (foot radius) off the region's edge."""
    for poly in regions.polygons:
        pts = np.vstack([poly.vertices, 0.5 * (poly.vertices + poly.seed)])
        for x, y in pts:
            # a foot centred here: its rim, 8 points, on cells of the same region
            for a in np.linspace(0.0, 2 * np.pi, 8, endpoint=False):
                r = regions.params.foot_radius_m
                assert regions.label_at(x + r * math.cos(a), y + r * math.sin(a)) == poly.label


def test_stair_treads_are_one_region_each_with_a_level_plane() -> None:
    X, _ = _grid(100, 50)
    # floor, then 3 treads of 0.30 m rising 0.15 m each from x = 0.9 m, then a landing
    k = np.clip(np.floor((X - 0.915) / 0.30) + 1, 0, 4)  # risers between cell centres
    h = 0.15 * k
    maps = _maps(h)
    regions = segment_regions(maps, PARAMS)
    labels = {regions.label_at(x, 0.75) for x in (0.45, 1.05, 1.35, 1.65, 2.5)}
    assert 0 not in labels and len(labels) == 5
    # each tread its own region, level, at its height
    for x, z in ((1.05, 0.15), (1.35, 0.30), (1.65, 0.45)):
        lab = regions.label_at(x, 0.75)
        assert regions.slope_deg(lab) < 1.0
        assert regions.z0[lab] == pytest.approx(z, abs=1e-9)
        polys = regions.polygons_of(lab)
        assert polys, f"tread at x={x} has no polygon"
        # the tread is 0.30 m deep: a polygon along it, inset from its riser and nosing
        xmin = min(float(p.vertices[:, 0].min()) for p in polys)
        xmax = max(float(p.vertices[:, 0].max()) for p in polys)
        # (the cell at the riser's foot is cut: the polygon starts a cell further from the riser)
        assert xmax - xmin == pytest.approx(0.30 - RES - 2 * PARAMS.inset_m, abs=RES)
        assert max(p.area_m2 for p in polys) > 0.15 * 1.2
    _assert_polygons_inside(regions, maps)


def test_a_stone_top_is_a_region_of_its_own_and_its_polygon_keeps_off_its_edges() -> None:
    X, Y = _grid(80, 80)
    h = np.full(X.shape, -0.30)  # the pit
    stone = (np.abs(X - 1.2) <= 0.15) & (np.abs(Y - 1.2) <= 0.20)
    h[stone] = 0.02
    maps = _maps(h)
    regions = segment_regions(maps, PARAMS)
    lab = regions.label_at(1.2, 1.2)
    assert lab != 0 and lab != regions.label_at(0.3, 0.3)
    assert regions.z0[lab] == pytest.approx(0.02)
    polys = regions.polygons_of(lab)
    assert len(polys) == 1
    v = polys[0].vertices
    # the stone spans 1.05..1.35 × 1.0..1.4 (cell centres 1.05.. within); the polygon is inset by the foot + margin
    assert v[:, 0].min() >= 1.05 - RES / 2 + PARAMS.inset_m - 1e-6
    assert v[:, 0].max() <= 1.35 + RES / 2 - PARAMS.inset_m + 1e-6
    assert v[:, 1].min() >= 1.0 - RES / 2 + PARAMS.inset_m - 1e-6
    assert v[:, 1].max() <= 1.4 + RES / 2 - PARAMS.inset_m + 1e-6
    assert polys[0].area_m2 > 0.6 * (0.30 - 2 * PARAMS.inset_m) * (0.40 - 2 * PARAMS.inset_m)
    _assert_polygons_inside(regions, maps)


def test_the_floor_between_boxes_is_one_region_covered_by_several_convex_polygons() -> None:
    X, Y = _grid(90, 90)
    h = np.zeros(X.shape)
    boxes = [(0.8, 0.8, 0.10), (1.8, 1.4, 0.10), (1.2, 2.0, 0.6)]
    for bx, by, bz in boxes:
        h[(np.abs(X - bx) <= 0.15) & (np.abs(Y - by) <= 0.15)] = bz
    maps = _maps(h)
    regions = segment_regions(maps, PARAMS)
    floor = regions.label_at(0.2, 0.2)
    assert floor != 0
    for x, y in ((2.5, 2.5), (0.2, 2.5), (2.5, 0.2), (1.3, 1.1)):
        assert regions.label_at(x, y) == floor
    for bx, by, _ in boxes:
        assert regions.label_at(bx, by) not in (0, floor)  # a box top is a region of its own
    polys = regions.polygons_of(floor)
    assert 2 <= len(polys) <= PARAMS.max_polygons
    # the convex pieces cover most of the floor's inset and never reach over a box
    xs, ys = maps.cell_centers()
    inset = np.column_stack(
        [np.broadcast_to(xs[:, None], X.shape)[regions.inset & (regions.labels == floor)],
         np.broadcast_to(ys[None, :], X.shape)[regions.inset & (regions.labels == floor)]]
    )  # fmt: skip
    covered = np.zeros(len(inset), bool)
    for poly in polys:
        covered |= poly.contains(inset, 1e-6)
    assert covered.mean() >= 0.6
    _assert_polygons_inside(regions, maps)


@pytest.mark.parametrize("angle_deg", [5.0, 15.0, 25.0])
def test_a_slope_is_one_region_with_its_incline(angle_deg: float) -> None:
    X, _ = _grid(100, 60)
    rise = np.clip(X - 0.9, 0.0, 1.2) * math.tan(math.radians(angle_deg))
    h = rise
    maps = _maps(h)
    regions = segment_regions(maps, PARAMS)
    lab = regions.label_at(1.5, 0.9)
    assert lab != 0
    # no riser anywhere: floor, ramp and plateau are one steppable region (the kinks are not edges)
    assert regions.label_at(0.3, 0.9) == lab == regions.label_at(2.6, 0.9)
    ramp = convex_around(regions, lab, np.array([1.5, 0.9]))
    assert ramp is not None and bool(ramp.contains(np.array([1.5, 0.9])))
    # the plane of a region of ramp cells alone has the slope's angle
    ramp_only = _maps(np.where((X > 0.95) & (X < 2.05), h, -1.0))
    r2 = segment_regions(ramp_only, PARAMS)
    assert r2.slope_deg(r2.label_at(1.5, 0.9)) == pytest.approx(angle_deg, abs=0.5)
    assert r2.roughness_m[r2.label_at(1.5, 0.9)] < 1e-6


def test_too_steep_ground_and_step_obstacles_are_not_steppable() -> None:
    X, _ = _grid(60, 40)
    h = np.clip(X - 0.6, 0.0, None) * math.tan(math.radians(45.0))
    step = np.zeros(X.shape, bool)
    step[5:10, :] = True
    regions = segment_regions(_maps(h, step), PARAMS)
    assert regions.label_at(1.2, 0.6) == 0  # 45° is steeper than 35°
    assert regions.label_at(0.2, 0.6) == 0  # a step obstacle
    assert regions.label_at(0.45, 0.6) != 0


def test_a_patch_too_small_for_a_foot_is_dropped() -> None:
    X, Y = _grid(40, 40)
    h = np.full(X.shape, -0.3)
    h[(np.abs(X - 0.6) <= 0.03) & (np.abs(Y - 0.6) <= 0.03)] = 0.0  # a 9 cm post top
    regions = segment_regions(_maps(h), PARAMS)
    assert regions.label_at(0.6, 0.6) == 0


def test_convex_around_a_point_contains_its_nearest_inset_cell_and_only_its_region() -> None:
    X, Y = _grid(80, 80)
    h = np.zeros(X.shape)
    h[(np.abs(X - 1.2) <= 0.3) & (np.abs(Y - 1.2) <= 0.3)] = 0.12  # a platform
    maps = _maps(h)
    regions = segment_regions(maps, PARAMS)
    floor = regions.label_at(0.3, 0.3)
    # a nominal foothold on the platform's edge, asked on the floor: the polygon lies on the floor near it
    poly = convex_around(regions, floor, np.array([0.9, 1.2]))
    assert poly is not None
    assert poly.distance(np.array([0.9, 1.2])) < 0.12
    for x, y in poly.vertices:
        assert regions.label_at(x, y) == floor
    top = convex_around(regions, regions.label_at(1.2, 1.2), np.array([0.9, 1.2]))
    assert top is not None and top.vertices[:, 0].min() >= 0.9 + PARAMS.inset_m - 1e-6


@settings(max_examples=25, deadline=None)
@given(
    st.floats(0.6, 1.8), st.floats(0.6, 1.8), st.floats(0.1, 0.4), st.floats(0.1, 0.4), st.floats(-0.4, 0.4)
)
def test_a_random_block_gives_a_polygon_inside_its_top(
    cx: float, cy: float, hx: float, hy: float, z: float
) -> None:
    X, Y = _grid(82, 82)
    h = np.full(X.shape, -0.5 if z > -0.1 else 0.5)
    top = (np.abs(X - cx) <= hx) & (np.abs(Y - cy) <= hy)
    h[top] = z
    maps = _maps(h)
    regions = segment_regions(maps, PARAMS)
    lab = regions.label_at(cx, cy)
    assert lab != 0
    polys = regions.polygons_of(lab)
    assert polys
    ix, iy = np.nonzero(top)
    xs, ys = maps.cell_centers()
    lo = np.array([xs[ix].min(), ys[iy].min()]) - RES / 2 + PARAMS.inset_m - 1e-6
    hi = np.array([xs[ix].max(), ys[iy].max()]) + RES / 2 - PARAMS.inset_m + 1e-6
    for poly in polys:
        assert isinstance(poly, ConvexRegion)
        assert np.all(poly.vertices >= lo) and np.all(poly.vertices <= hi)
        # convex, counter-clockwise, and its half-planes hold at its vertices
        e = np.roll(poly.vertices, -1, axis=0) - poly.vertices
        cross = e[:, 0] * np.roll(e[:, 1], -1) - e[:, 1] * np.roll(e[:, 0], -1)
        assert np.all(cross >= -1e-9)
        assert np.all(poly.vertices @ poly.A.T <= poly.b[None, :] + 1e-9)


def test_from_robot_insets_by_the_foot_radius() -> None:
    robot = load_robot("spot")
    p = RegionParams.from_robot(robot, edge_margin_m=0.01)
    assert p.foot_radius_m == pytest.approx(robot.foot_radius_m)
    assert p.inset_m == pytest.approx(robot.foot_radius_m + 0.01)


@pytest.mark.parametrize("name", ["stairs", "stones", "clutter", "slope"])
def test_scene_maps_give_regions_where_feet_go(name: str) -> None:
    scene = build_terrain(name, seed=0)
    maps = maps_from_scene(scene, center_xy=(2.5, 0.0), half_extent_m=2.0)
    regions = segment_regions(maps, PARAMS)
    assert regions.n_regions >= 1 and regions.polygons
    # the start (flat floor before the terrain) is steppable
    assert regions.label_at(0.5, 0.0) != 0
    _assert_polygons_inside(regions, maps)


def _fit_planes_reference(labels: np.ndarray, n: int, X: np.ndarray, Y: np.ndarray, h: np.ndarray) -> tuple:
    """Each label's plane fitted cell by cell, centred on the label's own means (the straightforward way)."""
    normals, z0, xy0, rough = np.zeros((n + 1, 3)), np.zeros(n + 1), np.zeros((n + 1, 2)), np.zeros(n + 1)
    for lab in range(1, n + 1):
        sel = labels == lab
        x, y, z = X[sel], Y[sel], h[sel]
        dx, dy, dz = x - x.mean(), y - y.mean(), z - z.mean()
        a = b = 0.0  # one row or one column (or one cell): no slope (the fit's convention)
        if dx @ dx > 1e-9 and dy @ dy > 1e-9:
            a, b = np.linalg.solve(np.array([[dx @ dx, dx @ dy], [dx @ dy, dy @ dy]]), [dx @ dz, dy @ dz])
        nrm = np.array([-a, -b, 1.0])
        normals[lab] = nrm / np.linalg.norm(nrm)
        z0[lab], xy0[lab] = z.mean(), (x.mean(), y.mean())
        rough[lab] = math.sqrt(np.mean((dz - a * dx - b * dy) ** 2))
    return normals, z0, xy0, rough


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 10_000))
def test_plane_fit_from_moments_matches_a_cell_by_cell_fit(seed: int) -> None:
    """The plane fit's moments (per row / column sums) give each region's plane, centre and roughness as a fit over
    its own cells does: tilted noisy patches, one-row and one-column strips, single cells, far from the origin."""
    from planning.terrain.regions import _fit_planes

    rng = np.random.default_rng(seed)
    nx, ny = int(rng.integers(8, 40)), int(rng.integers(8, 40))
    X, Y = _grid(nx, ny, origin=(float(rng.uniform(-50, 50)), float(rng.uniform(-50, 50))))
    labels = np.zeros((nx, ny), np.int32)
    h = rng.normal(0.0, 0.3, (nx, ny))
    n = 0
    for _ in range(int(rng.integers(1, 6))):
        i0, j0 = int(rng.integers(0, nx - 1)), int(rng.integers(0, ny - 1))
        kind = rng.integers(0, 4)
        di = 1 if kind == 1 else int(rng.integers(1, 9))
        dj = 1 if kind == 2 else int(rng.integers(1, 9))
        if kind == 3:
            di = dj = 1
        n += 1
        labels[i0 : i0 + di, j0 : j0 + dj] = n
        a, b, c = rng.uniform(-0.6, 0.6, 3)
        sl = (slice(i0, i0 + di), slice(j0, j0 + dj))
        h[sl] = (
            c + a * X[sl] + b * Y[sl] - a * X[sl].mean() - b * Y[sl].mean() + rng.normal(0, 0.01, X[sl].shape)
        )
    present = np.unique(labels[labels > 0])
    relabel = np.zeros(n + 1, np.int32)
    relabel[present] = np.arange(1, present.size + 1)
    labels, n = relabel[labels], int(present.size)
    normals, z0, xy0, rough, area = _fit_planes(labels, n, X, Y, h, RES)
    ref = _fit_planes_reference(labels, n, X, Y, h)
    np.testing.assert_allclose(normals[1:], ref[0][1:], atol=1e-7)
    np.testing.assert_allclose(z0[1:], ref[1][1:], atol=1e-9)
    np.testing.assert_allclose(xy0[1:], ref[2][1:], atol=1e-9)
    np.testing.assert_allclose(rough[1:], ref[3][1:], atol=1e-6)
    np.testing.assert_allclose(area[1:], np.bincount(labels.ravel(), minlength=n + 1)[1:] * RES * RES)


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 10_000))
def test_steppable_cells_match_the_padded_differences_rule(seed: int) -> None:
    """steppable_cells (differences to the next cell, edges repeating) keeps the rule of the module docstring,
    written with an edge-padded grid: free, slope of the gentler one-sided difference, no 4-neighbour jump."""
    from planning.terrain.regions import steppable_cells

    rng = np.random.default_rng(seed)
    nx, ny = int(rng.integers(3, 30)), int(rng.integers(3, 30))
    h = np.round(rng.normal(0.0, 0.03, (nx, ny)), 3) + rng.choice([0.0, 0.1], (nx, ny), p=[0.8, 0.2])
    step = rng.random((nx, ny)) < 0.1
    maps = _maps(h, step)
    hp = np.pad(h, 1, mode="edge")
    c = hp[1:-1, 1:-1]
    xf, xb, yf, yb = hp[2:, 1:-1] - c, c - hp[:-2, 1:-1], hp[1:-1, 2:] - c, c - hp[1:-1, :-2]
    gx = np.minimum(np.abs(xf), np.abs(xb)) / RES
    gy = np.minimum(np.abs(yf), np.abs(yb)) / RES
    slope = np.hypot(gx, gy)
    tan = math.tan(math.radians(PARAMS.max_slope_deg))
    ref = ~step & (slope <= tan) & (np.maximum(np.maximum(xf, -xb), np.maximum(yf, -yb)) <= PARAMS.max_jump_m)
    got = steppable_cells(maps, PARAMS)
    # Cells whose slope sits within rounding of the bound may go either way (squared comparison).
    tie = np.abs(slope - tan) < 1e-9
    assert np.array_equal(got[~tie], ref[~tie])


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 10_000))
def test_projection_onto_a_polygon_matches_the_edge_by_edge_array_form(seed: int) -> None:
    """ConvexRegion.project (scalar loop) gives the point the array form gives: the point itself inside, else the
    nearest point of the nearest edge; and that point lies in the polygon."""
    rng = np.random.default_rng(seed)
    h = np.zeros((40, 40))
    step = np.zeros((40, 40), bool)
    step[rng.integers(0, 40, 12), rng.integers(0, 40, 12)] = True
    maps = _maps(h, step)
    regions = segment_regions(maps, PARAMS)
    assert regions.polygons
    for poly in regions.polygons[:4]:
        v = poly.vertices
        e = np.roll(v, -1, axis=0) - v
        for p in rng.uniform(-0.3, 1.5, (25, 2)):
            if bool(poly.contains(p)):
                ref = p
            else:
                t = np.clip(np.sum((p - v) * e, axis=1) / np.maximum(np.sum(e * e, axis=1), 1e-18), 0.0, 1.0)
                q = v + t[:, None] * e
                ref = q[int(np.argmin(np.sum((q - p) ** 2, axis=1)))]
            got = poly.project(p)
            np.testing.assert_allclose(got, ref, atol=1e-12)
            assert bool(poly.contains(got, 1e-7))


def test_the_inset_from_the_shadow_keeps_footholds_off_a_stones_unseen_far_edge() -> None:
    """A stone whose far edge the sensor never saw: its shadow filled from the stone's top reads as more stone. With
    inset_from_shadow the polygon keeps the inset from the last seen cells (off the true edge by the foot and the
    margin), and the shadow cells keep their label (the region and its plane as without the rule)."""
    import dataclasses

    X, Y = _grid(80, 80)
    h = np.full(X.shape, -0.30)  # the pit
    stone = (np.abs(X - 1.2) <= 0.15) & (np.abs(Y - 1.2) <= 0.20)
    h[stone] = 0.02
    # the shadow: the 3 rows of pit cells beyond the stone's far edge (x > 1.35) unseen, filled at the top's height
    shadow = (X > 1.35 + 1e-9) & (X <= 1.35 + 3 * RES + 1e-9) & (np.abs(Y - 1.2) <= 0.20)
    h[shadow] = 0.02
    maps = dataclasses.replace(_maps(h), observed=~shadow)
    view = (0.6, 1.2)  # the sensor before the stone
    assert np.array_equal(shadow_cells(maps, view, 3), shadow)
    for rule in (False, True):
        params = dataclasses.replace(PARAMS, inset_from_shadow=rule)
        regions = segment_regions(maps, params, view_xy=view)
        lab = regions.label_at(1.2, 1.2)
        assert lab != 0
        # the shadow cells are on the stone's region either way (labels and plane as without the rule)
        assert regions.label_at(1.35 + 2 * RES, 1.2) == lab
        assert regions.z0[lab] == pytest.approx(0.02)
        polys = regions.polygons_of(lab)
        far = max(float(p.vertices[:, 0].max()) for p in polys)
        # the true edge is at 1.35 + RES / 2 (the last stone cell's border)
        if rule:
            assert far <= 1.35 + RES / 2 - params.inset_m + 1e-6
        else:
            assert far > 1.35 + RES / 2 - params.foot_radius_m  # the polygon runs out over the shadow
        # the other edges, seen, keep the same inset with or without the rule
        assert min(float(p.vertices[:, 0].min()) for p in polys) >= 1.05 - RES / 2 + params.inset_m - 1e-6
        assert float(X[regions.inset & (regions.labels == lab)].max()) <= (
            1.35 + RES / 2 - params.inset_m + 1e-6 if rule else 1.35 + 3 * RES
        )


def test_the_unseen_patch_under_the_sensor_is_not_a_shadow() -> None:
    """The never-seen patch under the robot (seen ground all round it, none between it and the sensor) is no shadow:
    the floor's inset there is as without the rule, so the feet standing in it keep their region."""
    import dataclasses

    X, Y = _grid(60, 60)
    h = np.zeros(X.shape)
    under = (np.abs(X - 0.9) <= 0.45) & (np.abs(Y - 0.9) <= 0.25)
    maps = dataclasses.replace(_maps(h), observed=~under)
    for view in ((0.9, 0.9), (1.2, 0.9), (0.75, 0.95)):  # the body over the patch, moved within it
        assert not shadow_cells(maps, view, 3).any()
        with_rule = segment_regions(maps, dataclasses.replace(PARAMS, inset_from_shadow=True), view_xy=view)
        without = segment_regions(maps, PARAMS, view_xy=view)
        assert np.array_equal(with_rule.inset, without.inset)


def test_the_shadow_counts_only_beyond_a_cell_as_seen_from_the_sensor() -> None:
    """shadow_depth: a cell is near a shadow cell that lies beyond it (the occluder's side), not one behind it or
    beside it; with a cone of 180 degrees every direction counts (the session-12 rule)."""
    shadow = np.zeros((11, 11), bool)
    shadow[6, 5] = True
    view = (0.0, 5 * RES)  # the sensor on the row's axis, before the shadow (x grows away from it)
    d = shadow_depth(shadow, (0.0, 0.0), RES, view, 0.1, 60.0)
    assert d[5, 5] == pytest.approx(0.5 * RES)  # the seen cell before it: its edge half a cell away
    assert d[4, 5] == pytest.approx(1.5 * RES)
    assert np.isinf(d[7, 5]) and np.isinf(d[8, 5])  # the ground beyond the shadow does not see it as an edge
    assert np.isinf(d[6, 4]) and np.isinf(d[6, 6])  # nor the ground beside it
    assert np.isinf(d[1, 5])  # nor ground beyond reach
    every = shadow_depth(shadow, (0.0, 0.0), RES, view, 0.1, 180.0)
    assert every[7, 5] == pytest.approx(0.5 * RES) and every[6, 4] == pytest.approx(0.5 * RES)
    assert np.isinf(shadow_depth(np.zeros((5, 5), bool), (0.0, 0.0), RES, view, 0.1, 60.0)).all()


def test_the_floor_seen_beyond_a_boxs_shadow_keeps_its_footholds() -> None:
    """A box on the floor before the sensor: the floor just behind it is never seen (its shadow, filled at the
    floor's height). With inset_from_shadow the floor seen beyond the shadow keeps the inset it has without the
    rule (the shadow lies between it and the sensor), and so do the box top's far side (inset from the box's edge
    as before) and the shadow's own cells (those near the box are within its foot's inset anyway). Inset from the shadow in every direction (cone 180),
    the floor beyond loses a band."""
    import dataclasses

    X, Y = _grid(80, 80)
    h = np.zeros(X.shape)
    box = (X >= 1.0 - 1e-9) & (X <= 1.3 + 1e-9) & (np.abs(Y - 1.2) <= 0.3 + 1e-9)
    h[box] = 0.2
    shadow = (X > 1.3 + 1e-9) & (X <= 1.3 + 3 * RES + 1e-9) & (np.abs(Y - 1.2) <= 0.3 + 1e-9)
    maps = dataclasses.replace(_maps(h), observed=~shadow)
    view = (0.4, 1.2)
    assert np.array_equal(shadow_cells(maps, view, 3), shadow)
    without = segment_regions(maps, PARAMS, view_xy=view)
    rule = dataclasses.replace(PARAMS, inset_from_shadow=True)
    with_rule = segment_regions(maps, rule, view_xy=view)
    assert np.array_equal(with_rule.labels, without.labels)
    assert np.array_equal(with_rule.inset, without.inset)
    floor_beyond = (X > 1.3 + 3 * RES + 1e-9) & (np.abs(Y - 1.2) <= 0.3)
    every = segment_regions(maps, dataclasses.replace(rule, shadow_cone_deg=180.0), view_xy=view)
    assert (without.inset & floor_beyond & ~every.inset).any()
    # the floor beyond: polygons grown there reach as close to the box as without the rule
    lab = with_rule.label_at(1.6, 1.2)
    assert lab == without.label_at(1.6, 1.2) != 0
    a = convex_around(with_rule, lab, (1.45, 1.2))
    b = convex_around(without, lab, (1.45, 1.2))
    assert a is not None and b is not None
    assert float(a.vertices[:, 0].min()) == pytest.approx(float(b.vertices[:, 0].min()), abs=1e-9)


def test_a_shadow_starts_only_behind_a_drop_edge() -> None:
    """shadow_cells with drop_m: never-seen cells on level ground (a patch the cameras missed, beside or behind the
    moving body) are no shadow, while the cells behind a stone's top (higher than the seen pit around it) are; with
    the region parameters' defaults the floor's inset beside such a patch is as without the rule."""
    import dataclasses

    X, Y = _grid(60, 60)
    h = np.zeros(X.shape)
    # level floor, never seen, ahead of the sensor
    missed = (np.abs(X - 1.2) <= 0.1) & (np.abs(Y - 0.9) <= 0.2)
    maps = dataclasses.replace(_maps(h), observed=~missed)
    view = (0.6, 0.9)
    assert shadow_cells(maps, view, 3).any()  # any seen cell occludes: the patch's far part reads as a shadow
    assert not shadow_cells(maps, view, 3, drop_m=0.04, drop_radius_m=0.3).any()
    rule = RegionParams(foot_radius_m=0.02, edge_margin_m=0.02, inset_from_shadow=True)
    assert rule.shadow_drop_m is not None
    with_rule = segment_regions(maps, rule, view_xy=view)
    without = segment_regions(maps, dataclasses.replace(rule, inset_from_shadow=False), view_xy=view)
    assert np.array_equal(with_rule.inset, without.inset)
    # a stone 0.3 m above the seen pit, its far edge's shadow beyond it: a shadow with the drop rule too
    h2 = np.full(X.shape, -0.30)
    stone = (np.abs(X - 1.2) <= 0.15) & (np.abs(Y - 0.9) <= 0.2)
    shadow = (X > 1.35 + 1e-9) & (X <= 1.35 + 2 * RES + 1e-9) & (np.abs(Y - 0.9) <= 0.2)
    h2[stone | shadow] = 0.02
    maps2 = dataclasses.replace(_maps(h2), observed=~shadow)
    assert np.array_equal(shadow_cells(maps2, view, 3, drop_m=0.04, drop_radius_m=0.3), shadow)
