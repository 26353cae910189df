"""The regions pipeline's map settings on staircases (issue 26): every tread of a steep flight keeps steppable ground
across the flight, where the shared step map's closing (min_support_m) and its too-high rule took whole treads and
the flight's open sides off it."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from planning.robot import load_robot
from planning.terrain.decision import PipelineParams
from planning.terrain.maps import MapParams, TerrainMaps, maps_from_scene
from planning.terrain.regions import RegionParams, segment_regions
from planning.terrain.spec import load_terrain

RES = 0.03
# (riser m, tread m, railings): building-code and steeper flights, with and without railings
FLIGHTS = [(0.128, 0.266, True), (0.18, 0.28, False), (0.195, 0.274, False), (0.2, 0.25, True)]


def _pipeline_maps() -> MapParams:
    return dataclasses.replace(MapParams(), **PipelineParams().maps)


def _tread_rows(maps: TerrainMaps, inset: np.ndarray, x0: float, tread: float, k: int, half_w: float) -> int:
    """How many rows (cells along the heading) of tread k (1: the first) are inset cells all across |y| <= half_w."""
    xs, ys = maps.cell_centers()
    sel = (xs > x0 + (k - 1) * tread) & (xs < x0 + k * tread)
    across = np.abs(ys) <= half_w
    return int(np.count_nonzero(np.all(inset[np.ix_(sel, across)], axis=1)))


@pytest.mark.parametrize(("riser", "tread", "rails"), FLIGHTS)
def test_every_tread_keeps_a_strip_a_foot_stands_on_across_the_flight(
    riser: float, tread: float, rails: bool
) -> None:
    """With the pipeline's map settings each of the first five treads has at least two rows of inset cells (a foot
    of the robot's radius, with its edge margin, inside its region) all across the middle 0.8 m of a 1.2 m flight:
    a body walking up to 0.3 m off the centre line has ground for its feet on every tread."""
    terrain = f"stairs:riser_m={riser},tread_m={tread},n_steps=6,railings={str(rails).lower()}"
    scene = load_terrain(terrain)
    rp = RegionParams.from_robot(load_robot("spot"), max_planes=8)
    x0 = scene.span_x[0]
    maps = maps_from_scene(scene, (x0 + 1.0, 0.0), 2.5, RES, _pipeline_maps())
    regions = segment_regions(maps, rp)
    rows = [_tread_rows(maps, regions.inset, x0, tread, k, 0.4) for k in range(1, 6)]
    assert min(rows) >= 2, f"inset rows per tread {rows}"


def test_the_shared_step_map_loses_treads_the_pipeline_keeps() -> None:
    """The shared settings (MapParams()) on the same flights: some tread has no such strip (what the pipeline's
    settings change; if the shared rule changes, the pipeline's override may no longer be needed)."""
    rp = RegionParams.from_robot(load_robot("spot"), max_planes=8)
    lost = 0
    for riser, tread, rails in FLIGHTS:
        scene = load_terrain(
            f"stairs:riser_m={riser},tread_m={tread},n_steps=6,railings={str(rails).lower()}"
        )
        x0 = scene.span_x[0]
        maps = maps_from_scene(scene, (x0 + 1.0, 0.0), 2.5, RES, MapParams())
        regions = segment_regions(maps, rp)
        lost += min(_tread_rows(maps, regions.inset, x0, tread, k, 0.4) for k in range(1, 6)) < 2
    assert lost >= 2
