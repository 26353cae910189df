"""The unified pipeline's decisions: region choice, the step QP inside regions, the decision's body posture and
speed, the swing ground. Pure functions on synthetic maps (the closed loop is tests/terrain_walk)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from planning.steps import SteeringCommand
from planning.steps.gait import get_gait
from planning.steps.state import BodyMotion, StepPath
from planning.terrain.bodypath import BodyPath, plan_body_path
from planning.terrain.cadence import CADENCES, CadenceParams, make_request
from planning.terrain.decision import (
    BACK_DROP_FRAC,
    DecisionParams,
    FootholdDecision,
    FootholdMemory,
    HeightGrid,
    TerrainView,
    TerrainWorld,
    _choose_regions,
    _regions_qp,
    cadence,
    choose_footholds,
    choose_region,
    climb_top_speed,
    crouch_height,
    decide,
    descent_edges,
    feet_turn_level,
    follow_path,
    footholds_plane,
    hips_pairs,
    hips_plane,
    leg_bounds,
    leg_bounds_found,
    leg_clearance,
    level_height,
    lost_region,
    next_facing,
    own_side,
    path_holds,
    pitched_nominals,
    reach_height,
    rise_behind,
    shin_cell_cost,
    shin_choice,
    shin_cost_region,
    shin_needed,
    shin_region,
    stance_feet_level,
    stride_m,
    swing_ground,
    swing_hump,
    touchdown_reach_height,
    trail_speed,
    turn_room,
)
from planning.terrain.maps import maps_from_grids
from planning.terrain.memory import OverhangMemory
from planning.terrain.regions import RegionParams, convex_around, segment_regions
from planning.terrain.stepqp import StepQP, StepQPParams

RES = 0.03
P = DecisionParams(regions=RegionParams(foot_radius_m=0.02, max_planes=8))
P_LINE = dataclasses.replace(P, shin_rule="line")  # the shin rule along the heading (the line tests below)


def _stones() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A platform up to x = 0.6 m, a pit 0.3 m deep, a stone at 0.85–1.15 m, the far platform from 1.4 m."""
    xs = -0.6 + np.arange(110) * RES
    ys = -0.9 + np.arange(60) * RES
    X = np.broadcast_to(xs[:, None], (110, 60))
    h = np.where((X < 0.6) | (X > 1.4) | ((X > 0.85) & (X < 1.15)), 0.0, -0.3)
    return xs, ys, np.asarray(h, dtype=np.float64)


def _world(xs: np.ndarray, ys: np.ndarray, h: np.ndarray) -> TerrainWorld:
    maps = maps_from_grids((xs[0], ys[0]), RES, h, np.zeros(h.shape, bool))
    regions = segment_regions(maps, P.regions, cover=False)
    return TerrainWorld(maps, regions, swing_ground(maps, 0.03), None)


def test_a_foothold_over_the_pit_goes_to_the_nearest_region_in_reach_never_the_pit_floor() -> None:
    world = _world(*_stones())
    regions, maps = world.regions, world.maps
    pit = regions.label_at(0.75, 0.0)
    stone = regions.label_at(1.0, 0.0)
    near = regions.label_at(0.3, 0.0)
    assert pit and stone and near and len({pit, stone, near}) == 3
    # nominal in the pit, nearer the stone: the stone (the pit floor is 0.3 m down, beyond max_rise_m)
    assert choose_region(regions, maps, np.array([0.78, 0.0]), 0.0, None, P) == stone
    # nearer the platform: the platform
    assert choose_region(regions, maps, np.array([0.64, 0.0]), 0.0, None, P) == near
    # a leg standing in the pit (z_ref -0.3) may stay on the pit floor
    assert choose_region(regions, maps, np.array([0.75, 0.0]), -0.3, None, P) == pit
    # nothing steppable within search_m: none
    assert choose_region(regions, maps, np.array([0.75, 2.5]), 0.0, None, P) == 0


def test_the_previous_region_is_kept_unless_clearly_worse_and_always_in_flight() -> None:
    world = _world(*_stones())
    regions, maps = world.regions, world.maps
    stone = regions.label_at(1.0, 0.0)
    near = regions.label_at(0.3, 0.0)
    # about halfway: slightly nearer the platform, but the stone was chosen before: kept
    xy = np.array([0.72, 0.0])
    assert choose_region(regions, maps, xy, 0.0, None, P) == near
    assert choose_region(regions, maps, xy, 0.0, np.array([1.0, 0.0]), P) == stone
    # clearly nearer the platform: switches, unless the foot is in the air
    xy = np.array([0.6, 0.0])
    assert choose_region(regions, maps, xy, 0.0, np.array([1.0, 0.0]), P) == near
    assert choose_region(regions, maps, xy, 0.0, np.array([1.0, 0.0]), P, in_flight=True) == stone


def test_a_foothold_whose_region_the_segmentation_lost_is_held_while_the_ground_is_unchanged() -> None:
    world = _world(*_stones())
    regions, maps = world.regions, world.maps
    on_stone = np.array([1.0, 0.0, 0.0])
    assert regions.label_at(1.0, 0.0) and not lost_region(regions, maps, on_stone, P)
    # the stone's cells unlabelled (as a re-segmentation of a sensor's map may leave them for a moment)
    labels = regions.labels.copy()
    labels[labels == regions.label_at(1.0, 0.0)] = 0
    gone = dataclass_replace(regions, labels=labels, inset=regions.inset & (labels > 0))
    assert lost_region(gone, maps, on_stone, P)
    # the ground moved there (a foothold remembered 5 cm higher than the map now says): not held
    assert not lost_region(gone, maps, on_stone + [0.0, 0.0, P.lost_hold_m + 0.02], P)
    # a foothold in the pit (no region, the ground 0.3 m below the remembered height): not held
    assert not lost_region(gone, maps, np.array([0.75, 0.0, 0.0]), P)


def test_the_step_qp_keeps_every_foothold_inside_its_region() -> None:
    world = _world(*_stones())
    path = plan_body_path(None, (0.0, 0.0), 0.0, (4.0, 0.0))
    cp = CadenceParams()
    cad = next(c for c in CADENCES if c.name == "medium")
    xy, _ = path.pose_at(0.45)
    req = make_request(cad, path, cp, 8, np.asarray(cp.feet_body_xy) + xy, s_now_m=0.45, phase_s=0.05)
    polys = []
    for k in range(8):
        lab = choose_region(world.regions, world.maps, req.p_nominal[k], 0.0, None, P)
        polys.append(None if not lab else convex_around(world.regions, lab, req.p_nominal[k], P.window_m))
    assert any(p is not None and not bool(p.contains(req.p_nominal[k])) for k, p in enumerate(polys))
    w = list(StepQPParams().weights)
    w[2] = 3e4
    # tight tolerances: at OSQP's 1e-4 a cold and a warm solve of this request differ by up to 3 cm (the slack
    # weights of 3e4 leave the footholds' pull weak in OSQP's scaled residuals), both reported solved
    qp = StepQP(
        StepQPParams(keep_planes=12, weights=tuple(w), self_longitudinal_m=0.15, eps_abs=1e-6, eps_rel=1e-6)
    )
    plan = qp.solve(req, world.maps, [None if p is None else (p.A, p.b) for p in polys])
    assert plan.rounds == 1
    for k, poly in enumerate(polys):
        if poly is not None:
            assert bool(poly.contains(plan.footholds[k, :2], 2e-3)), (k, plan.footholds[k], poly.vertices)
    assert "reach_oct" not in plan.hard_softened
    # the same request again, warm: the same footholds (within the solver's tolerance)
    again = qp.solve(req, world.maps, [None if p is None else (p.A, p.b) for p in polys])
    np.testing.assert_allclose(again.footholds, plan.footholds, atol=5e-3)
    with pytest.raises(ValueError, match="regions: need 8"):
        qp.solve(req, world.maps, polys[:3])  # type: ignore[arg-type]


def _view(feet_z: np.ndarray, feet_x: np.ndarray, goal: np.ndarray | None = None) -> TerrainView:
    feet = np.column_stack([feet_x, [0.15, -0.15, 0.15, -0.15], feet_z + 0.02])
    return TerrainView(
        t_s=1.0,
        p_world_body=np.array([0.0, 0.0, 0.55]),
        yaw=0.0,
        p_world_foot=feet,
        v_world_foot=np.zeros((4, 3)),
        stance=np.ones(4, bool),
        z_contact=float(np.mean(feet[:, 2])),
        gait="trot",
        gait_since_s=-10.0,
        fast_gait="trot",
        operator=SteeringCommand(0.5, 0.0, 0.0),
        goal=goal,
        pitch_rad=0.0,
        height_m=0.52,
        foot_radius_m=0.02,
        standing_height_m=0.52,
        p_body_hip=np.array([[0.3, 0.1], [0.3, -0.1], [-0.3, 0.1], [-0.3, -0.1]]),
        dt_s=0.01,
    )


def test_the_decision_pitches_the_body_with_its_footholds_plane_and_slows_for_moved_footholds() -> None:
    world = _world(*_stones())
    params = dataclass_replace(P, max_pitch_rate_rps=100.0, posture="plane")
    # front feet 0.2 m higher than the hind feet, 0.6 m apart: 18° uphill
    view = _view(np.array([0.2, 0.2, 0.0, 0.0]), np.array([0.3, 0.3, -0.3, -0.3]))
    d = decide(view, world, None, params)
    assert d.body_pitch_rad == pytest.approx(-math.atan(0.2 / 0.6), abs=1e-6)  # nose up
    assert d.body_height_m == pytest.approx(0.52 + 0.1 - view.z_contact + 0.0 + 0.0, abs=1e-6)
    assert d.command.vx == pytest.approx(params.max_speed_mps)
    # a foothold moved 10 cm off its nominal: slower, the same rule on any terrain
    mem = FootholdMemory.empty()
    last = FootholdDecision(np.zeros((0, 3)), (), None, 0.10, mem)
    slow = decide(view, world, last, params)
    assert params.min_speed_mps < slow.command.vx < params.max_speed_mps
    very = decide(view, world, dataclass_replace(last, max_shift_m=1.0), params)
    assert very.command.vx == pytest.approx(params.min_speed_mps)
    # the pitch moves toward its target at its rate
    d2 = decide(view, world, None, dataclass_replace(P, posture="plane"))
    assert abs(d2.body_pitch_rad) == pytest.approx(P.max_pitch_rate_rps * view.dt_s)


def test_the_swing_ground_is_the_height_map_dilated_by_the_foot() -> None:
    xs, ys, h = _stones()
    maps = maps_from_grids((xs[0], ys[0]), RES, h, np.zeros(h.shape, bool))
    g = swing_ground(maps, 0.05)
    # a cell before the stone's first cell (0.87 m) the ground is the stone's top; three cells before, the pit
    assert g(0.84, 0.0) == pytest.approx(0.0)
    assert g(0.78, 0.0) == pytest.approx(-0.3)
    assert g(np.array([0.75, 1.0]), np.array([0.0, 0.0])).shape == (2,)


def _steps_down() -> TerrainWorld:
    """A landing at 0.6 m up to x = 1.0 m, then treads 0.3 m long, each 0.15 m lower (going down along +x)."""
    xs = -0.6 + np.arange(110) * RES
    ys = -0.9 + np.arange(60) * RES
    X = np.broadcast_to(xs[:, None], (110, 60))
    h = 0.6 - 0.15 * np.clip(np.floor((X - 1.0) / 0.3) + 1.0, 0.0, 4.0)
    return _world(xs, ys, np.asarray(h, dtype=np.float64))


def _leg_view(body_x: float, z_contact: float) -> TerrainView:
    v = _view(np.zeros(4), np.array([0.3, 0.3, -0.3, -0.3]))
    return dataclass_replace(
        v, p_world_body=np.array([body_x, 0.0, 1.0]), z_contact=z_contact, l_upper_m=0.32, l_lower_m=0.34
    )


def test_a_foot_stepping_down_is_kept_where_its_shin_clears_the_edge_it_stepped_over() -> None:
    world = _steps_down()
    maps, regions = world.maps, world.regions
    # the body on the landing, a front foot stepping down onto the first tread (0.45 m, x 1.0–1.3)
    view = _leg_view(0.85, 0.6)
    hip = np.array([0.85 + 0.3, 0.1])
    feet = np.column_stack([np.arange(1.05, 1.3, 0.03), np.full(9, 0.1)])
    clear, within = leg_clearance(view, maps, 0, hip, feet, P_LINE)
    assert np.all(within)
    # the farther past the nosing, the farther the shin from it: too near just past it, clear at the tread's end
    assert clear[0] < P_LINE.shin_clear_m <= clear[-1] and np.all(np.diff(clear) > 0.0)
    label = regions.label_at(1.15, 0.1)
    poly = convex_around(regions, label, np.array([1.08, 0.1]), P.window_m)
    assert poly is not None
    bounds = leg_bounds(view, maps, 0, hip, np.array([1.08, 0.1]), poly, P_LINE)
    # one bound: the foot at least some way past the nosing (along +x), not past the tread's end
    assert len(bounds) == 1 and bounds[0][0][0] == pytest.approx(-1.0)
    x_min = -bounds[0][1]
    assert 1.1 < x_min <= float(np.max(poly.vertices[:, 0])) + 1e-9
    # the same foothold on flat ground (the landing): no bound
    flat = regions.label_at(0.6, 0.1)
    poly_flat = convex_around(regions, flat, np.array([0.6, 0.1]), P.window_m)
    assert poly_flat is not None
    view_flat = _leg_view(0.3, 0.6)
    assert leg_bounds(view_flat, maps, 0, np.array([0.6, 0.1]), np.array([0.6, 0.1]), poly_flat, P_LINE) == []


def test_a_tread_below_no_place_of_which_clears_the_shin_is_found_so() -> None:
    """leg_bounds_found: with the hip well behind the nosing no place on the tread below clears the shin (the
    bounds keep the place of most clearance, and say none clears: DecisionParams.shin_hold holds that touchdown);
    with the hip over the tread a place clears."""
    world = _steps_down()
    maps, regions = world.maps, world.regions
    label = regions.label_at(1.15, 0.1)
    poly = convex_around(regions, label, np.array([1.08, 0.1]), P.window_m)
    assert poly is not None
    behind = _leg_view(0.5, 0.6)
    hip_behind = np.array([0.8, 0.1])
    bounds, found = leg_bounds_found(behind, maps, 0, hip_behind, np.array([1.08, 0.1]), poly, P_LINE)
    same = leg_bounds(behind, maps, 0, hip_behind, np.array([1.08, 0.1]), poly, P_LINE)
    assert not found and len(bounds) == len(same) >= 1
    for (a, b), (a2, b2) in zip(bounds, same, strict=True):
        np.testing.assert_array_equal(a, a2)
        assert b == b2
    # along the tread: the shin too near the nosing wherever the hip reaches
    feet = np.column_stack([np.arange(1.06, 1.3, 0.03), np.full(8, 0.1)])
    clear, within = leg_clearance(behind, maps, 0, hip_behind, feet, P_LINE)
    assert within.any() and np.all(~within | (clear < P_LINE.shin_clear_m))
    over = _leg_view(0.85, 0.6)
    _, found_over = leg_bounds_found(
        over, maps, 0, np.array([1.15, 0.1]), np.array([1.08, 0.1]), poly, P_LINE
    )
    assert found_over
    # flat ground: nothing to bound, found
    flat = regions.label_at(0.6, 0.1)
    poly_flat = convex_around(regions, flat, np.array([0.6, 0.1]), P.window_m)
    assert poly_flat is not None
    view_flat = _leg_view(0.3, 0.6)
    assert leg_bounds_found(
        view_flat, maps, 0, np.array([0.6, 0.1]), np.array([0.6, 0.1]), poly_flat, P_LINE
    ) == (
        [],
        True,
    )


def test_a_region_no_place_of_which_clears_the_shin_is_rejected_for_the_landing_above() -> None:
    """shin_region (DecisionParams.shin_regions): a front foot's nominal on the tread below a landing, the hip well
    behind the nosing: the tread has no place that clears the shin, so the region choice is made again without it
    and gives the landing, where a place clears; with the hip over the tread, or the filter off, the tread stands;
    with no other region to choose (max_rise_m), the tread stands (today's place of most clearance)."""
    world = _steps_down()
    maps, regions = world.maps, world.regions
    nom = np.array([1.08, 0.1])
    on = dataclasses.replace(P_LINE, shin_regions=3)
    tread = regions.label_at(1.15, 0.1)
    landing = regions.label_at(0.6, 0.1)
    assert tread and landing and tread != landing
    behind = _leg_view(0.5, 0.6)
    hip_behind = np.array([0.8, 0.1])
    # the first choice: the tread under the nominal
    assert choose_region(regions, maps, nom, 0.6, None, on) == tread
    assert choose_region(regions, maps, nom, 0.6, None, on, exclude=frozenset({tread})) == landing
    poly = convex_around(regions, tread, nom, P.window_m)
    assert poly is not None
    label, q = shin_region(behind, world, 0, hip_behind, nom, 0.6, None, True, None, tread, poly, on)
    assert label == landing and q is not poly
    bounds, found = leg_bounds_found(behind, maps, 0, hip_behind, nom, q, on)
    assert found
    # the foot in the air kept on the tread (its earlier choice there): the tread is still rejected
    kept = shin_region(behind, world, 0, hip_behind, nom, 0.6, nom, True, None, tread, poly, on)
    assert kept[0] == landing
    # off: the tread
    off = shin_region(behind, world, 0, hip_behind, nom, 0.6, None, True, None, tread, poly, P_LINE)
    assert off == (tread, poly)
    # the hip over the tread: a place of it clears, it stands
    over = _leg_view(0.85, 0.6)
    assert shin_region(
        over, world, 0, np.array([1.15, 0.1]), nom, 0.6, None, True, None, tread, poly, on
    ) == (
        tread,
        poly,
    )
    # no other region within max_rise_m of the reference: the tread stands
    low = dataclasses.replace(on, max_rise_m=0.1)
    assert shin_region(behind, world, 0, hip_behind, nom, 0.45, None, True, None, tread, poly, low) == (
        tread,
        poly,
    )


def test_a_foot_in_the_air_keeps_its_clearing_choice_when_its_new_polygon_has_no_place_the_shin_clears() -> (
    None
):
    """shin_hold: FL in the air, its nominal moved from before a low box (6 cm, x 0.40-0.52) to just past it, the hip
    still behind the box: no place of the floor's polygon there clears the shin (clutter draw 548's late flip). With
    shin_hold the foot keeps the choice made for this touchdown before the box, where the shin cleared; without
    (or with that choice not known to clear) it goes to the polygon's place of most clearance."""
    xs = -0.6 + np.arange(110) * RES
    ys = -0.9 + np.arange(60) * RES
    X = np.broadcast_to(xs[:, None], (110, 60))
    Y = np.broadcast_to(ys[None, :], (110, 60))
    box = (X > 0.40) & (X < 0.52) & (Y > 0.03) & (Y < 0.33)
    world = _world(xs, ys, np.asarray(np.where(box, 0.06, 0.0), dtype=np.float64))
    feet_x = np.array([0.2, 0.3, -0.3, -0.3])
    view = dataclass_replace(
        _view(np.zeros(4), feet_x), stance=np.array([False, True, True, True]), l_upper_m=0.32, l_lower_m=0.34
    )
    path = _trot_path(feet_x, np.array([0.58, 0.3, -0.3, -0.3]))
    k_fl = int(np.flatnonzero(path.leg == 0)[0])
    chosen = np.full((4, 3), np.nan)
    chosen[0] = [0.3, 0.15, 0.0]
    t_mem = np.full(4, np.nan)
    t_mem[0] = float(path.t_touchdown[k_fl])
    qp = StepQP(dataclass_replace(StepQPParams(), keep_planes=14, max_iter=400))
    params = dataclasses.replace(
        P_LINE, shin_hold=True, flight_piece_s=0.0
    )  # (the piece rule alone would keep it too)
    kept = FootholdMemory(t_mem, chosen, np.zeros(4), np.ones(4, dtype=bool), np.ones(4, dtype=bool))
    d = choose_footholds(view, path, world, kept, qp, params)
    np.testing.assert_allclose(d.p_world_touchdown[k_fl, :2], [0.3, 0.15], atol=0.011)
    assert d.memory.shin_ok is not None and d.memory.shin_ok[0]
    # without the rule, or with the earlier choice not known to clear: the place of most clearance, elsewhere
    off = choose_footholds(view, path, world, kept, qp, dataclasses.replace(params, shin_hold=False))
    unknown = FootholdMemory(t_mem, chosen, np.zeros(4), np.ones(4, dtype=bool))
    d2 = choose_footholds(view, path, world, unknown, qp, params)
    for dd in (off, d2):
        assert abs(dd.p_world_touchdown[k_fl, 0] - 0.3) > 0.05
        assert dd.memory.shin_ok is not None and not dd.memory.shin_ok[0]


def test_going_down_a_slope_is_not_stepping_down_an_edge() -> None:
    # 15° down along +x from x = 0: the ground behind a foot is higher, but along the slope under it
    xs = -0.6 + np.arange(110) * RES
    ys = -0.9 + np.arange(60) * RES
    X = np.broadcast_to(xs[:, None], (110, 60))
    h = np.asarray(-math.tan(math.radians(15.0)) * np.maximum(X, 0.0), dtype=np.float64)
    world = _world(xs, ys, h)
    label = world.regions.label_at(1.0, 0.1)
    poly = convex_around(world.regions, label, np.array([1.0, 0.1]), P.window_m)
    assert poly is not None
    view = _leg_view(0.7, -0.19)
    hip = np.array([1.0, 0.1])
    clear, _ = leg_clearance(view, world.maps, 0, hip, np.array([[1.0, 0.1]]), P_LINE)
    assert clear[0] == np.inf
    assert leg_bounds(view, world.maps, 0, hip, np.array([1.0, 0.1]), poly, P_LINE) == []


def test_a_foothold_beyond_the_legs_reach_is_bounded_back_toward_the_hip() -> None:
    world = _steps_down()
    maps, regions = world.maps, world.regions
    view = _leg_view(0.0, 0.6)
    hip = np.array([0.3, 0.1])
    # 0.45 m ahead of the hip on the landing: beyond where 90 % of the leg's 0.66 m reaches from 0.52 m up
    nom = np.array([0.75, 0.1])
    poly = convex_around(regions, regions.label_at(0.6, 0.1), nom, P.window_m)
    assert poly is not None
    _, within = leg_clearance(view, maps, 0, hip, nom[None, :], P)
    assert not within[0]
    bounds = leg_bounds(view, maps, 0, hip, nom, poly, P)
    assert len(bounds) == 1 and bounds[0][0][0] == pytest.approx(1.0)
    reach = math.sqrt((0.9 * 0.66) ** 2 - 0.52**2)
    assert bounds[0][1] == pytest.approx(0.3 + reach, abs=RES + 1e-6)
    # the region choice leaves out what is out of reach
    assert choose_region(regions, maps, np.array([0.9, 0.1]), 0.6, None, P, hip=hip[:2], reach_m=reach) == 0


def dataclass_replace(obj, **kw):  # type: ignore[no-untyped-def]
    import dataclasses

    return dataclasses.replace(obj, **kw)


def test_a_swing_rises_over_a_nosing_going_up_but_not_stepping_down_past_it() -> None:
    world = _steps_down()
    view = _view(np.zeros(4), np.array([0.3, 0.3, -0.3, -0.3]))

    def going(z_from: float, x_from: float, z_to: float, x_to: float) -> tuple[float, float, str]:
        feet = view.p_world_foot.copy()
        feet[0] = [x_from, 0.15, z_from + view.foot_radius_m]
        chosen = np.full((4, 3), np.nan)
        chosen[0] = [x_to, 0.15, z_to]
        mem = FootholdMemory(np.full(4, np.nan), chosen, np.full(4, np.nan))
        last = FootholdDecision(np.zeros((0, 3)), (), None, 0.0, mem)
        v = dataclass_replace(view, p_world_foot=feet)
        return swing_hump(v, world, last, False), swing_hump(v, world, last, True), cadence(v, world, last, P)

    # down from the landing (0.6 m) onto the first tread (0.45 m): the nosing lies above the straight line, but
    # not above the foot: no rise asked for, the walk's own gait
    line, above, gait = going(0.6, 0.9, 0.45, 1.2)
    assert line > 0.03 and above == pytest.approx(0.0, abs=1e-9) and gait == "trot"
    # up the same step: the nosing is above both, a slower gait with longer swings
    line, above, gait = going(0.45, 1.2, 0.6, 0.9)
    assert above > 0.05 and above == pytest.approx(line) and gait in P.climb_gaits


def test_hind_feet_a_riser_below_the_front_feet_keep_the_climbing_gait() -> None:
    """Up _steps_down along -x: the front feet on the landing (0.6 m), the hind feet on the tread below (0.45 m),
    every next foothold on its foot's own tread (no step rise, no hump: the walk's trot before). The hind feet have
    the riser still to climb: rise_behind is 0.15 m and the gait is a climbing one with swings long enough for it.
    Walking backward down the same flight, or on one plane, nothing is behind and below."""
    world = _steps_down()
    view = dataclass_replace(
        _view(np.array([0.6, 0.6, 0.45, 0.45]), np.array([0.85, 0.85, 1.15, 1.15])), yaw=math.pi
    )
    view = dataclass_replace(view, p_world_body=np.array([1.0, 0.0, 1.05]), z_contact=0.545)
    chosen = view.p_world_foot.copy()
    chosen[:, 0] -= 0.1  # each on its own tread
    chosen[:, 2] -= view.foot_radius_m
    last = FootholdDecision(
        np.zeros((0, 3)), (), None, 0.0, FootholdMemory(np.full(4, np.nan), chosen, np.full(4, np.nan))
    )
    assert rise_behind(view, world, last, math.pi) == pytest.approx(0.15, abs=1e-9)  # going up, along -x
    gait = cadence(view, world, last, P)
    need = P.base_swing_s + 0.15 / P.rise_speed_mps
    assert gait in P.climb_gaits and get_gait(gait).swing_s >= min(need, get_gait(P.climb_gaits[-1]).swing_s)
    assert cadence(view, world, last, dataclass_replace(P, count_rise_behind=False)) == "trot"  # as before
    # going down (walking backward, or turning round at the top to go down): the feet behind are the higher ones
    assert rise_behind(view, world, last, 0.0) == 0.0
    on_top = view.p_world_foot * np.array([1.0, 1.0, 0.0]) + np.array([-0.3, 0.0, 0.62])
    level = dataclass_replace(view, p_world_foot=on_top)
    assert rise_behind(level, world, None, math.pi) == 0.0  # all four on the landing


def test_a_plain_slope_is_the_walks_own_gait_ground_at_the_legs_stride() -> None:
    """A 15° slope: the dilated swing ground stands a few mm above a straight swing up it, below free_rise_m, so at
    a 1.0 m/s allowance (above the climb gaits' 0.5) the walk keeps its trot (without the threshold, or at 0.5 m/s,
    it takes `climb`), and the trot strides as far as the legs reach (1.0 m/s at its 0.5 s cycle), the climb gaits
    max_stride_m."""
    xs = -0.6 + np.arange(110) * RES
    ys = -0.9 + np.arange(60) * RES
    h = np.broadcast_to(math.tan(math.radians(15.0)) * xs[:, None], (110, 60)).astype(np.float64)
    world = _world(xs, ys, h)
    legs = {"l_upper_m": 0.32, "l_lower_m": 0.34}
    view = dataclass_replace(_view(np.zeros(4), np.array([0.3, 0.3, -0.3, -0.3])), **legs)
    feet = view.p_world_foot.copy()
    feet[:, 2] = np.tan(math.radians(15.0)) * feet[:, 0] + view.foot_radius_m
    chosen = feet.copy()
    chosen[:, 0] += 0.25
    chosen[:, 2] = np.tan(math.radians(15.0)) * chosen[:, 0]
    last = FootholdDecision(
        np.zeros((0, 3)), (), None, 0.0, FootholdMemory(np.full(4, np.nan), chosen, np.full(4, np.nan))
    )
    view = dataclass_replace(view, p_world_foot=feet)
    rise = swing_hump(view, world, last, True)
    assert 0.0 < rise < P.free_rise_m
    assert (
        rise_behind(view, world, last, 0.0) == 0.0
    )  # a slope is one region: its front feet higher count nothing
    fast = dataclass_replace(P, max_speed_mps=1.0)
    assert climb_top_speed(view, P) == pytest.approx(0.5)
    assert cadence(view, world, last, fast) == "trot"
    assert cadence(view, world, last, dataclass_replace(fast, free_rise_m=0.0)) in P.climb_gaits
    assert cadence(view, world, last, P) in P.climb_gaits
    stride = 2.0 * math.sqrt((P.fast_stride_reach_frac * 0.66) ** 2 - 0.52**2)
    assert stride_m(view, "trot", P) == pytest.approx(stride) and stride > 0.5
    assert stride_m(view, "climb", P) == P.max_stride_m
    cmd = dataclass_replace(view, operator=SteeringCommand(1.0, 0.0, 0.0))
    assert decide(cmd, world, last, fast).command.vx == pytest.approx(1.0)


def test_a_trailing_stance_foot_paces_the_body_and_holds_its_height_within_the_legs_reach() -> None:
    # a 0.32 m thigh and a 0.34 m shank; the body 0.52 m above flat ground, the feet under their hips
    legs = {"l_upper_m": 0.32, "l_lower_m": 0.34}
    view = dataclass_replace(
        _view(np.zeros(4), np.array([0.3, 0.3, -0.3, -0.3])), z_contact=0.0, foot_radius_m=0.0, **legs
    )
    view = dataclass_replace(view, p_world_foot=view.p_world_foot * np.array([1.0, 1.0, 0.0]))
    mem = FootholdMemory.empty()
    lift = np.array([1.2, 1.2, 1.4, 1.4])  # each stance foot's planned liftoff (now: 1.0 s)
    last = FootholdDecision(np.zeros((0, 3)), (), None, 0.0, mem, 0.0, lift)
    # under their hips, the feet leave room: the speed and the height stand
    assert trail_speed(view, last, P) > P.max_speed_mps
    assert reach_height(view, 0.0, P) > view.standing_height_m
    # a hind foot 0.2 m back and 5 cm below: the body lower, and slower as the foot's liftoff is 0.4 s away
    feet = view.p_world_foot.copy()
    feet[2] = [-0.5, 0.15, -0.05]
    low = dataclass_replace(view, p_world_foot=feet)
    length = P.height_reach_frac * 0.66
    h = reach_height(low, 0.0, P)
    assert h == pytest.approx(-0.05 + math.sqrt(length**2 - 0.2**2), abs=1e-9)
    assert h < view.standing_height_m
    room = math.sqrt((P.trail_reach_frac * 0.66) ** 2 - (0.52 + 0.05) ** 2) - 0.2
    v = trail_speed(low, last, P)
    assert v == pytest.approx(room / 0.4, abs=1e-9)
    assert 0.0 < v < P.max_speed_mps
    # that foot in the air, or without a planned liftoff: no bound from it
    air = dataclass_replace(low, stance=np.array([True, True, False, True]))
    assert trail_speed(air, last, P) > P.max_speed_mps
    assert reach_height(air, 0.0, P) > view.standing_height_m
    # a hind foot left 0.58 m behind its hip (near the leg's reach): not below min_height_m, never to the ground
    far = feet.copy()
    far[2] = [-0.88, 0.15, 0.0]
    stuck = dataclass_replace(view, p_world_foot=far)
    assert _reach_bound_unfloored(stuck, P) < P.min_height_m
    assert reach_height(stuck, 0.0, P) == pytest.approx(P.min_height_m)
    # the decision applies both: the body height and the speed come down
    world = _world(*_stones())
    d = decide(low, world, last, P)
    assert d.body_height_m == pytest.approx(h, abs=0.005)  # (the pitch target moved a little meanwhile)
    assert d.speed_cap_mps <= max(v, 0.0) + 1e-9


def test_pitched_nominal_footholds_are_moved_under_the_pitched_hips() -> None:
    from planning.steps.state import BodyMotion, StepPath

    view = dataclass_replace(_view(np.zeros(4), np.zeros(4)), pitch_rad=-0.5)
    legs = np.array([0, 3], dtype=np.int64)
    p = np.array([[0.3, 0.1, 0.0], [-0.3, -0.1, 0.0]])
    path = StepPath(
        leg=legs,
        t_touchdown=np.array([1.2, 1.3]),
        t_liftoff=np.array([1.6, 1.7]),
        p_world_touchdown=p,
        t_liftoff_now=np.full(4, np.nan),
        body=BodyMotion(np.zeros(2), 0.0, np.zeros(2), 0.0, 1.0),
    )
    out = pitched_nominals(view, path).p_world_touchdown
    shift = 0.3 * (1.0 - math.cos(0.5))
    np.testing.assert_allclose(out[:, 0], [0.3 - shift, -0.3 + shift])
    np.testing.assert_allclose(out[:, 1:], p[:, 1:])
    assert pitched_nominals(dataclass_replace(view, pitch_rad=0.0), path) is path


def test_a_table_top_out_of_the_sensors_sight_is_remembered_and_keeps_the_body_crouched() -> None:
    # a table's underside 0.6 m up over x 0.2-1.0 m, seen in the first scan; the next scans (the window moved on
    # by 3 cells) no longer see it, as the cameras do not once the body is under it
    xs = -0.6 + np.arange(60) * RES
    ys = -0.45 + np.arange(30) * RES
    seen = np.full((60, 30), np.inf)
    seen[(xs > 0.2) & (xs < 1.0), :] = 0.6
    memory = OverhangMemory()
    memory.apply((xs[0], ys[0]), RES, seen)
    origin = (xs[0] + 3 * RES, ys[0])
    remembered = memory.apply(origin, RES, np.full((60, 30), np.inf))
    grid = HeightGrid(origin, RES, remembered)
    assert grid(0.5, 0.0) == pytest.approx(0.6) and grid(1.3, 0.0) == np.inf
    # a lower underside seen later wins; a higher one does not replace it
    lower = np.full((60, 30), np.inf)
    lower[:, :] = np.where(((origin[0] + np.arange(60) * RES) > 0.4)[:, None], 0.58, np.inf)
    remembered = memory.apply(origin, RES, lower)
    assert HeightGrid(origin, RES, remembered)(0.5, 0.0) == pytest.approx(0.58)
    assert HeightGrid(origin, RES, remembered)(0.3, 0.0) == pytest.approx(0.6)

    maps = maps_from_grids(origin, RES, np.zeros((60, 30)), np.zeros((60, 30), bool))
    view = _view(np.zeros(4), np.array([0.3, 0.3, -0.3, -0.3]))
    assert crouch_height(view, maps, P) == np.inf  # no overhang: no bound
    crouched = crouch_height(view, maps, P, HeightGrid(origin, RES, remembered))
    assert P.min_height_m <= crouched <= 0.58 - P.body_top_m - P.head_margin_m + 1e-9


def _reach_bound_unfloored(view: TerrainView, p: DecisionParams) -> float:
    """reach_height's geometry by hand, without its floor: the highest hip height (pitch 0) at which every stance foot
    lies within height_reach_frac of the leg's length of its hip along x."""
    length = p.height_reach_frac * (view.l_upper_m + view.l_lower_m)
    dx = view.p_world_foot[:, 0] - (view.p_world_body[0] + view.p_body_hip[:, 0])
    use = view.stance & (np.abs(dx) < length)
    return float(np.min(view.p_world_foot[use, 2] + np.sqrt(length**2 - dx[use] ** 2) - view.z_contact))


def _trot_path(x_feet: np.ndarray, nominal_x: np.ndarray, t_now: float = 1.0) -> StepPath:
    """Two trot steps per leg, the first pair (FL, RR) 0.1 s ahead, the other (FR, RL) 0.3 s ahead; the body moving at
    0.3 m/s along x from x 0; each leg's two touchdowns at nominal_x[leg] and 0.3 m further on (y ±0.15)."""
    legs = np.array([0, 3, 1, 2, 0, 3, 1, 2])
    t_td = t_now + np.array([0.1, 0.1, 0.3, 0.3, 0.5, 0.5, 0.7, 0.7])
    y = np.array([0.15, -0.15, 0.15, -0.15])
    p = np.column_stack([nominal_x[legs] + np.repeat([0.0, 0.3], 4), y[legs], np.zeros(8)])
    body = BodyMotion(np.array([0.0, 0.0]), 0.0, np.array([0.3, 0.0]), 0.0, t_now)
    lo_now = np.array([t_now - 0.1, t_now + 0.1, t_now + 0.1, t_now - 0.1])
    return StepPath(legs, t_td, t_td + 0.2, p, lo_now, body, "reference", "trot")


def test_a_touchdown_with_no_region_steps_in_place_and_a_foothold_off_every_region_is_not_held() -> None:
    """A pit 1 m wide (x 0.6-1.6): a stance foot whose next nominal lies mid-pit, farther than search_m from any
    region, keeps standing where it is (held in the step QP), not sent to its nominal over the pit; a foot in the
    air keeps its choice made on a region; and a foothold remembered in the pit (chosen off every region) is not
    held by the lost-region rule."""
    xs = -0.6 + np.arange(110) * RES
    ys = -0.9 + np.arange(60) * RES
    X = np.broadcast_to(xs[:, None], (110, 60))
    h = np.asarray(np.where((X < 0.6) | (X > 1.6), 0.0, -0.3), dtype=np.float64)
    world = _world(xs, ys, h)
    feet_x = np.array([0.45, 0.45, -0.15, -0.15])
    view = dataclass_replace(_view(np.zeros(4), feet_x), stance=np.array([False, True, True, True]))
    # FR (leg 1, in stance) has its next nominal at x 1.1, mid-pit; the others on the platform
    path = _trot_path(feet_x, np.array([0.5, 1.1, -0.1, -0.1]))
    qp = StepQP(dataclass_replace(StepQPParams(), keep_planes=14, max_iter=400))
    d = choose_footholds(view, path, world, FootholdMemory.empty(), qp, P)
    k_fr = int(np.flatnonzero(path.leg == 1)[0])
    np.testing.assert_allclose(d.p_world_touchdown[k_fr, :2], view.p_world_foot[1, :2], atol=0.011)
    assert d.memory.on_region is not None and d.memory.on_region[1]
    # the other legs' first touchdowns stay on the platform (their regions)
    for leg in (0, 2, 3):
        k = int(np.flatnonzero(path.leg == leg)[0])
        assert d.p_world_touchdown[k, 0] < 0.6
    # a foothold remembered in the pit, chosen off every region: not held, the touchdown steps in place instead
    chosen = np.full((4, 3), np.nan)
    chosen[1] = [1.1, -0.15, -0.3]
    t_mem = np.full(4, np.nan)
    t_mem[1] = float(path.t_touchdown[k_fr])
    off = FootholdMemory(t_mem, chosen, np.zeros(4), np.array([True, False, True, True]))
    d2 = choose_footholds(view, path, world, off, qp, P)
    np.testing.assert_allclose(d2.p_world_touchdown[k_fr, :2], view.p_world_foot[1, :2], atol=0.011)
    # FL in the air, its nominal moved mid-pit after it lifted off toward a foothold on the platform: kept there
    path_fl = _trot_path(feet_x, np.array([1.1, 0.5, -0.1, -0.1]))
    k_fl = int(np.flatnonzero(path_fl.leg == 0)[0])
    chosen = np.full((4, 3), np.nan)
    chosen[0] = [0.5, 0.15, 0.0]
    t_mem = np.full(4, np.nan)
    t_mem[0] = float(path_fl.t_touchdown[k_fl])
    kept = FootholdMemory(t_mem, chosen, np.zeros(4), np.ones(4, dtype=bool))
    d3 = choose_footholds(view, path_fl, world, kept, qp, P)
    np.testing.assert_allclose(d3.p_world_touchdown[k_fl, :2], [0.5, 0.15], atol=0.011)


def _choose_region_reference(regions, maps, xy, z_ref, keep_xy, p, in_flight, hip, reach_m, side=None):  # type: ignore[no-untyped-def]
    """choose_region's rule cell by cell: each region's least cost over its inset cells in the window."""
    res, (ox, oy) = regions.resolution_m, regions.origin_xy
    w = int(math.ceil(p.search_m / res))
    cx, cy = int(round((xy[0] - ox) / res)), int(round((xy[1] - oy) / res))
    best: dict[int, float] = {}
    for i in range(max(cx - w, 0), min(cx + w + 1, regions.labels.shape[0])):
        for j in range(max(cy - w, 0), min(cy + w + 1, regions.labels.shape[1])):
            if not regions.inset[i, j]:
                continue
            lab = int(regions.labels[i, j])
            dx, dy = ox + i * res - xy[0], oy + j * res - xy[1]
            dist, dz = math.hypot(dx, dy), abs(float(maps.ground_height[i, j]) - z_ref)
            ok = dist <= p.search_m and dz <= p.max_rise_m
            if hip is not None and math.isfinite(reach_m):
                ok = ok and math.hypot(dx + xy[0] - hip[0], dy + xy[1] - hip[1]) <= reach_m
            if side is not None:
                along = (dx + xy[0] - side[0]) * side[2] + (dy + xy[1] - side[1]) * side[3]
                ok = ok and along >= p.regions.foot_radius_m + p.own_side_m
            best[lab] = min(best.get(lab, math.inf), dist + p.w_height * dz if ok else math.inf)
    finite = {k: v for k, v in best.items() if math.isfinite(v)}
    if not finite:
        return 0
    choice = min(finite, key=lambda k: (finite[k], k))
    if keep_xy is not None:
        prev = regions.label_at(keep_xy[0], keep_xy[1])
        if 0 < prev <= max(best) and best.get(prev, math.inf) <= finite[choice] + (
            math.inf if in_flight else p.keep_m
        ):
            return prev
    return choice


@pytest.mark.parametrize("seed", range(6))
def test_choose_region_equals_its_cell_by_cell_rule(seed: int) -> None:
    """The region choice on the window's arrays against the rule cell by cell: random terraces, kept regions in
    flight or not, hips with a reach."""
    rng = np.random.default_rng(seed)
    nx, ny = 50, 40
    h = np.round(rng.integers(0, 4, (5, 4)).astype(np.float64) * 0.05, 2)
    h = np.kron(h, np.ones((10, 10)))
    xs, ys = np.arange(nx) * RES, -0.6 + np.arange(ny) * RES
    maps = maps_from_grids((xs[0], ys[0]), RES, h, np.zeros(h.shape, bool))
    regions = segment_regions(maps, P.regions, cover=False)
    assert regions.n_regions > 2
    asked = []
    for _ in range(40):
        xy = np.array([rng.uniform(-0.2, 1.7), rng.uniform(-0.8, 0.8)])
        z_ref = float(rng.choice([0.0, 0.05, 0.1, 0.15]))
        keep = None if rng.random() < 0.3 else np.array([rng.uniform(0, 1.5), rng.uniform(-0.6, 0.6)])
        flying = bool(rng.random() < 0.5)
        hip = None if rng.random() < 0.5 else xy + rng.uniform(-0.2, 0.2, 2)
        reach = float(rng.uniform(0.1, 0.4))
        a = rng.uniform(-math.pi, math.pi)
        side = xy - rng.uniform(0.0, 0.2) * np.array([math.cos(a), math.sin(a)])
        side = np.concatenate([side, [math.cos(a), math.sin(a)]])
        got = choose_region(regions, maps, xy, z_ref, keep, P, flying, hip, reach)
        want = _choose_region_reference(regions, maps, xy, z_ref, keep, P, flying, hip, reach)
        assert got == want
        got_side = choose_region(regions, maps, xy, z_ref, keep, P, flying, hip, reach, side)
        assert got_side == _choose_region_reference(
            regions, maps, xy, z_ref, keep, P, flying, hip, reach, side
        )
        if hip is not None:
            asked.append((xy, z_ref, keep, flying, hip, side))
    # several at once (as the footholds ask a stride's four), one reach for all: each one's own answer
    reach = 0.3
    assert len(asked) >= 8
    for g in range(0, len(asked) - 3, 4):
        group = asked[g : g + 4]
        got_all = _choose_regions(
            regions,
            maps,
            np.array([a[0] for a in group]),
            [a[1] for a in group],
            [a[2] for a in group],
            P,
            [a[3] for a in group],
            np.array([a[4] for a in group]),
            reach,
        )
        assert got_all == [
            choose_region(regions, maps, a[0], a[1], a[2], P, a[3], a[4], reach) for a in group
        ]
        got_all = _choose_regions(
            regions,
            maps,
            np.array([a[0] for a in group]),
            [a[1] for a in group],
            [a[2] for a in group],
            P,
            [a[3] for a in group],
            np.array([a[4] for a in group]),
            reach,
            np.array([a[5] for a in group]),
        )
        assert got_all == [
            choose_region(regions, maps, a[0], a[1], a[2], P, a[3], a[4], reach, a[5]) for a in group
        ]


def _row_of_two() -> TerrainWorld:
    """A platform up to x = 0.6 m, a pit 0.3 m deep, one row of two stones at x 0.85-1.15 m: the left stone from
    y 0.10 m out, the right one from y -0.04 m out (a slot 14 cm wide between them, off the centre line)."""
    xs = -0.6 + np.arange(110) * RES
    ys = -0.9 + np.arange(60) * RES
    X = np.broadcast_to(xs[:, None], (110, 60))
    Y = np.broadcast_to(ys[None, :], (110, 60))
    row = (X > 0.85) & (X < 1.15) & ((Y > 0.10) | (Y < -0.04)) & (np.abs(Y) < 0.55)
    h = np.where((X < 0.6) | (X > 1.4) | row, 0.0, -0.3)
    return _world(xs, ys, np.asarray(h, dtype=np.float64))


def test_a_foothold_is_chosen_on_its_legs_own_side_of_the_body() -> None:
    """A left foot whose nominal place lies over the slot between a row's two stones, nearer the right stone: the
    right stone without the side bound (the legs would cross), the left stone with it; a right foot there keeps
    the right stone; the same through choose_footholds (stones draws 254 and 167's fault)."""
    world = _row_of_two()
    regions, maps = world.regions, world.maps
    left, right = regions.label_at(1.0, 0.3), regions.label_at(1.0, -0.3)
    assert left and right and left != right
    nom = np.array([1.0, 0.02])
    body = np.array([0.7, 0.0])
    left_side = np.array([*body, 0.0, 1.0])
    right_side = np.array([*body, 0.0, -1.0])
    assert choose_region(regions, maps, nom, 0.0, None, P) == right
    assert choose_region(regions, maps, nom, 0.0, None, P, side=left_side) == left
    assert choose_region(regions, maps, nom, 0.0, None, P, side=right_side) == right
    # no bound: the old choice
    loose = dataclass_replace(P, own_side_m=None)
    assert choose_region(regions, maps, nom, 0.0, None, loose, side=left_side) == right
    # a cell exactly on the bound counts; the bound is the robot's foot radius plus own_side_m
    assert own_side(P) == pytest.approx(P.regions.foot_radius_m + P.own_side_m)
    # the footholds: the body at the platform's edge, FL (leg 0) 0.1 s from its touchdown with its nominal place at
    # (1.0, 0.02), both stones' inner cells within its reach: its own stone with the bound, the right one without
    feet = np.array([[0.52, 0.15, 0.02], [0.52, -0.15, 0.02], [-0.05, 0.15, 0.02], [-0.05, -0.15, 0.02]])
    view = dataclass_replace(
        _view(np.zeros(4), feet[:, 0]),
        p_world_body=np.array([0.62, 0.0, 0.55]),
        p_world_foot=feet,
        stance=np.array([False, True, True, True]),
        l_upper_m=0.33,
        l_lower_m=0.33,
    )
    legs = np.array([0, 3, 1, 2, 0, 3, 1, 2])
    t_td = 1.0 + np.array([0.1, 0.1, 0.3, 0.3, 0.5, 0.5, 0.7, 0.7])
    p_td = np.array([[1.0, 0.02, 0.0], [0.45, -0.15, 0.0], [0.75, -0.15, 0.0], [0.1, 0.15, 0.0]])
    p_td = np.vstack([p_td, p_td + [0.3, 0.0, 0.0]])
    body = BodyMotion(np.array([0.62, 0.0]), 0.0, np.array([0.3, 0.0]), 0.0, 1.0)
    lo_now = np.array([0.9, 1.1, 1.1, 0.9])
    path = StepPath(legs, t_td, t_td + 0.2, p_td, lo_now, body, "reference", "trot")
    qp = StepQP(_regions_qp())
    for params, want_left in ((P, True), (loose, False)):
        d = choose_footholds(view, path, world, FootholdMemory.empty(), qp, params)
        y = float(d.p_world_touchdown[0, 1])
        assert y > 0.10 if want_left else y < -0.04, (params.own_side_m, d.p_world_touchdown[0])


@pytest.mark.parametrize("rule", ["line", "segment", "both"])
def test_the_shin_clearance_of_several_legs_at_once_equals_each_legs_own(rule: str) -> None:
    """The footholds test the first four slots' shins in one evaluation (a hip per foot): the same clearances and
    reaches as leg_clearance leg by leg, near the nosing and beyond reach."""
    from planning.terrain.decision import _clearance, hip_height

    world = _steps_down()
    view = dataclass_replace(_leg_view(0.85, 0.6), pitch_rad=0.2, abd_offset_m=ABD, shin_radius_m=0.02)
    p = dataclasses.replace(P, shin_rule=rule)
    rng = np.random.default_rng(3)
    legs = np.array([0, 1, 2, 3, 0, 2])
    hips = np.column_stack([0.85 + view.p_body_hip[legs, 0], view.p_body_hip[legs, 1]]) + rng.normal(
        0, 0.02, (6, 2)
    )
    feet = np.column_stack([rng.uniform(0.9, 1.6, 6), rng.uniform(-0.2, 0.2, 6)])
    feet[5] = hips[5] + 0.8  # out of reach
    z_hips = np.array([hip_height(view, int(leg)) for leg in legs])
    clear, within = _clearance(view, world.maps, z_hips, hips, feet, p, legs)
    for i, leg in enumerate(legs):
        c1, w1 = leg_clearance(view, world.maps, int(leg), hips[i], feet[i : i + 1], p)
        assert clear[i] == pytest.approx(c1[0], abs=1e-12) and within[i] == w1[0]
    assert not within[5] and np.any(np.isfinite(clear))


@pytest.mark.parametrize("robot_name", ["spot", "go1"])
def test_the_body_paths_footprint_from_the_robot_covers_its_legs_past_a_tall_box(robot_name: str) -> None:
    """The pipeline's body path sweeps circles that cover the robot's legs, not only its trunk (robot_footprint):
    every knee of the standing pose lies inside them, which the trunk's circles (BodyPathParams' defaults) leave
    out for Spot's hind knees; and a path planned past a tall box with them keeps those knees off the box, where
    the trunk's circles took them into it (the clutter falls on a hind thigh against a tall box). (The rule is off
    on the pipeline by default: PipelineParams.footprint_from_robot.)"""
    from planning.robot import load_robot
    from planning.terrain.bodypath import BodyPathParams
    from planning.terrain.decision import PipelineParams, robot_footprint

    robot = load_robot(robot_name)
    trunk = BodyPathParams()
    on = PipelineParams(footprint_from_robot=True)
    fp = robot_footprint(robot, on, trunk)
    knees = np.array([robot.knee_body(leg, robot.q_nominal[leg])[:2] for leg in range(4)])

    def covered(pts: np.ndarray, params: BodyPathParams) -> np.ndarray:
        d = np.hypot(pts[:, None, 0] - np.asarray(params.footprint_x_m)[None, :], pts[:, None, 1])
        return np.min(d, axis=1) <= params.footprint_r_m - on.footprint_margin_m + 1e-9

    assert np.all(covered(knees, fp))
    assert robot_footprint(robot, PipelineParams(footprint_from_robot=False), trunk) == trunk
    with pytest.raises(ValueError, match="footprint_circles"):
        robot_footprint(robot, dataclass_replace(on, footprint_circles=0), trunk)
    if robot_name != "spot":
        return
    assert not np.all(covered(knees, trunk))
    # a tall box across the straight line (clutter's first tall box), body obstacle cells
    xs, ys = -1.0 + np.arange(200) * RES, -1.5 + np.arange(100) * RES
    X, Y = np.meshgrid(xs, ys, indexing="ij")
    box = (1.5, 1.95, -0.3, 0.3)
    body = (X >= box[0]) & (X <= box[1]) & (Y >= box[2]) & (Y <= box[3])
    maps = maps_from_grids((xs[0], ys[0]), RES, np.where(body, 0.7, 0.0), body, body)

    def knees_clear(params: BodyPathParams, y0: float) -> float:
        path = plan_body_path(maps, (0.0, y0), 0.0, (4.0, y0), params)
        c, s = np.cos(path.yaw)[:, None], np.sin(path.yaw)[:, None]
        wx = path.xy[:, 0:1] + c * knees[None, :, 0] - s * knees[None, :, 1]
        wy = path.xy[:, 1:2] + s * knees[None, :, 0] + c * knees[None, :, 1]
        dx = np.maximum(np.maximum(box[0] - wx, wx - box[1]), 0.0)
        dy = np.maximum(np.maximum(box[2] - wy, wy - box[3]), 0.0)
        inside = (dx == 0.0) & (dy == 0.0)
        return float(np.min(np.where(inside, -1.0, np.hypot(dx, dy))))

    starts = (0.0, -0.1)
    assert min(knees_clear(trunk, y0) for y0 in starts) < 0.0
    for y0 in starts:
        assert knees_clear(fp, y0) >= 0.02


ABD = np.array([0.11, -0.11, 0.11, -0.11])  # the legs' planes' lateral offsets from their abduction axes (m)


@pytest.mark.parametrize("robot_name", ["spot", "go1"])
def test_the_shins_knee_is_the_robots_own_knee_for_the_foot(robot_name: str) -> None:
    """shin_knees (the leg's plane rolled about the abduction axis to hold the foot, the knee behind the
    pivot-foot line) puts the knee where the robot's inverse kinematics does, for feet around the nominal stance."""
    from planning.robot.model import load_robot
    from planning.terrain.decision import shin_knees

    robot = load_robot(robot_name)
    rng = np.random.default_rng(5)
    n = 0
    for leg in range(4):
        for _ in range(30):
            foot = (
                robot.nominal_foot_body[leg]
                + [0.0, 0.0, robot.foot_radius_m]
                + rng.normal(0, [0.08, 0.05, 0.05])
            )
            knee = robot.knee_of_foot(leg, *foot.tolist())
            if knee is None:
                continue
            got, reach = shin_knees(
                robot.p_body_hip[leg],
                foot[None, :],
                np.array([1.0, 0.0, 0.0]),
                np.array([0.0, 1.0, 0.0]),
                robot.abd_offset[leg],
                robot.l_upper,
                robot.l_lower,
            )
            assert reach[0] and np.linalg.norm(got[0] - np.array(knee)) < 1e-6
            n += 1
    assert n > 60


def _box_world(x0: float, x1: float, y0: float, y1: float, height: float) -> TerrainWorld:
    xs = np.arange(80) * RES
    ys = -0.6 + np.arange(40) * RES
    X, Y = np.meshgrid(xs, ys, indexing="ij")
    box = (X > x0) & (X < x1) & (Y > y0) & (Y < y1)
    return _world(xs, ys, np.where(box, height, 0.0))


def _spot_leg_view(body_x: float) -> TerrainView:
    return dataclass_replace(
        _leg_view(body_x, 0.0), foot_radius_m=0.035, shin_radius_m=0.02, abd_offset_m=ABD, height_m=0.52
    )


def test_the_shin_segment_meets_a_box_corner_beside_the_foot_that_the_heading_line_misses() -> None:
    """A front left foot 5 cm past a low box's far end (9 cm tall) and 3 cm to its right (clutter draw 86): the
    knee lies back over the box, the shin through its top corner: the segment rule flags it (for the hip over
    the foot or leaning in), the line along the heading passes beside the box and sees nothing; farther on,
    the shin clears it."""
    world = _box_world(0.75, 0.95, 0.03, 0.3, 0.09)
    view = _spot_leg_view(0.7)
    p_seg = dataclasses.replace(P, shin_rule="segment")
    feet = np.array([[1.0, 0.0], [1.02, 0.0]])
    for hip in ([1.0, -0.11], [1.0, 0.0], [0.95, 0.05]):
        clear, within = leg_clearance(view, world.maps, 0, np.array(hip), feet, p_seg)
        line, _ = leg_clearance(view, world.maps, 0, np.array(hip), feet, P_LINE)
        assert np.all(within) and np.all(clear < shin_needed(p_seg)), (hip, clear)
        assert np.all(line == np.inf)
    far, _ = leg_clearance(view, world.maps, 0, np.array([1.25, -0.11]), np.array([[1.25, 0.0]]), p_seg)
    assert far[0] >= shin_needed(p_seg)
    # the foothold's bounds along the heading move it on, past the box's reach (and ahead, the hip's reach)
    label = world.regions.label_at(1.0, 0.0)
    poly = convex_around(world.regions, label, np.array([1.0, 0.0]), P.window_m)
    assert poly is not None
    bounds = leg_bounds(view, world.maps, 0, np.array([1.0, -0.11]), np.array([1.0, 0.0]), poly, p_seg)
    behind = [b for a, b in bounds if a[0] == pytest.approx(-1.0)]
    assert len(behind) == 1 and -behind[0] > 1.03


def test_the_shin_segment_flags_a_box_corner_behind_a_long_step_that_the_heading_line_misses() -> None:
    """Clutter draw 889 (session 13): a front right foot landing 10 cm past a low box's far end (8 cm tall), the
    box's near side 3 cm outside the heading line through the foot, the foot 12-18 cm ahead of its hip (a long
    step: the shin flat). The line along the heading passes beside the box and sees nothing; the segment rule
    ("segment", and "both": the line and the segment) flags it, and clears a foot far enough past the box."""
    world = _box_world(0.70, 0.92, -0.35, -0.03, 0.08)
    view = _spot_leg_view(0.7)
    foot = np.array([[1.02, 0.0]])
    far = np.array([[1.30, 0.0]])
    for rule in ("segment", "both"):
        p_rule = dataclasses.replace(P, shin_rule=rule)
        for back in (0.12, 0.15, 0.18):
            hip = np.array([1.02 - back, 0.11])
            line, _ = leg_clearance(view, world.maps, 1, hip, foot, P_LINE)
            clear, within = leg_clearance(view, world.maps, 1, hip, foot, p_rule)
            assert line[0] == np.inf, back
            assert within[0] and clear[0] < shin_needed(p_rule), (rule, back, clear)
        clear, _ = leg_clearance(view, world.maps, 1, np.array([1.30 - 0.12, 0.11]), far, p_rule)
        assert clear[0] >= shin_needed(p_rule), rule


@pytest.mark.parametrize("rule", ["segment", "both"])
@pytest.mark.parametrize("seed", range(4))
def test_the_shin_segment_never_flags_flat_or_sloped_ground(seed: int, rule: str) -> None:
    """On a flat floor or a plain slope (up to 20°, any direction; the body pitched with it along its heading, as
    the decisions pitch it), footholds within 0.12 m of their nominal place under the hip: the shin always clears
    the ground by the margin (the ground's own plane at the foot is no edge)."""
    rng = np.random.default_rng(seed)
    xs = np.arange(80) * RES
    ys = -0.6 + np.arange(40) * RES
    X, Y = np.meshgrid(xs, ys, indexing="ij")
    slope = math.tan(math.radians(rng.uniform(5.0, 20.0))) if seed else 0.0
    a = rng.uniform(-math.pi, math.pi)
    world = _world(xs, ys, slope * (math.cos(a) * (X - 1.2) + math.sin(a) * Y))
    p_seg = dataclasses.replace(P, shin_rule=rule)
    pitch = -math.atan(slope * math.cos(a))  # nose down (+) where the ground falls along +x
    view = dataclass_replace(_spot_leg_view(1.2), pitch_rad=pitch)
    for leg in range(4):
        hip = np.array([1.2 + view.p_body_hip[leg, 0] * math.cos(pitch), view.p_body_hip[leg, 1]])
        feet = hip + np.array([0.0, ABD[leg]]) + rng.uniform(-0.12, 0.12, (20, 2))
        z_under = float(world.maps.height_at(1.2, 0.0))
        clear, within = leg_clearance(
            dataclass_replace(view, z_contact=z_under), world.maps, leg, hip, feet, p_seg
        )
        assert np.all(np.isfinite(clear)) and np.all(clear >= shin_needed(p_seg)), (slope, a, clear)


def test_a_swinging_foot_stepping_down_out_of_reach_lowers_the_body_height() -> None:
    # a 0.32 m thigh and a 0.34 m shank, feet under their hips on flat ground (contact points at 0)
    legs = {"l_upper_m": 0.32, "l_lower_m": 0.34}
    view = dataclass_replace(
        _view(np.zeros(4), np.array([0.3, 0.3, -0.3, -0.3])), z_contact=0.0, foot_radius_m=0.0, **legs
    )
    view = dataclass_replace(view, p_world_foot=view.p_world_foot * np.array([1.0, 1.0, 0.0]))
    on = dataclasses.replace(P, touchdown_reach_frac=0.95)
    chosen = np.full((4, 3), np.nan)
    chosen[1] = [0.5, -0.15, -0.18]  # FR's touchdown a riser below, 0.2 m ahead of its hip
    # FR in stance: its chosen touchdown does not count; off: no bound
    assert touchdown_reach_height(view, chosen, 0.0, on) == np.inf
    air = dataclass_replace(view, stance=np.array([True, False, True, True]))
    assert (
        touchdown_reach_height(air, chosen, 0.0, dataclasses.replace(P, touchdown_reach_frac=None)) == np.inf
    )
    # in the air: the body comes down until that touchdown is within 0.95 of the leg's length of its hip
    length = 0.95 * 0.66
    h = touchdown_reach_height(air, chosen, 0.0, on)
    assert h == pytest.approx(-0.18 + math.sqrt(length**2 - 0.2**2), abs=1e-9)
    assert h < view.standing_height_m
    # a longer leg share, or the touchdown on the ground it leaves: higher, or no lower than standing
    assert touchdown_reach_height(air, chosen, 0.0, dataclasses.replace(on, touchdown_reach_frac=1.0)) > h
    level = chosen.copy()
    level[1, 2] = 0.0
    assert touchdown_reach_height(air, level, 0.0, on) > view.standing_height_m
    # never below min_height_m (a touchdown far down: the body does not sit on the ground)
    deep = chosen.copy()
    deep[1, 2] = -0.6
    assert touchdown_reach_height(air, deep, 0.0, on) == pytest.approx(on.min_height_m)
    # the foot radius lifts the centre the leg reaches
    r = dataclass_replace(air, foot_radius_m=0.02)
    assert touchdown_reach_height(r, chosen, 0.0, on) == pytest.approx(h + 0.02, abs=1e-9)


def test_following_a_path_just_replanned_turns_the_body_toward_its_heading_near_body_obstacles() -> None:
    """A path replanned from the body's pose starts at the body's yaw (0) and turns to its heading (-30°) over its
    first 0.3 m: pursued at its nearest point (the default) it asks no turn, so a path replanned every tick (one
    grazing a body obstacle) leaves the body crabbing at its old yaw. With yaw_lookahead_m (off: it measured worse
    on the clutter family) the yaw is taken that far ahead, near body obstacles only (yaw_near_m)."""
    heading = math.radians(-30.0)
    goal = np.array([3.0 * math.cos(heading), 3.0 * math.sin(heading)])
    view = dataclasses.replace(_view(np.zeros(4), np.array([0.3, 0.3, -0.3, -0.3]), goal=goal), yaw=0.0)
    fresh = plan_body_path(None, (0.0, 0.0), 0.0, goal)
    assert fresh.yaw[0] == pytest.approx(0.0, abs=1e-9)
    near = dataclasses.replace(fresh, min_clearance_m=0.01)
    assert P.yaw_lookahead_m == 0.0
    old = follow_path(view, near, 0.3, P)
    assert abs(old.yaw_rate) < 1e-6  # no turn
    on = dataclasses.replace(P, yaw_lookahead_m=0.3)
    turn = follow_path(view, near, 0.3, on)
    assert -on.max_yaw_rate_rps - 1e-9 <= turn.yaw_rate < -0.3  # toward -30°, within the yaw-rate limit
    assert (turn.vx, turn.vy) == pytest.approx((old.vx, old.vy))  # the same pursuit
    # far from body obstacles the path is followed at its nearest point; yaw_near_m None: everywhere
    far = dataclasses.replace(fresh, min_clearance_m=0.5)
    assert abs(follow_path(view, far, 0.3, on).yaw_rate) < 1e-6
    everywhere = dataclasses.replace(on, yaw_near_m=None)
    assert follow_path(view, far, 0.3, everywhere).yaw_rate == pytest.approx(turn.yaw_rate)


def test_a_path_is_replanned_early_only_when_its_rest_sweeps_deeper_than_when_planned() -> None:
    # the default (path_worse_m None): any negative clearance of the rest replans at once
    assert path_holds(0.0, -0.03, None) and not path_holds(-0.001, 0.05, None)
    # with path_worse_m a path that grazed (-0.01) when planned holds until its rest goes 2 cm deeper
    assert path_holds(-0.02, -0.01, 0.02) and not path_holds(-0.04, -0.01, 0.02)
    # a path planned clear is replanned, as before, once its rest sweeps into an obstacle at all
    assert path_holds(0.0, 0.1, 0.02) and not path_holds(-0.001, 0.1, 0.02)


def _hip_heights_above_support(view: TerrainView, pitch: float, height: float) -> np.ndarray:
    """Each hip's height above its foot's contact point, the body at height above the mean contact height and
    pitched by pitch (positive nose down)."""
    z_hip = view.z_contact + height - math.sin(pitch) * view.p_body_hip[:, 0]
    return z_hip - (view.p_world_foot[:, 2] - view.foot_radius_m)


def test_the_hips_plane_pitches_the_body_so_each_hip_stands_as_high_above_its_own_foot() -> None:
    # feet under their hips on a slope, the front 0.2 m higher: the pitch whose sine is the rise over the hips' 0.6 m
    under = _view(np.array([0.2, 0.2, 0.0, 0.0]), np.array([0.3, 0.3, -0.3, -0.3]))
    offset, sin_pitch = hips_plane(under, None)
    assert sin_pitch == pytest.approx(-0.2 / 0.6)
    assert offset == pytest.approx(
        footholds_plane(under, None)[0], abs=1e-9
    )  # the feet under the hips: the same
    # a descent: the front feet reach ahead of their hips onto the tread below, the hind feet trail on the tread
    # above; the footholds' plane over the feet's 0.9 m is shallower than the drop between the hips' supports
    down = _view(np.array([0.0, 0.0, 0.2, 0.2]), np.array([0.45, 0.45, -0.45, -0.45]))
    _, slope = footholds_plane(down, None)
    _, sin_pitch = hips_plane(down, None)
    plane_pitch = -math.atan(slope)
    hips_pitch = math.asin(sin_pitch)
    assert hips_pitch > plane_pitch > 0.0  # nose down, more with the hips' rule
    offset, _ = hips_plane(down, None)
    h = down.standing_height_m + offset
    clear = _hip_heights_above_support(down, hips_pitch, h)
    np.testing.assert_allclose(clear, down.standing_height_m, atol=1e-9)  # every hip at the standing height
    flat_pitch = _hip_heights_above_support(down, plane_pitch, h)
    assert (
        flat_pitch[2:].min() < down.standing_height_m - 0.02
    )  # the plane's pitch folds the high (hind) pair
    # flat ground: no pitch, the support at the contact height
    flat = _view(np.zeros(4), np.array([0.4, 0.35, -0.2, -0.3]))
    offset, sin_pitch = hips_plane(flat, None)
    assert sin_pitch == pytest.approx(0.0, abs=1e-12)
    assert offset == pytest.approx(footholds_plane(flat, None)[0], abs=1e-9)


def test_the_hips_plane_counts_a_swinging_legs_chosen_touchdown() -> None:
    view = _view(np.zeros(4), np.array([0.3, 0.3, -0.3, -0.3]))
    view = dataclasses.replace(view, stance=np.array([False, True, True, True]))
    mem = dataclasses.replace(
        FootholdMemory.empty(), p_chosen=np.array([[0.5, 0.15, -0.2]] + [[np.nan] * 3] * 3)
    )
    last = FootholdDecision(np.zeros((0, 3)), (), None, 0.0, mem)
    _, with_chosen = hips_plane(view, last)
    _, without = hips_plane(view, None)
    assert without == pytest.approx(0.0, abs=1e-12)
    assert with_chosen > 0.0  # the front left stepping down: nose down


def test_the_decision_with_the_hips_posture() -> None:
    world = _world(*_stones())
    params = dataclass_replace(P, max_pitch_rate_rps=100.0, posture="hips")
    down = _view(np.array([0.0, 0.0, 0.2, 0.2]), np.array([0.45, 0.45, -0.45, -0.45]))
    d = decide(down, world, None, params)
    assert d.body_pitch_rad == pytest.approx(math.asin(0.2 / 0.6), abs=1e-6)
    assert d.body_pitch_rad <= params.max_pitch_rad
    # flat: the same height and pitch as the footholds' plane gives
    flat = _view(np.zeros(4), np.array([0.3, 0.3, -0.3, -0.3]))
    a = decide(flat, world, None, params)
    b = decide(flat, world, None, dataclass_replace(params, posture="plane"))
    assert a.body_pitch_rad == pytest.approx(b.body_pitch_rad) and a.body_height_m == pytest.approx(
        b.body_height_m
    )


def test_the_hips_pairs_posture_takes_each_pairs_highest_support() -> None:
    # a descent, the hind right foot swinging down to the tread below (its chosen touchdown), the hind left still
    # on the tread above: the least-squares line lowers the hind hips, the pairs' rule keeps them over the high foot
    view = _view(np.array([0.0, 0.0, 0.2, 0.2]), np.array([0.45, 0.45, -0.3, -0.3]))
    view = dataclasses.replace(view, stance=np.array([True, True, True, False]))
    mem = dataclasses.replace(
        FootholdMemory.empty(), p_chosen=np.array([[np.nan] * 3] * 3 + [[0.0, -0.15, 0.1]])
    )
    last = FootholdDecision(np.zeros((0, 3)), (), None, 0.0, mem)
    _, sin_ls = hips_plane(view, last)
    offset, sin_pairs = hips_pairs(view, last)
    assert sin_pairs == pytest.approx(0.2 / 0.6) and sin_pairs > sin_ls > 0.0
    h = view.standing_height_m + offset
    z_hip = view.z_contact + h - sin_pairs * view.p_body_hip[:, 0]
    support = np.array([0.0, 0.0, 0.2, 0.1])
    np.testing.assert_allclose((z_hip - support)[[0, 2]], view.standing_height_m, atol=1e-9)
    assert (z_hip - support).min() >= view.standing_height_m - 1e-9  # no leg folded below the standing height
    # flat ground: the same as the least-squares line
    flat = _view(np.zeros(4), np.array([0.4, 0.35, -0.2, -0.3]))
    assert hips_pairs(flat, None) == pytest.approx(hips_plane(flat, None))


def test_the_plane_without_touchdowns_holds_a_swinging_legs_last_stance_height() -> None:
    # the front left in the air 0.1 m up, its chosen touchdown 0.2 m lower than where it lifted off
    view = _view(np.zeros(4), np.array([0.3, 0.3, -0.3, -0.3]))
    feet = view.p_world_foot.copy()
    feet[0, 2] += 0.1
    view = dataclasses.replace(view, p_world_foot=feet, stance=np.array([False, True, True, True]))
    mem = FootholdMemory(np.full(4, np.nan), np.array([[0.5, 0.15, -0.2]] + [[np.nan] * 3] * 3), np.zeros(4))
    last = FootholdDecision(np.zeros((0, 3)), (), None, 0.0, mem)
    _, toward = footholds_plane(view, last)
    _, held = footholds_plane(view, last, touchdowns=False)
    assert toward < -0.05  # the plane tips toward the touchdown below
    assert held == pytest.approx(0.0, abs=1e-12)  # the foot counted at its last stance height, not in the air
    params = dataclass_replace(P, max_pitch_rate_rps=100.0, posture="plane", plane_touchdowns=False)
    d = decide(view, _world(*_stones()), last, params)
    assert d.body_pitch_rad == pytest.approx(0.0, abs=1e-9)


def test_the_shin_term_of_the_region_cost_and_the_cell_it_chooses() -> None:
    """shin_cell_cost: 0 where the shin clears within reach, the cost elsewhere; shin_choice: the cell of least
    cost with it when that one clears, none when the cell of least cost does not clear, the kept cell while it
    clears and costs at most keep_m more, and in the air only the kept cell (while it clears or cleared)."""
    clear = np.array([0.2, 0.05, np.inf, -np.inf, 0.1])
    within = np.array([True, True, True, True, False])
    np.testing.assert_array_equal(shin_cell_cost(clear, within, 0.1, 0.5), [0.0, 0.5, 0.0, 0.5, 0.5])
    base = np.array([0.0, 0.1, 0.3])
    assert shin_choice(base, np.array([0.5, 0.5, 0.0]), None, 0.05) == 2
    # the shin term smaller than the way to the clearing cell: no change
    assert shin_choice(base, np.array([0.2, 0.2, 0.0]), None, 0.05) == -1
    assert shin_choice(np.zeros(0), np.zeros(0), None, 0.05) == -1
    # the kept cell: while it clears and costs at most keep_m more
    near = np.array([0.1, 0.12, 0.5])
    assert shin_choice(near, np.zeros(3), 1, 0.05) == 1
    assert shin_choice(near, np.zeros(3), 2, 0.05) == 0
    assert shin_choice(near, np.array([0.0, 0.5, 0.0]), 1, 0.05) == 0
    # in the air: the kept cell or nothing
    assert shin_choice(near, np.zeros(3), 2, 0.05, flying=True) == 2
    assert shin_choice(near, np.array([0.0, 0.0, 0.5]), 2, 0.05, flying=True) == -1
    assert shin_choice(near, np.array([0.0, 0.0, 0.5]), 2, 0.05, flying=True, kept_ok=True) == 2
    assert shin_choice(near, np.zeros(3), None, 0.05, flying=True) == -1


def test_a_foothold_past_a_low_box_whose_shin_meets_its_edge_is_held_on_the_boxs_top() -> None:
    """shin_cost_region (DecisionParams.shin_region_cost_m): a front foot's nominal 10-15 cm past a low box (9 cm
    tall, 15 cm along the heading), its hip over the box's near half (a long step: clutter draws 544, 617): no
    place of the floor past the box clears the shin within reach, so the foothold is held on the box's top,
    where it clears; off, or with the hip over the floor past the box, or on flat ground, nothing changes; with
    a shin term too small to pay the way back to the box, nothing changes either."""
    world = _box_world(0.70, 0.85, -0.7, 0.7, 0.09)
    regions, maps = world.regions, world.maps
    box = regions.label_at(0.78, 0.1)
    past = regions.label_at(1.0, 0.1)
    assert box and past and box != past != regions.label_at(0.5, 0.1)
    view = _spot_leg_view(0.45)
    on = dataclasses.replace(P_LINE, shin_region_cost_m=0.5)
    for hip_x, nom_x in ((0.70, 0.95), (0.72, 0.98), (0.75, 1.0)):
        hip, nom = np.array([hip_x, 0.1]), np.array([nom_x, 0.1])
        poly = convex_around(regions, past, nom, P.window_m)
        assert poly is not None
        assert not leg_bounds_found(view, maps, 0, hip, nom, poly, on)[1]
        label, q, hold = shin_cost_region(view, world, 0, hip, nom, 0.0, None, False, None, past, poly, on)
        assert label == box and hold is not None and q is not poly
        assert 0.70 < hold[0] < 0.85 and hold[2] == pytest.approx(0.09, abs=0.01)
        clear, within = leg_clearance(view, maps, 0, hip, hold[None, :2], on)
        assert within[0] and clear[0] >= shin_needed(on)
        # off: the floor past the box, no hold
        assert shin_cost_region(view, world, 0, hip, nom, 0.0, None, False, None, past, poly, P_LINE) == (
            past,
            poly,
            None,
        )
        # a shin term smaller than the way back onto the box: no change
        small = dataclasses.replace(on, shin_region_cost_m=0.05)
        assert (
            shin_cost_region(view, world, 0, hip, nom, 0.0, None, False, None, past, poly, small)[2] is None
        )
        # in the air with no choice that cleared: no change; with the box's top chosen before: kept
        assert shin_cost_region(view, world, 0, hip, nom, 0.0, None, True, None, past, poly, on)[2] is None
        kept = shin_cost_region(
            view, world, 0, hip, nom, 0.0, hold[:2], True, None, past, poly, on, None, True
        )
        assert kept[0] == box and kept[2] is not None
        np.testing.assert_allclose(kept[2][:2], hold[:2])
    # the hip over the floor past the box: a place there clears, nothing changes
    nom = np.array([1.0, 0.1])
    poly = convex_around(regions, past, nom, P.window_m)
    assert poly is not None
    out = shin_cost_region(view, world, 0, np.array([0.9, 0.1]), nom, 0.0, None, False, None, past, poly, on)
    assert out == (past, poly, None)
    # flat ground: nothing changes
    flat = _box_world(5.0, 5.1, 5.0, 5.1, 0.09)
    for hip_x, nom_x in ((0.7, 1.0), (0.9, 1.0), (1.1, 1.0)):
        nom = np.array([nom_x, 0.1])
        label = flat.regions.label_at(*nom)
        poly = convex_around(flat.regions, label, nom, P.window_m)
        assert poly is not None
        out = shin_cost_region(
            view, flat, 0, np.array([hip_x, 0.1]), nom, 0.0, None, False, None, label, poly, on
        )
        assert out == (label, poly, None)


def test_the_shin_region_cost_holds_a_foot_stepping_down_on_the_landing_and_leaves_flat_footholds() -> None:
    """On a descent (the landing, then treads 0.15 m lower) a front foot's nominal on the tread below with its hip
    well behind the nosing: no place of the tread clears, and the rule holds the foot on the landing, where it
    clears (the stairs are where the rule acts besides the boxes); with the hip over the tread nothing changes.
    choose_footholds on flat ground: the same footholds with the rule on as off."""
    world = _steps_down()
    maps, regions = world.maps, world.regions
    nom = np.array([1.08, 0.1])
    on = dataclasses.replace(P_LINE, shin_region_cost_m=0.5)
    tread = regions.label_at(1.15, 0.1)
    landing = regions.label_at(0.6, 0.1)
    poly = convex_around(regions, tread, nom, P.window_m)
    assert poly is not None
    behind = _leg_view(0.5, 0.6)
    hip_behind = np.array([0.8, 0.1])
    label, _, hold = shin_cost_region(
        behind, world, 0, hip_behind, nom, 0.6, None, False, None, tread, poly, on
    )
    assert label == landing and hold is not None and hold[0] < 1.0
    clear, within = leg_clearance(behind, maps, 0, hip_behind, hold[None, :2], on)
    assert within[0] and clear[0] >= shin_needed(on)
    over = _leg_view(0.85, 0.6)
    out = shin_cost_region(
        over, world, 0, np.array([1.15, 0.1]), nom, 0.6, None, False, None, tread, poly, on
    )
    assert out == (tread, poly, None)
    # flat ground, the whole decision: the same footholds
    flat = _world(*_flat_grid())
    feet_x = np.array([0.45, 0.45, -0.15, -0.15])
    view = dataclass_replace(
        _view(np.zeros(4), feet_x), l_upper_m=0.32, l_lower_m=0.34, stance=np.array([False, True, True, True])
    )
    path = _trot_path(feet_x, np.array([0.55, 0.5, -0.1, -0.05]))
    qp_off = StepQP(dataclass_replace(StepQPParams(), keep_planes=14, max_iter=400))
    qp_on = StepQP(dataclass_replace(StepQPParams(), keep_planes=14, max_iter=400))
    d_off = choose_footholds(view, path, flat, FootholdMemory.empty(), qp_off, P_LINE)
    d_on = choose_footholds(view, path, flat, FootholdMemory.empty(), qp_on, on)
    np.testing.assert_array_equal(d_on.p_world_touchdown, d_off.p_world_touchdown)


def _flat_grid() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    xs = -0.6 + np.arange(80) * RES
    ys = -0.9 + np.arange(60) * RES
    return xs, ys, np.zeros((80, 60))


class _FlipQP:
    """A step QP whose answer moves one leg's first slot sideways by dy (m): a late flip, as an answer with a hard
    family softened gives (sound: the answer reports itself solved with nothing softened)."""

    def __init__(self, qp: StepQP, leg: int, dy: float, sound: bool = False) -> None:
        self.qp, self.leg, self.dy, self.sound = qp, leg, dy, sound
        self.K = qp.K

    def solve(self, req, maps, rows):  # type: ignore[no-untyped-def]
        plan = self.qp.solve(req, maps, rows)
        feet = plan.footholds.copy()
        feet[int(np.flatnonzero(plan.legs == self.leg)[0]), 1] += self.dy
        soft = () if self.sound else ("reach_rect",)
        return dataclasses.replace(plan, footholds=feet, hard_softened=soft, softened=soft)


def test_a_late_jump_of_the_step_qps_answer_keeps_the_foothold_chosen_before() -> None:
    """The pit world (x 0.6-1.6; FR's nominal mid-pit, so the step QP is solved): an unsound step QP answer (a hard
    family softened) that moves a touchdown due within late_jump_s by more than late_jump_m keeps the foothold
    chosen before (the swing could not follow it); a sound answer, a small move, a touchdown due later and one
    whose kept foothold lies on no polygon take the new answer, and so does every touchdown with the rule off."""
    xs = -0.6 + np.arange(110) * RES
    ys = -0.9 + np.arange(60) * RES
    X = np.broadcast_to(xs[:, None], (110, 60))
    world = _world(xs, ys, np.asarray(np.where((X < 0.6) | (X > 1.6), 0.0, -0.3), dtype=np.float64))
    feet_x = np.array([0.45, 0.45, -0.15, -0.15])
    view = dataclass_replace(_view(np.zeros(4), feet_x), stance=np.array([False, True, True, True]))
    path = _trot_path(feet_x, np.array([0.5, 1.1, -0.1, -0.1]))
    qp = StepQP(dataclass_replace(StepQPParams(), keep_planes=14, max_iter=400))
    assert P.late_jump_s is not None and P.late_jump_s > 0.1  # FL's touchdown, 0.1 s ahead, is a late one

    def memory(leg: int, xy: tuple[float, float]) -> FootholdMemory:
        k = int(np.flatnonzero(path.leg == leg)[0])
        chosen = np.full((4, 3), np.nan)
        chosen[leg] = [xy[0], xy[1], 0.0]
        t_mem = np.full(4, np.nan)
        t_mem[leg] = float(path.t_touchdown[k])
        return FootholdMemory(t_mem, chosen, np.zeros(4), np.ones(4, dtype=bool))

    k_fl = int(np.flatnonzero(path.leg == 0)[0])
    fresh = choose_footholds(view, path, world, memory(0, (0.5, 0.15)), qp, P)
    assert fresh.plan is not None and abs(fresh.p_world_touchdown[k_fl, 1] - 0.15) < 0.02
    # FL (due in 0.1 s) flipped 0.4 m across: held where it was chosen, and counted
    flip = _FlipQP(qp, 0, -0.4)
    held = choose_footholds(view, path, world, memory(0, (0.5, 0.15)), flip, P)
    np.testing.assert_allclose(held.p_world_touchdown[k_fl, :2], [0.5, 0.15], atol=1e-9)
    assert held.late_holds == 1
    # the rule off: the flipped answer is taken
    off = choose_footholds(
        view, path, world, memory(0, (0.5, 0.15)), flip, dataclasses.replace(P, late_jump_s=None)
    )
    assert off.p_world_touchdown[k_fl, 1] < -0.2 and off.late_holds == 0
    # a sound answer is taken however far it moves (a region switch late in a swing)
    sound = choose_footholds(view, path, world, memory(0, (0.5, 0.15)), _FlipQP(qp, 0, -0.4, sound=True), P)
    assert sound.p_world_touchdown[k_fl, 1] < -0.2 and sound.late_holds == 0
    # a small move (below late_jump_m) is taken
    small = choose_footholds(view, path, world, memory(0, (0.5, 0.15)), _FlipQP(qp, 0, -0.05), P)
    assert small.p_world_touchdown[k_fl, 1] < 0.12 and small.late_holds == 0
    # a kept foothold on no polygon (on the platform's edge, inside no inset): the new answer is taken
    moved = choose_footholds(view, path, world, memory(0, (0.6, 0.15)), flip, P)
    assert moved.p_world_touchdown[k_fl, 1] < -0.2 and moved.late_holds == 0
    # RL's touchdown is 0.3 s ahead, beyond late_jump_s: its flip is taken
    k_rl = int(np.flatnonzero(path.leg == 2)[0])
    later = choose_footholds(view, path, world, memory(2, (-0.1, 0.15)), _FlipQP(qp, 2, -0.4), P)
    assert later.p_world_touchdown[k_rl, 1] < -0.2 and later.late_holds == 0


def test_the_body_walks_tall_on_level_ground_and_at_its_standing_height_across_a_step() -> None:
    view = dataclass_replace(
        _view(np.zeros(4), np.array([0.3, 0.3, -0.3, -0.3])), l_upper_m=0.32, l_lower_m=0.34
    )
    p = dataclass_replace(P, level_extension_frac=0.81, level_span_m=0.10)
    tall = view.foot_radius_m + 0.81 * 0.66
    assert level_height(view, None, p) == pytest.approx(tall)
    # the feet 5 cm apart in height: halfway; 10 cm or more (a riser, the platform): the standing height
    for dz, want in ((0.05, (tall + 0.52) / 2), (0.10, 0.52), (0.30, 0.52)):
        v = dataclass_replace(view, p_world_foot=view.p_world_foot + np.array([[0, 0, dz], [0, 0, 0]] * 2))
        assert level_height(v, None, p) == pytest.approx(want), dz
    # a chosen touchdown a riser up counts as a foot there
    swing = dataclass_replace(view, stance=np.array([False, True, True, True]))
    chosen = np.full((4, 3), np.nan)
    chosen[0] = (0.6, 0.15, 0.15)
    last = FootholdDecision(
        np.zeros((0, 3)), (), None, 0.0, FootholdMemory(np.full(4, np.nan), chosen, np.full(4, np.nan))
    )
    assert level_height(swing, last, p) == pytest.approx(0.52)
    assert level_height(swing, None, p) == pytest.approx(tall)
    # never below the standing height; off: the standing height
    assert level_height(view, None, dataclass_replace(p, level_extension_frac=0.5)) == pytest.approx(0.52)
    assert level_height(view, None, dataclass_replace(p, level_extension_frac=None)) == pytest.approx(0.52)
    # the decision's height on level ground is the tall one, with no ceiling to bound it
    world = _world(*_stones())
    d = decide(view, world, None, dataclass_replace(p, max_pitch_rate_rps=100.0, posture="plane"))
    assert d.body_height_m == pytest.approx(
        tall - view.z_contact, abs=1e-6
    )  # as the standing height: the plane at 0


def _line_path(x0: float, x1: float) -> BodyPath:
    x = np.arange(x0, x1 + 1e-9, 0.05)
    return BodyPath(np.column_stack([x, np.zeros_like(x)]), np.zeros_like(x), x - x0, "straight", True, 1.0)


def _ground(f) -> tuple[np.ndarray, np.ndarray, np.ndarray]:  # type: ignore[no-untyped-def]
    xs = -0.6 + np.arange(160) * RES
    ys = -0.9 + np.arange(60) * RES
    return xs, ys, np.asarray(f(np.broadcast_to(xs[:, None], (160, 60))), dtype=np.float64)


LEG = 0.66  # thigh + shank (m); a descent edge falls 0.2 of it, 0.132 m


def test_a_descent_edge_is_a_riser_down_with_lower_ground_past_it_not_a_pit_a_slope_or_a_low_step() -> None:
    """Along a straight path from x 0: stairs down from x 1.0 (0.15 m risers, 0.30 m treads) have descent edges; the
    gap between two stones (0.3 m deep, 0.25 m wide: the ground comes back up), a 20° slope down and a 6 cm step
    down have none; the window [s0, s1] bounds where an edge may lie; on the feet's lines, a slot under the centre
    line between stones is none."""
    path = _line_path(0.0, 3.5)
    pb = dataclasses.replace(P, back_drop_frac=BACK_DROP_FRAC)
    stairs = _world(*_ground(lambda X: -0.15 * np.clip(np.floor((X - 1.0) / 0.3) + 1, 0, 5)))
    assert descent_edges(stairs.maps, path, 0.4, 1.1, pb, LEG)
    assert not descent_edges(stairs.maps, path, 0.0, 0.8, pb, LEG)  # the first edge is at 1.0
    # an edge inside the window is found wherever the window's ends fall between the map's cells (a window's
    # samples once fell one short of the fall's far side, and the edge flipped in and out with a millimetre)
    for shift in np.linspace(0.0, 0.03, 31):
        assert descent_edges(stairs.maps, path, 0.7 + shift, 1.05 + shift, pb, LEG), shift
    pit = _world(*_ground(lambda X: np.where((X > 1.0) & (X < 1.25), -0.3, 0.0)))
    assert not descent_edges(pit.maps, path, 0.0, 2.0, pb, LEG)
    slope = _world(*_ground(lambda X: -math.tan(math.radians(20.0)) * np.maximum(X - 1.0, 0.0)))
    assert not descent_edges(slope.maps, path, 0.0, 2.0, pb, LEG)
    low = _world(*_ground(lambda X: np.where(X > 1.0, -0.06, 0.0)))
    assert not descent_edges(low.maps, path, 0.0, 2.0, pb, LEG)
    assert descent_edges(low.maps, path, 0.0, 2.0, dataclasses.replace(pb, back_drop_frac=0.05), LEG)
    # read on the feet's lines (0.165 m either side): stepping stones in a pit from x 1.0 with a slot 8 cm wide
    # down to the pit's floor under the path's centre line (the mixed family's stone field) have none; the stairs
    # still do
    xs, ys, flat = _ground(lambda X: np.zeros_like(X))
    X, Y = np.meshgrid(xs, ys, indexing="ij")
    slot = _world(xs, ys, np.where((X > 1.0) & (np.abs(Y) < 0.04), -0.3, flat))
    assert descent_edges(slot.maps, path, 0.0, 2.0, pb, LEG)  # on the centre line alone
    assert not descent_edges(slot.maps, path, 0.0, 2.0, pb, LEG, 0.165)
    assert descent_edges(stairs.maps, path, 0.4, 1.1, pb, LEG, 0.165)
    assert not descent_edges(stairs.maps, path, 0.0, 0.8, pb, LEG, 0.165)


def test_a_turn_round_needs_room_for_the_footprint_on_one_way_round() -> None:
    """Circles of 0.17 m at -0.5, 0 and 0.3 m along the body (a rear that reaches farther), 0.06 m margin, a turn from
    yaw 0 to pi: on open floor either way (+1 or -1); a wall 0.62 m to the left lets the rear pass only turning
    counterclockwise (the rear swings right); walls 0.62 m on both sides: no way round; at 1 m: room."""
    xs, ys, h = _ground(lambda X: np.zeros_like(X))
    view = dataclass_replace(_view(np.zeros(4), np.array([0.3, 0.3, -0.3, -0.3])), z_contact=0.0)
    Y = np.broadcast_to(ys[None, :], h.shape)
    circles = (-0.5, 0.0, 0.3)

    def maps_with(wall: np.ndarray):  # type: ignore[no-untyped-def]
        return maps_from_grids((xs[0], ys[0]), RES, h, wall, wall)

    assert turn_room(view, maps_with(np.zeros(h.shape, bool)), math.pi, circles, 0.17, 0.06) in (1, -1)
    assert turn_room(view, maps_with(Y > 0.62), math.pi, circles, 0.17, 0.06) == 1
    assert turn_room(view, maps_with(Y < -0.62), math.pi, circles, 0.17, 0.06) == -1
    assert turn_room(view, maps_with(np.abs(Y) > 0.62), math.pi, circles, 0.17, 0.06) == 0
    assert turn_room(view, maps_with(np.abs(Y) > 1.0), math.pi, circles, 0.17, 0.06) != 0


def test_a_walk_to_a_goal_turns_round_in_place_before_a_descent_and_goes_down_backward() -> None:
    """Stairs down from x 1.0 (0.15 m risers, edges at 1.0-1.9) on the way to a goal at x 3.2: 0.5 m before the first
    edge the body, facing forward, turns "back": in place (no speed, a yaw rate); facing back it walks backward
    along its path; back_behind_m past the last edge it turns "round" (in place), and "forward" once within turn_rad
    of its way; with the rule off, with a wall beside it, or on the flat before the stairs, it walks on forward."""
    xs, ys, h = _ground(lambda X: -0.15 * np.clip(np.floor((X - 1.0) / 0.3) + 1, 0, 4))
    world = _world(xs, ys, h)
    legs = {"l_upper_m": 0.32, "l_lower_m": 0.34}
    path = _line_path(0.0, 3.2)

    def view_at(x: float, yaw: float) -> TerrainView:
        z = float(world.maps.height_at(x, 0.0))
        v = _view(np.full(4, z), x + np.array([0.3, 0.3, -0.3, -0.3]), goal=np.array([3.2, 0.0]))
        return dataclass_replace(
            v, p_world_body=np.array([x, 0.0, z + 0.55]), yaw=yaw, z_contact=z + 0.02, **legs
        )

    p = dataclasses.replace(P, back_drop_frac=BACK_DROP_FRAC)
    maps = world.maps
    assert next_facing(view_at(0.1, 0.0), maps, path, "forward", p) == "forward"  # the edge 0.9 m ahead
    assert next_facing(view_at(0.5, 0.0), maps, path, "forward", p) == "back"
    assert (
        next_facing(view_at(0.7, 0.0), maps, path, "forward", p) == "forward"
    )  # 0.3 m from the edge: too near
    turn = follow_path(view_at(0.5, 0.0), path, 0.5, p, "back", maps)
    assert turn.vx == 0.0 and turn.vy == 0.0 and abs(turn.yaw_rate) > 0.0
    down = follow_path(view_at(1.4, math.pi), path, 0.5, p, "back")
    assert down.vx < -0.1 and abs(down.yaw_rate) < 1e-6
    # past the last edge (x 1.9) by more than back_behind_m: round, in place, until it faces its way again
    after = 1.9 + p.back_behind_m
    assert next_facing(view_at(after - 0.1, math.pi), maps, path, "back", p) == "back"
    assert next_facing(view_at(after + 0.05, math.pi), maps, path, "back", p) == "round"
    assert follow_path(view_at(after + 0.05, math.pi), path, 0.5, p, "round").vx == 0.0
    assert next_facing(view_at(after + 0.05, math.pi), maps, path, "round", p) == "round"
    assert next_facing(view_at(after + 0.05, 0.1), maps, path, "round", p) == "forward"
    # already on the flight (an edge behind its centre), it does not turn there, also on a path planned from the
    # body (what lies behind it is not on the path); walking backward, it keeps backward until well past the edge
    assert next_facing(view_at(1.2, 0.0), maps, path, "forward", p) == "forward"
    assert next_facing(view_at(1.2, 0.0), maps, _line_path(1.2, 3.2), "forward", p) == "forward"
    assert next_facing(view_at(2.1, math.pi), maps, _line_path(2.1, 3.2), "back", p) == "back"
    # climbing a tread up to a short landing: the far edge ahead, but the body not on level ground
    up = _world(*_ground(lambda X: np.where(X < 0.0, -0.15, np.where(X < 0.5, 0.0, -0.15))))
    assert (
        next_facing(dataclass_replace(view_at(0.1, 0.0), z_contact=-0.05), up.maps, path, "forward", p)
        == "forward"
    )
    # the feet's circle (Spot's: 0.34 m + the foot) on the top: on a top 1.1 m long (x -0.1-1.0, a tread 0.15 m
    # below before it), centred 0.5 m before its edge, the body turns; on a top 0.8 m long it reaches off its
    # back, and the body walks on forward
    spot_legs = dict(p_body_hip=np.array([[0.3, 0.055], [0.3, -0.055], [-0.3, 0.055], [-0.3, -0.055]]),
                     abd_offset_m=np.array([0.11, -0.11, 0.11, -0.11]))  # fmt: skip
    at = dataclass_replace(view_at(0.5, 0.0), **spot_legs)
    assert next_facing(at, maps, path, "forward", p) == "back"
    long_top = _world(*_ground(lambda X: np.where(X < -0.1, -0.15, np.where(X < 1.0, 0.0, -0.15))))
    assert next_facing(at, long_top.maps, path, "forward", p) == "back"
    short_top = _world(*_ground(lambda X: np.where(X < -0.1, -0.15, np.where(X < 0.7, 0.0, -0.15))))
    on_short = dataclass_replace(at, p_world_body=np.array([0.2, 0.0, 0.55]))
    assert next_facing(on_short, short_top.maps, path, "forward", p) == "forward"
    assert feet_turn_level(at, long_top.maps, 0.066) and not feet_turn_level(on_short, short_top.maps, 0.066)
    # the hind feet measured a tread below the front ones (the map behind the body unseen, level): no turn
    hind_low = dataclass_replace(
        at, p_world_foot=at.p_world_foot - np.array([0.0, 0.0, 0.15]) * [[0], [0], [1], [1]]
    )
    assert next_facing(hind_low, maps, path, "forward", p) == "forward"
    # a swinging foot high in the air does not count (only the feet down); one hind foot down a tread below does
    swinging = dataclass_replace(
        at, p_world_foot=at.p_world_foot + np.array([0.0, 0.0, 0.12]) * [[0], [0], [1], [0]],
        stance=np.array([True, True, False, True]),
    )  # fmt: skip
    assert next_facing(swinging, maps, path, "forward", p) == "back"
    assert not stance_feet_level(dataclass_replace(swinging, stance=np.ones(4, dtype=bool)), 0.066)
    one_low = dataclass_replace(hind_low, stance=np.array([True, True, False, True]))
    assert next_facing(one_low, maps, path, "forward", p) == "forward"
    assert not stance_feet_level(dataclass_replace(at, stance=np.array([True, False, False, False])), 0.066)
    # facing forward, the way the body goes backward (a path that turns back) is no descent walked backward
    assert next_facing(view_at(after + 0.05, math.pi), maps, path, "forward", p) == "forward"
    off = dataclasses.replace(p, back_drop_frac=None)
    assert next_facing(view_at(0.5, 0.0), maps, path, "forward", off) == "forward"
    assert follow_path(view_at(0.5, 0.0), path, 0.5, off).vx > 0.1
    Y = np.broadcast_to(ys[None, :], h.shape)
    side = (Y > 0.45) & (np.broadcast_to(xs[:, None], h.shape) < 1.0)
    walled = maps_from_grids((xs[0], ys[0]), RES, np.where(side, 0.9, h), side, side)
    assert next_facing(view_at(0.5, 0.0), walled, path, "forward", p) == "forward"


def test_a_foot_in_the_air_keeps_the_piece_of_the_floor_it_was_headed_for() -> None:
    """The floor with a box on it (x 0.40-0.55, y -0.05-0.45, 0.2 m high) across FL's line: one floor region (it goes
    round the box's ends) of convex pieces before and past the box. FL in the air was headed for the piece before it (kept at x 0.35); its
    nominal now lies past the box (x 0.68, as a selection flickering across the box gives): it keeps the piece
    before the box and lands by its far edge, not 0.3 m on. In stance, or due later than flight_piece_s, the nominal's
    piece is taken."""
    xs = -0.6 + np.arange(80) * RES
    ys = -0.9 + np.arange(60) * RES
    X = np.broadcast_to(xs[:, None], (80, 60))
    Y = np.broadcast_to(ys[None, :], (80, 60))
    box = (X > 0.40) & (X < 0.55) & (Y > -0.05) & (Y < 0.45)
    world = _world(xs, ys, np.asarray(np.where(box, 0.2, 0.0), dtype=np.float64))
    floor = world.regions.label_at(0.3, 0.15)
    assert floor and world.regions.label_at(0.7, 0.15) == floor and world.regions.label_at(0.5, 0.15) != floor
    feet_x = np.array([0.2, 0.3, -0.15, -0.15])
    air = dataclass_replace(_view(np.zeros(4), feet_x), stance=np.array([False, True, True, True]))
    path = _trot_path(feet_x, np.array([0.68, 0.3, -0.1, -0.1]))
    k_fl = int(np.flatnonzero(path.leg == 0)[0])

    def kept(x: float, z: float = 0.0) -> FootholdMemory:
        chosen = np.full((4, 3), np.nan)
        chosen[0] = [x, 0.15, z]
        t_mem = np.full(4, np.nan)
        t_mem[0] = float(path.t_touchdown[k_fl])
        return FootholdMemory(t_mem, chosen, np.zeros(4), np.ones(4, dtype=bool))

    def fl_x(view: TerrainView, memory: FootholdMemory, p: DecisionParams) -> float:
        qp = StepQP(dataclass_replace(StepQPParams(), keep_planes=14, max_iter=400))
        return float(choose_footholds(view, path, world, memory, qp, p).p_world_touchdown[k_fl, 0])

    # in the air, headed for the piece before the box: by its far edge (the box at 0.40, the inset 4 cm)
    assert 0.3 < fl_x(air, kept(0.35), P) < 0.37
    # the nominal's piece past the box: with the rule off, in stance, and headed past the box already
    assert P.flight_piece_s > 0.1  # FL is due in 0.1 s
    assert fl_x(air, kept(0.35), dataclasses.replace(P, flight_piece_s=0.05)) > 0.58
    assert fl_x(dataclass_replace(air, stance=np.ones(4, bool)), kept(0.35), P) > 0.58
    assert fl_x(air, kept(0.7), P) > 0.58
