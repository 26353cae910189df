"""Stepping stones: the pit detection that switches the stones mode on, foothold snapping along the heading onto
the nearer stone, the snapped footholds pinned over the QP's answer, the maps' stones rules, and the closed-loop
crossings (seed 0) on the scene's ground-truth maps and with the depth sensor.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from terrain_rates import crossings

from planning.sim.run import RunOptions, WalkCommand
from planning.terrain.bodypath import plan_body_path
from planning.terrain.cadence import CADENCES, CadenceParams, make_request
from planning.terrain.maps import MapParams, TerrainMaps, build_maps, maps_from_grids, maps_from_scene
from planning.terrain.navigate import NavigatorParams, StonesMode, TerrainNavigator, pit_between
from planning.terrain.scenes import build_terrain
from planning.terrain.stepqp import StepQP, StepQPParams, StepRequest, snap_footholds
from planning.terrain.voxels import Columns

RES = 0.03
CLEAR = 0.06
MODE = StonesMode()


def _detect(h: np.ndarray, z_feet: float = 0.0) -> bool:
    return pit_between(np.stack([h, h]), z_feet, MODE.drop_m, MODE.return_m)


def test_a_pit_between_stones_switches_the_mode_on() -> None:
    d = np.arange(-0.5, 1.0 + 1e-9, RES)
    pit = np.where((d > 0.4) & (d < 0.65), -0.3, 0.0)
    assert _detect(pit)
    # Standing on a stone jittered 1.5 cm up, the next one 1.5 cm down: still a pit.
    assert _detect(pit + np.where(d > 0.65, -0.015, 0.015), z_feet=0.015)
    # A shallow dip (a 10 cm trench) is ground to step in, not a pit.
    assert not _detect(np.where((d > 0.4) & (d < 0.65), -0.10, 0.0))
    # Unknown cells (NaN) are neither ground nor pit.
    assert not _detect(np.where((d > 0.4) & (d < 0.65), np.nan, 0.0))


@pytest.mark.parametrize("kind", ["flat", "box", "stairs_up", "stairs_down", "drop", "landing_up"])
def test_flat_boxes_and_stairs_do_not_switch_the_mode_on(kind: str) -> None:
    d = np.arange(-0.5, 1.0 + 1e-9, RES)
    steps = np.floor(np.clip(d - 0.1, 0.0, None) / 0.3)
    h, z_feet = {
        "flat": (np.zeros_like(d), 0.0),
        "box": (np.where((d > 0.3) & (d < 0.6), 0.3, 0.0), 0.0),
        "stairs_up": (0.15 * steps, 0.0),
        "stairs_down": (-0.15 * steps, 0.0),
        "drop": (np.where(d > 0.4, -0.3, 0.0), 0.0),
        # Climbing: the rear feet one riser below, the ground behind them lower still.
        "landing_up": (0.15 * np.floor((d + 0.5) / 0.3), 0.45),
    }[kind]
    assert not _detect(h, z_feet)


def _lines(scene: str, xy: tuple[float, float], seed: int = 0) -> np.ndarray:
    maps = maps_from_scene(build_terrain(scene, seed=seed), xy, 2.0, params=NavigatorParams().perception.maps)
    d = np.arange(-MODE.behind_m, MODE.ahead_m + 1e-9, maps.resolution_m)
    return np.stack([maps.height_at(xy[0] + d, np.full_like(d, xy[1] + y)) for y in (-0.165, 0.165)])


def test_detection_on_the_scenes_maps() -> None:
    # Stones: on from the start platform once a gap and the stone behind it are in the window, and on a stone.
    assert pit_between(_lines("stones", (0.5, 0.0)), 0.0, MODE.drop_m, MODE.return_m)
    assert pit_between(_lines("stones", (2.0, 0.0)), 0.0, MODE.drop_m, MODE.return_m)
    assert not pit_between(_lines("stones", (-1.0, 0.0)), 0.0, MODE.drop_m, MODE.return_m)
    # Stairs, up and down the flight (feet on the tread under the body), and clutter: never.
    stairs = build_terrain("stairs")
    for x in np.arange(0.0, 4.5, 0.25):
        h = _lines("stairs", (float(x), 0.0))
        z = float(stairs.ground_height(np.array([x]), np.array([0.165]))[0])
        assert not pit_between(h, z, MODE.drop_m, MODE.return_m), x
    for x in np.arange(0.0, 5.0, 0.5):
        assert not pit_between(_lines("clutter", (float(x), 0.0)), 0.0, MODE.drop_m, MODE.return_m), x


def stones_maps(gaps: list[tuple[float, float]]) -> TerrainMaps:
    """Flat ground from x = -1 to 3.5 m, no-step strips (gaps, m along x) across it."""
    xs = -1.0 + np.arange(150) * RES
    ys = -1.5 + np.arange(100) * RES
    X, _ = np.meshgrid(xs, ys, indexing="ij")
    step = np.zeros(X.shape, dtype=bool)
    for x0, x1 in gaps:
        step |= (X >= x0) & (X <= x1)
    return maps_from_grids((xs[0], ys[0]), RES, np.zeros(X.shape), step)


def test_snap_moves_a_gap_foothold_onto_the_nearer_stone() -> None:
    maps = stones_maps([(1.0, 1.3)])
    p = np.array([[1.08, 0.15], [1.24, 0.15], [0.5, -0.15], [1.15, -0.15]])
    hip = np.array([[1.0, 0.15], [1.2, 0.15], [0.5, -0.15], [1.15, -0.15]])
    out, moved = snap_footholds(maps, p, np.zeros(4), hip, (0.3, 0.3), 0.45, CLEAR)
    assert moved.tolist() == [True, True, False, True]
    sd = np.asarray(maps.sdf_step(out[:, 0], out[:, 1]))
    assert np.all(sd >= CLEAR - 1e-9)
    assert out[0, 0] < 1.0 and out[1, 0] > 1.3  # back onto the current stone, across onto the next one
    np.testing.assert_allclose(out[:, 1], p[:, 1])  # only along the heading
    np.testing.assert_allclose(out[2], p[2])  # on a stone already: untouched


def test_snap_stays_within_the_hip_range_and_holds_a_swing_side() -> None:
    maps = stones_maps([(1.0, 1.3)])
    p = np.array([[1.24, 0.15]])
    # The nearer side (forward, across) lies beyond 0.2 m ahead of a hip at x = 1.1: back onto the current stone.
    out, moved = snap_footholds(maps, p, np.zeros(1), np.array([[1.1, 0.15]]), (0.3, 0.2), 0.45, CLEAR)
    assert moved[0] and out[0, 0] < 1.0
    # A swing sent back before keeps going back although forward is nearer now.
    out2, _ = snap_footholds(maps, p, np.zeros(1), np.array([[1.2, 0.15]]), (0.3, 0.3), 0.45, CLEAR, [out[0]])
    assert out2[0, 0] < 1.0
    out3, _ = snap_footholds(maps, p, np.zeros(1), np.array([[1.2, 0.15]]), (0.3, 0.3), 0.45, CLEAR)
    assert out3[0, 0] > 1.3


def test_snap_spread_sends_front_feet_forward_and_hind_feet_back() -> None:
    maps = stones_maps([(1.0, 1.3)])
    p = np.array([[1.12, 0.15], [1.12, -0.15]])  # in the gap, a bit nearer its back edge
    hip = np.array([[1.15, 0.15], [1.15, -0.15]])
    plain, _ = snap_footholds(maps, p, np.zeros(2), hip, (0.4, 0.4), 0.5, CLEAR)
    assert np.all(plain[:, 0] < 1.0)  # the nearer side: back
    out, moved = snap_footholds(
        maps, p, np.zeros(2), hip, (0.4, 0.4), 0.5, CLEAR, spread_m=np.array([0.08, -0.08])
    )
    assert (
        moved.all() and out[0, 0] > 1.3 and out[1, 0] < 1.0
    )  # a front foot (+) across, a hind foot (-) back
    # The bias only breaks near ties: a foothold right at the gap's back edge still goes back.
    near, _ = snap_footholds(maps, np.array([[1.03, 0.15]]), np.zeros(1), hip[:1], (0.4, 0.4), 0.5, CLEAR,
                             spread_m=np.array([0.08]))  # fmt: skip
    assert near[0, 0] < 1.0


def test_snap_middle_takes_a_narrow_stones_middle() -> None:
    # A 10 cm stone between two gaps: no spot on it has 6 cm of clearance.
    maps = stones_maps([(1.0, 1.3), (1.4, 1.8)])
    assert float(maps.sdf_step(1.35, 0.15)) < CLEAR
    p = np.array([[1.27, 0.15]])
    hip = np.array([[1.3, 0.15]])
    plain, moved = snap_footholds(maps, p, np.zeros(1), hip, (0.4, 0.4), 0.5, CLEAR)
    assert moved[0] and plain[0, 0] < 1.0  # without middle: back past the stone, whose edges are too near
    mid, moved = snap_footholds(maps, p, np.zeros(1), hip, (0.4, 0.4), 0.5, CLEAR, middle=True)
    assert moved[0] and 1.32 <= mid[0, 0] <= 1.38  # the stone's middle
    # On a wide stone the first spot with the full clearance is taken, as without middle.
    wide, _ = snap_footholds(maps, np.array([[1.8, 0.15]]), np.zeros(1), np.array([[1.8, 0.15]]), (0.25, 0.4),
                             0.5, CLEAR, middle=True)  # fmt: skip
    ref, _ = snap_footholds(maps, np.array([[1.8, 0.15]]), np.zeros(1), np.array([[1.8, 0.15]]), (0.25, 0.4),
                            0.5, CLEAR)  # fmt: skip
    np.testing.assert_allclose(wide, ref)


def test_step_qp_with_snapping_lands_gap_footholds_on_stones_and_reports_its_nominals() -> None:
    path = plan_body_path(None, (0.0, 0.0), 0.0, (4.0, 0.0))
    cad = next(c for c in CADENCES if c.name == "medium")
    cp = CadenceParams()
    xy, _ = path.pose_at(0.0)
    req = make_request(cad, path, cp, 8, np.asarray(cp.feet_body_xy) + xy, s_now_m=0.0, phase_s=0.05)
    maps = stones_maps([(0.45 + 0.7 * i, 0.70 + 0.7 * i) for i in range(4)])
    assert np.asarray(maps.no_step(req.p_nominal[:, 0], req.p_nominal[:, 1])).sum() >= 2
    plain = StepQP().solve(req, maps)
    snap = StepQP(StepQPParams(snap_search_m=0.45)).solve(req, maps)
    assert not snap.in_no_step.any()
    assert snap.p_nominal is not None and plain.p_nominal is not None
    np.testing.assert_allclose(plain.p_nominal, req.p_nominal)  # no snapping: the request's nominals
    sd_nom = np.asarray(maps.sdf_step(snap.p_nominal[:, 0], snap.p_nominal[:, 1]))
    assert np.all(sd_nom >= CLEAR - 1e-9)  # the snapped nominals are all on stones with the clearance


def test_pinning_takes_free_snapped_nominals_over_the_qp() -> None:
    nav = object.__new__(TerrainNavigator)  # only the pinning's state: no simulation needed
    nav.params = NavigatorParams(use_sensor=False)
    maps = stones_maps([(1.0, 1.3)])
    plan = StepQP(StepQPParams(snap_search_m=0.45)).solve(
        _request_at(np.array([[1.5, 0.15], [1.1, -0.15], [0.6, 0.15], [0.2, -0.15]])), maps
    )
    assert plan.p_nominal is not None
    nom = plan.p_nominal.copy()
    nom[1] = [1.15, -0.15]  # pretend one nominal is in the gap: that one keeps the QP's answer
    plan = dataclasses.replace(plan, p_nominal=nom)
    out = nav._pin_snapped(plan, maps)
    free = np.asarray(maps.sdf_step(nom[:, 0], nom[:, 1])) >= MODE.pin_min_sdf_m
    assert not free[1] and free.sum() >= 3
    np.testing.assert_allclose(out.footholds[free, :2], nom[free])
    np.testing.assert_allclose(out.footholds[~free], plan.footholds[~free])


def _request_at(p4: np.ndarray) -> StepRequest:
    path = plan_body_path(None, (0.0, 0.0), 0.0, (4.0, 0.0))
    cad = next(c for c in CADENCES if c.name == "medium")
    cp = CadenceParams()
    req = make_request(cad, path, cp, 8, np.asarray(cp.feet_body_xy), s_now_m=0.0, phase_s=0.05)
    p = req.p_nominal.copy()
    p[:4] = p4
    return dataclasses.replace(req, p_nominal=p)


STONES_TRUTH_SEEDS = (0, 1, 2, 3)
MIN_STONES_CROSSED = 1


def test_stones_crossings_on_ground_truth_maps_at_a_rate() -> None:
    """Ground-truth maps (terrain_sensor=False) isolate planning and control from perception: four stone layouts
    (scene seeds 0-3), at least MIN_STONES_CROSSED of them crossed clean (no fall, no body collision, crossed, at
    the goal, at most one landing in a no-step place: a hind foot 2.5 cm from the front edge of the stone behind),
    each in the stones mode for more than 10 s. With the depth sensor the stones cross less often (the shipped sweep
    `footfall sweep sweeps/stones.yaml` measures it; README). Measured 2026-11-26 on this project's 2-core build
    machine: seeds 1 and 2 cross, 0 and 3 fall (2 of 4; 4 of 4 on the machine the stones mode was tuned on)."""
    variants = [
        (
            f"stones seed {seed} (truth)",
            WalkCommand(goal=(6.0, 0.0), terrain_aware=True, terrain_sensor=False, stop_at_goal=True),
            RunOptions(terrain="stones", duration_s=30.0, seed=seed),
        )
        for seed in STONES_TRUTH_SEEDS
    ]
    n, outcome, reports = crossings(variants, max_no_step=1)
    assert n >= MIN_STONES_CROSSED, outcome
    for r, ok in zip(reports, outcome.values(), strict=True):
        if ok is None:
            assert r["navigator"]["stones_mode_s"] > 10.0 and r["navigator"]["stairs_mode_s"] == 0.0


def _stone_columns() -> Columns:
    """A stone (x 0..0.3 m, top 2 cm up) in a pit 31 cm deep (x -0.3..0 and beyond 0.3) after a platform at 0, as
    the sensor sees it: the stone's face toward the platform occupies the pit cell in front of it up to 3 cm."""
    xs = np.arange(-0.6, 0.6 + 1e-9, RES)
    ys = np.arange(-0.45, 0.45 + 1e-9, RES)
    ground = np.full((xs.size, ys.size), -0.31)
    ground[xs < -0.3 - 1e-9] = 0.0
    ground[(xs > 1e-9) & (xs < 0.31)] = 0.02
    z0, nz = -0.99, 90
    zs = z0 + np.arange(nz) * RES
    obstacle = np.zeros((*ground.shape, nz), dtype=bool)
    face = int(np.argmin(np.abs(xs + RES / 2)))
    obstacle[face, :, (zs > -0.3) & (zs < 0.04)] = True
    return Columns((float(xs[0]), float(ys[0])), RES, ground, obstacle, z0, RES)


def test_stones_map_rules_keep_a_stone_steppable_and_its_edge_no_body_obstacle() -> None:
    """Default maps mark a stone standing more than max_step_height_m above the pit beside it no-step and its top
    edge seen from the pit a body obstacle (the body path then veers off the stones); the stones mode's map
    parameters do neither, and the pit and the face stay no-step."""
    cols = _stone_columns()
    default = NavigatorParams().perception.maps
    stones = dataclasses.replace(default, **MODE.maps)
    assert isinstance(stones, MapParams) and stones != default
    x, y = np.array([0.15, -0.15, 0.15]), np.array([0.0, 0.0, 0.3])  # stone middle, pit, stone off the line
    m0, m1 = build_maps(cols, default), build_maps(cols, stones)
    assert bool(m0.no_step(0.15, 0.0)) and bool(np.any(m0.body_obstacle))
    assert not bool(m1.no_step(0.15, 0.0)) and not bool(np.any(m1.body_obstacle))
    assert list(np.asarray(m1.no_step(x, y), dtype=bool)) == [False, True, False]
    assert bool(m1.no_step(-0.015, 0.0))  # the face itself


def test_stones_fill_reads_the_shadow_behind_a_stone_as_pit() -> None:
    """The sensor never sees the pit right behind a stone's far edge; filled from its neighbors that shadow takes
    the stone's height (here a stone 6 cm longer than it is). With fill_low_radius_m it takes the pit's, so the far
    edge is an edge."""
    cols = _stone_columns()
    xs = cols.origin_xy[0] + np.arange(cols.ground_z.shape[0]) * RES
    ground = cols.ground_z.copy()
    ground[(xs > 0.31) & (xs < 0.44)] = np.nan  # the shadow, x 0.33..0.42
    cols = dataclasses.replace(cols, ground_z=ground)
    stones = dataclasses.replace(NavigatorParams().perception.maps, **MODE.maps)
    m0 = build_maps(cols, dataclasses.replace(stones, fill_low_radius_m=None))
    m1 = build_maps(cols, stones)
    assert float(m0.height_at(0.33, 0.0)) > 0.0 and not bool(m0.no_step(0.3, 0.0))
    assert (
        float(m1.height_at(0.33, 0.0)) < -0.25 and bool(m1.no_step(0.33, 0.0)) and bool(m1.no_step(0.3, 0.0))
    )
    assert not bool(m1.no_step(0.15, 0.0))
