"""The regions pipeline's map settings on staircases (issue 26): every tread of a steep flight keeps steppable ground
across the flight, where the shared step map's closing (min_support_m) and its too-high rule took whole treads and
the flight's open sides off it."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from planning.robot import load_robot
from planning.steps import SteeringCommand
from planning.steps.gait import get_gait
from planning.terrain.decision import (
    DecisionParams,
    FootholdDecision,
    FootholdMemory,
    PipelineParams,
    TerrainView,
    TerrainWorld,
    cadence,
    gap_ahead,
    is_flight,
    on_small_regions,
    step_rise,
    swing_ground,
)
from planning.terrain.maps import MapParams, TerrainMaps, maps_from_grids, maps_from_scene
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


def _world(h: np.ndarray, no_step: np.ndarray | None = None) -> TerrainWorld:
    xs = -0.6 + np.arange(h.shape[0]) * RES
    ys = -0.9 + np.arange(h.shape[1]) * RES
    maps = maps_from_grids((xs[0], ys[0]), RES, h, np.zeros(h.shape, bool) if no_step is None else no_step)
    regions = segment_regions(maps, RegionParams(foot_radius_m=0.02, max_planes=8), cover=False)
    return TerrainWorld(maps, regions, swing_ground(maps, 0.03), None)


def _going_view(feet: np.ndarray | None = None) -> TerrainView:
    """The body at the origin heading +x, walking (trot), feet under the hips unless given (4, 3)."""
    if feet is None:
        feet = np.array([[0.3, 0.15, 0.02], [0.3, -0.15, 0.02], [-0.3, 0.15, 0.02], [-0.3, -0.15, 0.02]])
    return TerrainView(
        t_s=1.0,
        p_world_body=np.array([0.0, 0.0, 0.55]),
        yaw=0.0,
        p_world_foot=feet,
        v_world_foot=np.zeros((4, 3)),
        stance=np.ones(4, bool),
        z_contact=0.0,
        gait="trot",
        gait_since_s=-10.0,
        fast_gait="trot",
        operator=SteeringCommand(0.5, 0.0, 0.0),
        goal=None,
        pitch_rad=0.0,
        height_m=0.52,
        foot_radius_m=0.02,
        standing_height_m=0.52,
        p_body_hip=np.array([[0.3, 0.1], [0.3, -0.1], [-0.3, 0.1], [-0.3, -0.1]]),
        dt_s=0.01,
    )


def _going(world: TerrainWorld, foot: tuple[float, float], to: tuple[float, float]) -> tuple[float, str]:
    """step_rise and the gait when the front-left foot stands at foot (x, z) and its next foothold is to (x, z)."""
    feet = np.array(
        [[foot[0], 0.15, foot[1] + 0.02], [0.3, -0.15, 0.02], [-0.3, 0.15, 0.02], [-0.3, -0.15, 0.02]]
    )
    view = _going_view(feet)
    chosen = np.full((4, 3), np.nan)
    chosen[0] = [to[0], 0.15, to[1]]
    last = FootholdDecision(
        np.zeros((0, 3)), (), None, 0.0, FootholdMemory(np.full(4, np.nan), chosen, np.full(4, np.nan))
    )
    return step_rise(view, world, last), cadence(view, world, last, DecisionParams())


@pytest.mark.parametrize("riser", [0.10, 0.12, 0.18])
def test_a_swing_up_a_riser_gets_the_time_to_rise_it(riser: float) -> None:
    """A foot stepping from a tread onto the next, a riser higher, counts the riser (step_rise): the gait's swing lasts
    at least base_swing_s + riser / rise_speed_mps, where the nosing's hump alone let the 0.3 s `climb` swing take
    it; on a slope as steep (one region) nothing counts, and stepping down nothing either."""
    X = np.broadcast_to((-0.6 + np.arange(110) * RES)[:, None], (110, 60))
    stairs = _world(
        np.asarray(riser * np.clip(np.floor((X - 0.405) / 0.3) + 1.0, 0.0, 4.0), dtype=np.float64)
    )
    rise, gait = _going(stairs, (0.55, riser), (0.85, 2 * riser))
    p = DecisionParams()
    assert rise == pytest.approx(riser, abs=0.01)
    assert (
        get_gait(gait).swing_s >= p.base_swing_s + riser / p.rise_speed_mps - 1e-9
        or gait == p.climb_gaits[-1]
    )
    assert _going(stairs, (0.85, 2 * riser), (0.55, riser))[0] == 0.0
    slope = _world(np.asarray(np.clip(X, 0.0, None) * riser / 0.3, dtype=np.float64))
    assert _going(slope, (0.55, 0.55 * riser / 0.3), (0.85, 0.85 * riser / 0.3))[0] == 0.0


def test_a_gap_is_ground_that_drops_below_the_feet_and_comes_back_not_a_flights_edge_bands() -> None:
    """gap_ahead with gap_dip_m: a pit 0.3 m deep and 0.3 m wide ahead (its floor no-step, as the step map's knee
    rule makes it) is a gap (the slow gait); two treads of a flight (0.18 m risers) with no region on them (a step
    map that closed them off) are a longer run without a region but no gap; without gap_dip_m both count."""
    X = np.broadcast_to((-0.6 + np.arange(110) * RES)[:, None], (110, 60))
    in_pit = (X > 0.6) & (X < 0.9)
    pit = _world(np.asarray(np.where(in_pit, -0.3, 0.0), dtype=np.float64), np.asarray(in_pit, dtype=bool))
    lost = (X > 0.6) & (X < 1.2)
    flight = _world(np.asarray(0.18 * np.clip(np.floor((X - 0.6) / 0.28) + 1.0, 0.0, 4.0)), np.asarray(lost))
    view = _going_view()
    dip = DecisionParams(gap_dip_m=0.05)
    every = DecisionParams(gap_dip_m=None)
    assert gap_ahead(view, pit, dip) > dip.slow_gap_m and gap_ahead(view, pit, every) > every.slow_gap_m
    assert gap_ahead(view, flight, every) > every.slow_gap_m
    assert gap_ahead(view, flight, dip) < dip.slow_gap_m


def test_only_a_flight_makes_a_step_between_two_heights_no_gap() -> None:
    """gap_flight_steps: the edge band from the floor onto a box 0.18 m high and 0.6 m long (0.35 m without a
    region, from one height to another) stays a gap, the line going up onto the box and down off it again; with any
    line counting (gap_flight_steps None) it is none. A flight's lost treads (above) are none either way; a flight
    going down counts as one, a single step does not."""
    X = np.broadcast_to((-0.6 + np.arange(110) * RES)[:, None], (110, 60))
    band = (X > 0.4) & (X < 0.75)
    box = _world(np.asarray(np.where((X > 0.6) & (X < 1.2), 0.18, 0.0), dtype=np.float64), np.asarray(band))
    view = _going_view()
    flights = DecisionParams(gap_dip_m=0.05)
    any_line = DecisionParams(gap_dip_m=0.05, gap_flight_steps=None)
    assert flights.gap_flight_steps == 2
    assert gap_ahead(view, box, flights) > flights.slow_gap_m
    assert gap_ahead(view, box, any_line) < any_line.slow_gap_m
    down = 0.9 - 0.18 * np.clip(np.floor((np.arange(60) * RES - 0.3) / 0.28) + 1.0, 0.0, 4.0)
    assert is_flight(down, 0.05, 2) and is_flight(down[::-1], 0.05, 2)
    spike = down[::-1].copy()
    spike[40] += 0.15  # one cell seen high (a riser's face edge-on): still a flight
    assert is_flight(spike, 0.05, 2)
    one = np.where(np.arange(60) * RES > 0.8, 0.18, 0.0)
    assert not is_flight(one, 0.05, 2) and is_flight(one, 0.05, 1)
    assert not is_flight(np.concatenate([down[::-1], down]), 0.05, 2)


def test_the_liftoff_hold_is_asked_on_a_stone_not_on_the_floor() -> None:
    """on_small_regions (DecisionParams.hold_region_m2): a stance foot on a 0.3 m square stone (0.09 m²) asks the
    slow gait's liftoff hold at 0.3 m²; the same feet all on the floor around it do not, nor the foot over the stone
    in the air, nor a threshold below the stone's area."""
    X = np.broadcast_to((-0.6 + np.arange(110) * RES)[:, None], (110, 60))
    Y = np.broadcast_to((-0.9 + np.arange(60) * RES)[None, :], (110, 60))
    stone = (X > 0.3) & (X < 0.6) & (np.abs(Y) < 0.15)
    world = _world(np.asarray(np.where(stone, 0.2, 0.0), dtype=np.float64))
    floor_feet = np.array([[0.9, 0.4, 0.02], [0.9, -0.4, 0.02], [-0.3, 0.4, 0.02], [-0.3, -0.4, 0.02]])
    on_stone = floor_feet.copy()
    on_stone[0] = [0.45, 0.0, 0.22]
    view = _going_view(on_stone)
    assert on_small_regions(view, world, 0.3)
    assert not on_small_regions(view, world, 0.05)
    assert not on_small_regions(_going_view(floor_feet), world, 0.3)
    flying = dataclasses.replace(view, stance=np.array([False, True, True, True]))
    assert not on_small_regions(flying, world, 0.3)


def test_the_slow_gait_waits_while_the_hind_feet_are_still_on_a_descent() -> None:
    """A pit 0.3 m wide lies ahead of a step 0.15 m down along +x: on the step, the hind feet on the tread above
    the front feet, the gait does not switch to the slow one (a switch there slowed the
    body while a hind foot stepped down, its hip left behind the nosing and its shin on it: the mixed family's
    hind lower-leg falls, docs/terrain-notes.md, session 24); with all four feet on the floor, or with the rule
    off (slow_drop_m None), it does; a walk already in the slow gait keeps it."""
    X = np.broadcast_to((-0.6 + np.arange(110) * RES)[:, None], (110, 60))
    steps = np.where(X < -0.15, 0.15, 0.0)  # the tread above, down to the floor at x = -0.15
    in_pit = (X > 0.75) & (X < 1.05)
    h = np.asarray(np.where(in_pit, -0.3, steps), dtype=np.float64)
    world = _world(h, np.asarray(in_pit, dtype=bool))
    p = DecisionParams()
    assert p.slow_drop_m is not None and p.slow_gait is not None
    level = _going_view(
        np.array([[0.3, 0.15, 0.02], [0.3, -0.15, 0.02], [0.6, 0.15, 0.02], [0.6, -0.15, 0.02]])
    )
    level = dataclasses.replace(level, p_world_body=np.array([0.45, 0.0, 0.55]))
    assert gap_ahead(level, world, p) > p.slow_gap_m
    assert cadence(level, world, None, p) == p.slow_gait
    # front feet on the floor (x 0.3), hind feet on the tread above it (x -0.3, 0.15 m up)
    feet = _going_view().p_world_foot.copy()
    feet[2:, 2] += 0.15
    on_flight = dataclasses.replace(level, p_world_foot=feet, p_world_body=np.array([0.0, 0.0, 0.6]))
    assert gap_ahead(on_flight, world, p) > p.slow_gap_m
    assert cadence(on_flight, world, None, p) != p.slow_gait
    assert cadence(on_flight, world, None, dataclasses.replace(p, slow_drop_m=None)) == p.slow_gait
    assert cadence(dataclasses.replace(on_flight, gait=p.slow_gait), world, None, p) == p.slow_gait
