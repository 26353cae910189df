"""Body path, cadence choice and the step QP."""

from __future__ import annotations

import numpy as np
import pytest

from planning.terrain.bench import bench_step_qp
from planning.terrain.bodypath import BodyPathParams, plan_body_path, sweep_clearance
from planning.terrain.cadence import CADENCES, CadenceParams, choose_cadence, make_request
from planning.terrain.maps import maps_from_grids, maps_from_scene
from planning.terrain.scenes import build_terrain
from planning.terrain.stepqp import StepQP, StepQPParams

RES = 0.03


def grid(x0: float = -1.0, y0: float = -1.5, nx: int = 150, ny: int = 100) -> tuple[np.ndarray, np.ndarray]:
    return x0 + np.arange(nx) * RES, y0 + np.arange(ny) * RES


def test_body_path_goes_around_the_tall_box() -> None:
    scene = build_terrain("clutter", seed=0)
    maps = maps_from_scene(scene, center_xy=(2.5, 0.0), half_extent_m=2.5)
    path = plan_body_path(maps, (0.0, 0.0), 0.0, (5.0, 0.0))
    assert path.valid and path.min_clearance_m >= 0.0
    assert np.linalg.norm(path.xy[-1] - [5.0, 0.0]) < 1e-6
    assert np.all(np.diff(path.s) > 0)
    assert sweep_clearance(maps, path, BodyPathParams()) >= 0.0
    assert np.max(np.abs(path.xy[:, 1])) > 0.25  # it left the straight line


def test_body_path_falls_back_to_grid_search_in_a_trap() -> None:
    xs, ys = grid()
    X, Y = np.meshgrid(xs, ys, indexing="ij")
    # A U-shaped wall open toward the start: the field walks into the cup and stalls.
    body = ((np.abs(X - 1.5) < 0.06) & (np.abs(Y) < 0.9)) | (
        (np.abs(np.abs(Y) - 0.9) < 0.06) & (X > 0.6) & (X < 1.56)
    )
    maps = maps_from_grids((xs[0], ys[0]), RES, np.zeros(X.shape), body, body)
    path = plan_body_path(maps, (0.0, 0.0), 0.0, (2.8, 0.0))
    assert path.method == "grid"
    assert path.valid
    assert np.linalg.norm(path.xy[-1] - [2.8, 0.0]) < 1e-6


def test_the_grid_search_with_the_footprint_at_each_heading_keeps_its_margin() -> None:
    xs, ys = grid()
    X, Y = np.meshgrid(xs, ys, indexing="ij")
    box = (X > 1.0) & (X < 1.45) & (np.abs(Y) < 0.3)  # a tall box, passed at its corner
    maps = maps_from_grids((xs[0], ys[0]), RES, np.zeros(X.shape), box, box)
    for heading in (False, True):
        p = BodyPathParams(grid_heading=heading, max_iters=0)  # no field: the grid search
        path = plan_body_path(maps, (0.2, -0.1), 0.0, (2.6, -0.2), p)
        assert path.method == "grid" and path.valid
        assert sweep_clearance(maps, path, p) >= (p.grid_clear_m - 0.01 if heading else 0.0)
        assert np.linalg.norm(path.xy[-1] - [2.6, -0.2]) < 1e-6


def test_body_path_rejects_bad_input() -> None:
    with pytest.raises(ValueError, match="finite"):
        plan_body_path(None, (np.nan, 0.0), 0.0, (1.0, 0.0))


def test_cadence_prefers_fast_on_flat_and_avoids_collisions() -> None:
    path = plan_body_path(None, (0.0, 0.0), 0.0, (4.0, 0.0))
    best, scores = choose_cadence(path, None)
    assert best.cadence.name == "fast"
    assert [s.cadence.name for s in scores] == [c.name for c in CADENCES]
    # No-step stripes placed on the fast cadence's footholds: another cadence must win.
    fast = next(s for s in scores if s.cadence.name == "fast")
    xs, ys = grid(nx=200)
    X, Y = np.meshgrid(xs, ys, indexing="ij")
    step = np.zeros(X.shape, dtype=bool)
    for x in fast.footholds[:, 0]:
        step |= np.abs(X - x) < 0.05
    maps = maps_from_grids((xs[0], ys[0]), RES, np.zeros(X.shape), step)
    best2, scores2 = choose_cadence(path, maps)
    fast2 = next(s for s in scores2 if s.cadence.name == "fast")
    assert fast2.collisions > 0
    assert best2.cadence.name != "fast"
    assert best2.collisions < fast2.collisions


def _walk_request(maps, cadence_name: str = "medium", s_now: float = 0.0):
    path = plan_body_path(maps, (0.0, 0.0), 0.0, (4.0, 0.0))
    cp = CadenceParams()
    cad = next(c for c in CADENCES if c.name == cadence_name)
    xy, _ = path.pose_at(s_now)
    feet = np.asarray(cp.feet_body_xy) + xy
    return make_request(cad, path, cp, 8, feet, s_now_m=s_now, phase_s=0.05)


def test_step_qp_keeps_footholds_out_of_no_step_cells() -> None:
    req = _walk_request(None)
    xs, ys = grid()
    X, Y = np.meshgrid(xs, ys, indexing="ij")
    step = np.zeros(X.shape, dtype=bool)
    # A 12 cm strip of no-step cells under each of the nominal footholds after the first two.
    for x in req.p_nominal[2:, 0]:
        step |= np.abs(X - x) < 0.06
    maps = maps_from_grids((xs[0], ys[0]), RES, np.zeros(X.shape), step)
    assert np.asarray(maps.no_step(req.p_nominal[:, 0], req.p_nominal[:, 1])).sum() >= 4
    qp = StepQP()
    plan = qp.solve(req, maps)
    assert not plan.in_no_step.any()
    assert plan.hard_softened == ()
    assert plan.footholds.shape == (8, 3)
    assert np.all(np.abs(plan.footholds[:, :2] - req.p_nominal) < 0.25)
    assert plan.rounds >= 2
    # The same answer again, warm: the planes carry over and one solve suffices.
    plan2 = qp.solve(req, maps)
    assert plan2.rounds == 1 and not plan2.in_no_step.any()
    np.testing.assert_allclose(plan2.footholds, plan.footholds, atol=2e-3)


def test_step_qp_reports_what_it_softened_when_infeasible() -> None:
    req = _walk_request(None)
    xs, ys = grid()
    X, Y = np.meshgrid(xs, ys, indexing="ij")
    step = np.hypot(X - req.p_nominal[3, 0], Y - req.p_nominal[3, 1]) < 0.6  # far beyond any reach of slot 3
    maps = maps_from_grids((xs[0], ys[0]), RES, np.zeros(X.shape), step)
    plan = StepQP().solve(req, maps)
    assert plan.hard_softened
    assert set(plan.hard_softened) & {"step_keep", "reach_rect", "reach_oct"}
    assert all(plan.slack[f] > 0 for f in plan.hard_softened)


def test_step_qp_on_flat_ground_stays_at_nominal() -> None:
    req = _walk_request(None)
    plan = StepQP().solve(req, None)
    assert plan.softened == ()
    np.testing.assert_allclose(plan.footholds[:, :2], req.p_nominal, atol=5e-3)


def test_step_qp_rejects_bad_requests() -> None:
    req = _walk_request(None)
    bad = type(req)(**{**req.__dict__, "p_nominal": req.p_nominal[:4]})
    with pytest.raises(ValueError, match="p_nominal"):
        StepQP().solve(bad, None)
    with pytest.raises(ValueError, match="n_steps"):
        StepQP(StepQPParams(n_steps=3))


def test_bench_step_qp_walks_stones_without_no_step_touchdowns() -> None:
    out = bench_step_qp(n=120, terrain="stones", cadence="medium")
    assert out["in_no_step"] == 0 and out["hard_softened"] == 0
    assert out["footholds"] >= 8
    for key in ("p50_ms", "p99_ms", "bare_solver_p50_ms"):
        assert out[key] > 0


def test_step_qp_rows_gathered_equal_rows_set_one_by_one() -> None:
    """The replan's rows set in a few indexings (gathered static rows, every region at once) hold the same
    matrix and bounds as rows set one at a time, for several cadences, phases and region shapes."""
    rng = np.random.default_rng(3)
    for cadence in ("slow", "medium", "fast"):
        for s_now in (0.0, 0.37):
            req = _walk_request(None, cadence, s_now)
            regions: list[tuple[np.ndarray, np.ndarray] | None] = []
            for k in range(8):
                if k == 5:
                    regions.append(None)  # a free slot
                    continue
                m = int(rng.integers(3, 7))
                ang = np.sort(rng.uniform(0.0, 2 * np.pi, m))
                A = np.column_stack([np.cos(ang), np.sin(ang)])
                regions.append((A, A @ req.p_nominal[k] + rng.uniform(-0.02, 0.08, m)))
            qp_params = StepQPParams(keep_planes=8)
            fast, ref = StepQP(qp_params), StepQP(qp_params)
            ref._fill_static = ref._fill_static_rows  # type: ignore[method-assign]

            def one_by_one(rs: list, qp: StepQP = ref) -> None:
                for k, r in enumerate(rs):
                    qp._keep_planes[k] = []
                    if r is not None:
                        for i in range(len(r[1])):
                            qp._set_keep_row(k, i, -r[0][i], float(-r[1][i] - qp.params.keep_clearance_m))

            ref._set_region_rows = one_by_one  # type: ignore[method-assign]
            a, b = fast.solve(req, None, regions), ref.solve(req, None, regions)
            assert np.array_equal(fast._vals, ref._vals)
            assert np.array_equal(fast.l, ref.l) and np.array_equal(fast.u, ref.u)
            assert np.count_nonzero(fast.l > -np.inf) > 8 * 4  # rows did get set
            np.testing.assert_allclose(a.footholds, b.footholds, atol=1e-9)
