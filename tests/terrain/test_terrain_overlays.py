"""The terrain overlays the studio draws: map outlines, the body path, the step QP's footholds, the depth cloud."""

from __future__ import annotations

import numpy as np

from planning.terrain.bodypath import plan_body_path
from planning.terrain.maps import maps_from_grids
from planning.terrain.overlays import map_overlays, outline, plan_overlays
from planning.terrain.sensor import PointCloud

RES = 0.05


def _maps(ground_z: float = 0.1):
    """A 4 m square map (origin at its corner cell) with a no-step square 0.5 m wide at (2, 2) and a body-obstacle
    bar at x 3.0..3.2, y 1..3."""
    n = 80
    xs = np.arange(n) * RES
    step = (np.abs(xs[:, None] - 2.0) <= 0.25) & (np.abs(xs[None, :] - 2.0) <= 0.25)
    body = ((xs[:, None] >= 3.0) & (xs[:, None] <= 3.2)) & ((xs[None, :] >= 1.0) & (xs[None, :] <= 3.0))
    return maps_from_grids((0.0, 0.0), RES, np.full((n, n), ground_z), step | body, body)


def test_outline_keeps_the_cells_with_a_free_neighbor() -> None:
    mask = np.zeros((10, 10), dtype=bool)
    mask[2:7, 3:8] = True  # 5 x 5
    edge = outline(mask)
    assert np.count_nonzero(edge) == 16 and not edge[4, 5] and edge[2, 3] and edge[6, 7]
    full = np.ones((4, 4), dtype=bool)
    assert not outline(full).any()  # the map's own edge is no outline


def test_map_overlays_outline_the_no_step_and_body_cells_at_their_ground_height() -> None:
    maps = _maps(0.1)
    ov = map_overlays(maps, np.array([2.0, 2.0]), radius_m=3.0)
    no_step = np.asarray(ov["terrain_no_step"]["points"])
    body = np.asarray(ov["terrain_body_obstacles"]["points"])
    assert len(no_step) > 0 and len(body) > 0
    assert np.all(maps.no_step(no_step[:, 0], no_step[:, 1]))
    assert np.all(maps.no_body(body[:, 0], body[:, 1]))
    assert not np.any(maps.no_body(no_step[:, 0], no_step[:, 1]) & (np.abs(no_step[:, 0] - 2.0) < 0.3))
    np.testing.assert_allclose(no_step[:, 2], 0.11, atol=1e-9)
    np.testing.assert_allclose(body[:, 2], 0.13, atol=1e-9)
    # the square's outline: 11 cells a side (x 1.75..2.25 every 5 cm), 40 in all, none from its inside
    square = no_step[(np.abs(no_step[:, 0] - 2.0) < 0.3) & (np.abs(no_step[:, 1] - 2.0) < 0.3)]
    assert len(square) == 40
    assert np.all((np.abs(square[:, 0] - 2.0) > 0.2) | (np.abs(square[:, 1] - 2.0) > 0.2))


def test_map_overlays_stay_near_the_body_and_within_their_point_budget() -> None:
    maps = _maps()
    near = np.asarray(map_overlays(maps, np.array([0.5, 0.5]), radius_m=1.0)["terrain_no_step"]["points"])
    assert len(near) == 0  # the square is 2.1 m away
    few = map_overlays(maps, np.array([2.0, 2.0]), radius_m=3.0, max_points=10)
    assert (
        0 < len(few["terrain_no_step"]["points"]) <= 10 and len(few["terrain_body_obstacles"]["points"]) <= 10
    )


def test_plan_overlays_draw_the_body_path_on_the_ground_and_thin_the_cloud() -> None:
    maps = _maps(0.1)
    path = plan_body_path(maps, (0.5, 2.0), 0.0, (3.6, 0.5))
    cloud = PointCloud(np.random.default_rng(0).random((9000, 3)), np.zeros((9000, 3)), 0.0)
    ov = plan_overlays(maps, path, None, cloud, max_cloud_points=1000)
    line = np.asarray(ov["body_path_plan"]["points"])
    assert ov["body_path_plan"]["kind"] == "polyline" and len(line) == len(path.xy)
    np.testing.assert_allclose(line[-1, :2], [3.6, 0.5], atol=0.06)
    np.testing.assert_allclose(line[:, 2], 0.12, atol=1e-9)
    assert 0 < len(ov["depth_cloud"]["points"]) <= 1000
    assert "step_qp_footholds" not in ov  # no plan, no footholds
    assert plan_overlays(None, None, None, None) == {}
