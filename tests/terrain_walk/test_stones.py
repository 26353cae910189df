"""Stepping stones: the step QP's foothold snapping along the heading onto the nearer stone (an option of the step
QP; the terrain pipeline constrains footholds to their regions instead), and the closed-loop crossings with the
depth sensor on the terrain pipeline, as a rate.
"""

from __future__ import annotations

import numpy as np
import pytest
from terrain_rates import crossings

from planning.sim.run import RunOptions, WalkCommand
from planning.terrain.bodypath import plan_body_path
from planning.terrain.cadence import CADENCES, CadenceParams, make_request
from planning.terrain.maps import TerrainMaps, maps_from_grids
from planning.terrain.stepqp import StepQP, StepQPParams, snap_footholds

RES = 0.03
CLEAR = 0.06


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


# (gaps m, stone depths m, stone widths m, top jitter m, scene seed): draws of sweeps/family-stones.yaml
STONES_DRAWS = [
    ("0.25..0.3", "0.3..0.4", "0.4..0.5", 0.0027, 234),
    ("0.2..0.25", "0.35..0.45", "0.4..0.5", 0.0219, 813),
    ("0.25..0.3", "0.3..0.4", "0.4..0.5", 0.0222, 169),
    ("0.15..0.2", "0.25..0.35", "0.4..0.5", 0.0137, 506),
]
MIN_STONES_CROSSED = 2


@pytest.mark.sim
def test_stones_crossings_with_the_sensor_at_a_rate() -> None:
    """Four stepping-stone fields of the family (gaps 0.15-0.30 m, tops jittered up to 2.2 cm) walked to the
    terrain's goal with the depth sensor: at least MIN_STONES_CROSSED cross clean (no fall, no body collision,
    crossed, the goal reached, no landing in a no-step place). Measured 2026-11-27 on this project's 2-core machine: 3
    of 4 (seeds 234, 813, 169 crossed at 28.7 s; 506, clean in the family sweep, fell at 15.0 s: a front lower leg
    on a stone); about 32 s of CPU each."""
    from planning.terrain.spec import load_terrain

    variants = []
    for gap, depth, width, jitter, seed in STONES_DRAWS:
        terrain = f"stones:gap_m={gap},stone_depth_m={depth},stone_width_m={width},jitter_z_m={jitter}"
        goal = load_terrain(terrain, seed=seed).goal_xy
        cmd = WalkCommand(goal=(float(goal[0]), float(goal[1])), terrain_sensor=True, stop_at_goal=True)
        variants.append((f"stones seed {seed}", cmd, RunOptions(terrain=terrain, seed=seed, duration_s=35.0)))
    n, outcome, _ = crossings(variants, max_no_step=0, needed=MIN_STONES_CROSSED)
    assert n >= MIN_STONES_CROSSED, outcome
