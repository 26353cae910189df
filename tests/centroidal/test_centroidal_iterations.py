"""Real-time iterations, iterative cuts, timing adjustment, footholds, objectives, and failures without exceptions."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from planning.centroidal import _so3
from planning.centroidal.problem import (
    BodyState,
    BodyTargets,
    CentroidalProblem,
    ContactPhase,
    CostWeights,
    Objective,
)
from planning.centroidal.scenarios import drop, nominal_feet, run, standing, trot
from planning.centroidal.solver import CentroidalParams, CentroidalSolver
from planning.centroidal.timegrid import make_time_grid

PARAMS = CentroidalParams(time_budget_ms=math.inf)


def _stand_problem(
    model, state, targets_p=(0.0, 0.0, 0.52), R_t=None, horizon=1.0, mu=0.6, weights=None, **kw
):
    feet = nominal_feet()
    phases = tuple(ContactPhase(i, -1.0, math.inf, feet[i]) for i in range(4))
    t = make_time_grid(state.t, [], state.t + horizon)
    R_t = np.eye(3) if R_t is None else R_t
    tg = BodyTargets.hold(t.size, np.asarray(targets_p), R_t, 200.0, 200.0)
    return CentroidalProblem(t, state, phases, tg, model, mu=mu, weights=weights or CostWeights(), **kw)


def _perturbed_state():
    return BodyState(
        0.0, np.array([0.02, -0.01, 0.50]), np.array([0.3, -0.2, 0.1]), _so3.rpy_to_R(np.radians([8.0, -6.0, 4.0])),
        np.array([1.0, -0.8, 0.5]),
    )  # fmt: skip


def test_linearization_error_converges_over_iterations(model):
    """Re-linearizing about each solution (same problem): from a cold start to well under the threshold."""
    pr = _stand_problem(model, _perturbed_state())
    solver = CentroidalSolver(PARAMS)
    errs = [solver.solve(pr).linearization_error for _ in range(4)]
    assert errs[0] > 0.02  # the cold start is a poor linearization point
    assert errs[1] < 0.01 * errs[0]
    assert errs[2] < 0.5 * errs[1] and errs[3] < errs[1]


def test_linearization_error_is_quadratic_in_the_estimate_error(model):
    """Move the linearization point off the solution by ε·δ: the error scales with ε² (halve ε, quarter it)."""
    pr = _stand_problem(model, _perturbed_state())
    solver = CentroidalSolver(PARAMS)
    for _ in range(8):
        sol = solver.solve(pr)
    assert sol.linearization_error < 1e-4
    star = solver._prev  # white box: the linearization point the next solve uses
    assert star is not None
    rng = np.random.default_rng(0)
    K = star.p.shape[0]
    dp, dth = rng.normal(size=(K, 3)) * 0.02, rng.normal(size=(K, 3)) * 0.05
    df, dw = rng.normal(size=star.f.shape) * 20.0, rng.normal(size=(K, 3)) * 0.3
    errs = []
    for eps in (1.0, 0.5, 0.25):
        solver._prev = replace(star, p=star.p + eps * dp, R=_so3.exp(eps * dth) @ star.R, f=star.f + eps * df,
                               w=star.w + eps * dw)  # fmt: skip
        errs.append(solver.solve(pr).linearization_error)
    ratios = np.array(errs[:-1]) / np.array(errs[1:])
    assert np.all((ratios > 3.0) & (ratios < 5.0)), ratios


def test_closed_loop_first_solutions_converge(model):
    """In the loop the problem changes every tick; the error still drops from the 1st solution to the 4th."""
    sc = replace(standing(model), start=_perturbed_state())
    log = run(sc, CentroidalSolver(PARAMS), duration_s=0.1, tick_s=0.02)
    errs = [s.linearization_error for s in log.solutions[:4]]
    assert errs[1] < 0.2 * errs[0] and errs[2] < 0.6 * errs[1] and errs[3] < 0.6 * errs[2]
    assert not log.solutions[0].ok or errs[0] < PARAMS.linearization_error_threshold_m
    assert all(s.ok for s in log.solutions[1:])


def test_violated_leg_length_is_satisfied_after_its_cut(model):
    # A body target 0.72 m up: the legs cannot reach the ground from there.
    st = BodyState(0.0, np.array([0.0, 0.0, 0.52]), np.zeros(3), np.eye(3), np.zeros(3))
    pr = _stand_problem(model, st, targets_p=(0.0, 0.0, 0.72))
    no_cuts = CentroidalSolver(replace(PARAMS, max_cut_rounds=0, cut_margin_m=-1.0)).solve(pr)
    assert no_cuts.max_leg_length_violation_m > 0.02
    sol = CentroidalSolver(replace(PARAMS, cut_margin_m=-1.0)).solve(pr)
    assert sol.n_cuts > 0 and sol.cut_iterations >= 1
    assert sol.max_leg_length_violation_m < 2 * PARAMS.leg_length_tol_m
    hips = sol.p_world[:, None, :] + np.einsum("kij,lj->kli", sol.R_world_body, model.p_body_hip)
    feet = nominal_feet() + [0.0, 0.0, model.foot_radius_m]
    dist = np.linalg.norm(hips[1:] - feet[None], axis=-1)
    assert dist.max() <= model.leg_length_max_m + 2 * PARAMS.leg_length_tol_m
    assert sol.p_world[-1, 2] > 0.58  # it still goes as high as the legs allow


def test_friction_pyramid_is_refined_toward_the_cone(model):
    # Accelerate diagonally on slippery ground: the pyramid's corners would allow √2 × μ.
    st = BodyState(0.0, np.array([0.0, 0.0, 0.52]), np.zeros(3), np.eye(3), np.zeros(3))
    pr = _stand_problem(model, st, targets_p=(0.06, 0.06, 0.52), horizon=0.4, mu=0.3)

    def worst(sol):
        """The largest excess over the cone, as a fraction of μ f_n, among excesses above cone_tol_N."""
        f = sol.f_world
        excess = np.linalg.norm(f[..., :2], axis=-1) - pr.mu * f[..., 2]
        big = excess > PARAMS.cone_tol_N
        return float(np.max(excess[big] / (pr.mu * f[..., 2][big]), initial=0.0)) + 1.0

    coarse = CentroidalSolver(replace(PARAMS, max_cut_rounds=0))
    fine = CentroidalSolver(PARAMS)
    for _ in range(3):  # a few ticks: the linearization settles, the cuts follow the forces
        s0, s1 = coarse.solve(pr), fine.solve(pr)
    assert worst(s0) > 1.2
    assert s1.ok and s1.n_cuts >= 0
    assert worst(s1) < 1.0 + 2 * PARAMS.cone_tol
    assert s1.max_cone_violation <= 2 * PARAMS.cone_tol


def test_infeasible_nominal_timing_succeeds_with_adjustment(model):
    sc = drop(model, early_s=0.2)  # falling: the nominal touchdown at 0.25 s comes when the body is too low
    on = CentroidalSolver(PARAMS)
    off = CentroidalSolver(replace(PARAMS, timing_adjustment=False))
    pr = sc.problem_at(sc.start)
    for _ in range(3):
        s_on, s_off = on.solve(pr), off.solve(pr)
    assert s_on.ok, s_on.message
    assert s_off.status == "infeasible" and not s_off.ok
    assert all(td.t < td.t_nominal - 0.1 for td in s_on.touchdowns)


def test_timing_adjustment_lowers_the_cost_clearly(model):
    sc = drop(model, z0=0.6, vz0=-0.3, t_touchdown=0.2, early_s=0.15, late_s=0.05)
    pr = sc.problem_at(sc.start)
    on = CentroidalSolver(PARAMS)
    off = CentroidalSolver(replace(PARAMS, timing_adjustment=False))
    for _ in range(3):
        s_on, s_off = on.solve(pr), off.solve(pr)
    assert s_on.ok and s_off.ok
    assert s_off.cost > 2.0 * s_on.cost
    assert all(td.t < td.t_nominal for td in s_on.touchdowns)
    assert all(td.t == pytest.approx(td.t_nominal) for td in s_off.touchdowns)
    # and the liftoff side: a stance that may end early or late reports the time it chose within its window
    for td in s_on.touchdowns:
        assert td.t_nominal - 0.15 - 1e-9 <= td.t <= td.t_nominal + 0.05 + 1e-9


def test_touchdown_places_stay_in_their_sets(model):
    """The body is asked to move sideways over fixed nominal footholds: the solver moves the touchdowns toward
    it (hip over foot), within their radius or polygon."""
    sc = trot(model, adjust_radius_m=0.05)
    sc = replace(sc, weights=replace(sc.weights, hip_over_foot=200.0, touchdown_position=10.0))
    region = np.array([[0.25, -0.25], [0.40, -0.25], [0.40, -0.12], [0.25, -0.12]])  # FR's only legal area
    phases = tuple(
        replace(p, region_xy=region) if (p.leg == 1 and p.t_touchdown > 0.0) else p for p in sc.phases
    )
    kf = ((1.5, np.array([0.0, 0.3, 0.52]), np.eye(3), 50.0),)
    sc = replace(sc, phases=phases, keyframes=kf)
    st = replace(sc.start, t=0.3, v_world=np.array([0.0, 0.2, 0.0]))
    pr = sc.problem_at(st)
    solver = CentroidalSolver(PARAMS)
    for _ in range(3):
        sol = solver.solve(pr)
    assert sol.ok, sol.message
    moved = [td for td in sol.touchdowns if not td.planted]
    assert moved
    shifts = np.array([td.p_world[:2] - td.p_world_nominal[:2] for td in moved])
    assert np.max(np.abs(shifts)) > 0.01  # it does use the freedom ...
    assert np.all(np.linalg.norm(shifts, axis=1) <= 0.05 + 1e-4)  # ... within the radius (octagon inside it)
    assert np.mean(shifts[:, 1]) > 0.0  # and steps toward the push
    for td in moved:
        if td.leg == 1:
            x, y = td.p_world[:2]
            assert 0.25 - 1e-4 <= x <= 0.40 + 1e-4 and -0.25 - 1e-4 <= y <= -0.12 + 1e-4


def test_maximize_height_objective_raises_the_body(model):
    st = BodyState(0.0, np.array([0.0, 0.0, 0.52]), np.zeros(3), np.eye(3), np.zeros(3))
    base = _stand_problem(model, st)
    up = replace(base, objectives=(Objective("maximize_height", 0.3, 1.0, 200.0),))
    lean = replace(base, objectives=(Objective("lean", 0.3, 1.0, 200.0, (0.0, 1.0)),))
    z0 = CentroidalSolver(PARAMS).solve(base).p_world[-3:, 2].mean()
    z1 = CentroidalSolver(PARAMS).solve(up).p_world[-3:, 2].mean()
    y1 = CentroidalSolver(PARAMS).solve(lean).p_world[-3:, 1].mean()
    assert z1 > z0 + 0.01
    assert y1 > 0.01


def test_warm_start_cuts_iterations(model):
    sc = trot(model)
    solver = CentroidalSolver(PARAMS)
    log = run(sc, solver, duration_s=0.4)
    first, later = log.solutions[0].qp_iterations, np.median([s.qp_iterations for s in log.solutions[5:]])
    assert later < first


def _resized(pr, n):
    t = np.linspace(0.0, 3.0, n)
    return replace(pr, t_knots=t, targets=BodyTargets.hold(n, pr.targets.p_world[0], np.eye(3)))


@pytest.mark.parametrize(
    "change, field",
    [
        (lambda p: replace(p, fz_min_N=700.0), "fz_min_N"),
        (lambda p: replace(p, mu=-0.1), "mu"),
        (
            lambda p: replace(p, initial=replace(p.initial, p_world=np.array([np.nan, 0.0, 0.5]))),
            "initial.p_world",
        ),
        (
            lambda p: replace(p, initial=replace(p.initial, R_world_body=2.0 * np.eye(3))),
            "initial.R_world_body",
        ),
        (lambda p: replace(p, t_knots=p.t_knots[::-1]), "t_knots"),
        (lambda p: _resized(p, 40), "t_knots"),
        (lambda p: replace(p, phases=p.phases + (ContactPhase(0, 0.2, 0.5, np.zeros(3)),)), "phases"),
        (lambda p: replace(p, objectives=(Objective("fly", 0.0, 1.0, 1.0),)), "objectives[0].kind"),  # type: ignore[arg-type]
        (
            lambda p: replace(
                p,
                phases=(
                    replace(
                        p.phases[0], t_touchdown=0.3, region_xy=np.array([[0.0, 0.0], [1.0, 1.0], [2.0, 2.0]])
                    ),
                )
                + p.phases[1:],
            ),
            "region_xy",
        ),
    ],
)
def test_contradictory_problems_fail_with_a_reason(model, change, field):
    st = BodyState(0.0, np.array([0.0, 0.0, 0.52]), np.zeros(3), np.eye(3), np.zeros(3))
    pr = change(_stand_problem(model, st))
    sol = CentroidalSolver(PARAMS).solve(pr)
    assert not sol.ok and sol.status == "invalid_problem"
    assert field in sol.message


def test_an_infeasible_problem_fails_without_an_exception(model):
    # Fifty newtons of minimum load on each foot while the body must stay in the air: no way to satisfy both.
    st = BodyState(0.0, np.array([0.0, 0.0, 0.52]), np.zeros(3), np.eye(3), np.zeros(3))
    pr = _stand_problem(
        model, st, fz_min_N=200.0, fz_max_N=210.0
    )  # 4 × 200 N > the weight, and no way to sink
    solver = CentroidalSolver(PARAMS)
    sol = solver.solve(pr)
    assert sol.ok or sol.status in ("infeasible", "linearization_error", "cuts_unsatisfied")
    bad = replace(pr, fz_min_N=200.0, fz_max_N=210.0, model=replace(model, leg_length_max_m=0.5))
    sol = CentroidalSolver(PARAMS).solve(bad)
    assert not sol.ok and sol.status in ("infeasible", "cuts_unsatisfied")
    # and the solver keeps working afterwards
    assert solver.solve(_stand_problem(model, st)).ok


def test_late_touchdown_is_taken_into_the_problem(model):
    sc = trot(model)
    # At 0.47 s FR and RL should have been down since 0.45 s, but the measurement says FR is still in the air.
    st = replace(sc.start, t=0.47)
    down = np.array([False, False, True, False])
    feet = nominal_feet()
    pr = sc.problem_at(st, contact_measured=down, p_world_foot_measured=feet)
    assert not pr.contact[0, 1]  # FR is not planned on now ...
    assert pr.contact[0, 2]  # ... RL is
    assert pr.contact[:, 1].any()  # and FR still touches down later
    sol = CentroidalSolver(PARAMS).solve(pr)
    assert sol.f_world.shape[0] and np.all(np.abs(sol.f_world[0, 1]) < 1e-3)
    # An early touchdown: FR measured down at 0.42 s, before its nominal 0.45 s: usable at once.
    st = replace(sc.start, t=0.42)
    down = np.array([True, True, False, True])
    pr = sc.problem_at(st, contact_measured=down, p_world_foot_measured=feet)
    assert pr.contact[0, 1] and not pr.contact[0, 2]
