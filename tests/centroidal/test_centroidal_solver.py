"""The solver on standing, a trot, a jump and three-leg stance: targets tracked, constraints held, forces exact."""

from __future__ import annotations

import math

import numpy as np
import pytest

from planning.centroidal import _so3
from planning.centroidal.integrate import model_error
from planning.centroidal.reference import reference_forces
from planning.centroidal.scenarios import jump, run, standing, three_leg, trot
from planning.centroidal.solver import CentroidalParams, CentroidalSolver

PARAMS = CentroidalParams(time_budget_ms=math.inf)  # tests check results, the bench checks time


def _assert_matches_clarabel(solver, sol, tol_n=1.0):
    ref, status = reference_forces(solver)
    assert status == "Solved"
    err = np.max(np.abs(ref - sol.f_world))
    assert err < tol_n, f"forces {err:.3f} N off the reference"
    return err


def test_standing_tracks_a_body_pose(model, checker):
    sc = standing(model)
    solver = CentroidalSolver(PARAMS)
    log = run(sc, solver, duration_s=1.0, keep_problems=True)
    assert all(s.ok for s in log.solutions[1:]), [s.message for s in log.solutions if not s.ok][:3]
    # Closed loop at the keyframe time (0.6 s): within a few mm and under a degree of the target.
    i = int(round(0.6 / 0.02))
    st = log.states[i]
    p_t, R_t = sc.keyframes[0][1], sc.keyframes[0][2]
    assert np.linalg.norm(st.p_world - p_t) < 0.01
    assert np.degrees(np.linalg.norm(_so3.log(st.R_world_body @ R_t.T))) < 1.5
    for k in (0, 10, 30):
        checker(log.solutions[k], log.problems[k])
    sol = solver.solve(sc.problem_at(log.states[-1]))
    _assert_matches_clarabel(solver, sol)


def test_trot_alternates_diagonal_pairs_and_keeps_the_body_level(model, checker):
    sc = trot(model, vx=0.3)
    solver = CentroidalSolver(PARAMS)
    log = run(sc, solver, duration_s=1.5, keep_problems=True)
    assert all(s.ok for s in log.solutions[1:])
    z = np.array([s.p_world[2] for s in log.states])
    rpy = np.array([_so3.R_to_rpy(s.R_world_body) for s in log.states])
    assert np.all(np.abs(z - sc.start.p_world[2]) < 0.02)
    assert np.degrees(np.max(np.abs(rpy[:, :2]))) < 3.0
    assert log.states[-1].p_world[0] == pytest.approx(0.3 * 1.5, abs=0.08)
    for k in (15, 40, 60):
        sol, pr = log.solutions[k], log.problems[k]
        checker(sol, pr)
        # diagonal pairs: FL with RR, FR with RL, never a pair split
        ic = sol.in_contact
        assert np.array_equal(ic[:, 0], ic[:, 3]) and np.array_equal(ic[:, 1], ic[:, 2])
        assert not np.any(ic[:, 0] & ic[:, 1])
    sol = solver.solve(sc.problem_at(log.states[-1]))
    _assert_matches_clarabel(solver, sol)
    # The plan's discrete model against the continuous rigid-body equations under its own forces: coarse
    # 0.15 s steps while walking, yet within millimetres over the whole horizon.
    assert model_error(sol, sc.problem_at(log.states[-1])).metric < 0.005


def test_jump_has_a_ballistic_flight_phase(model, checker):
    sc = jump(model)
    solver = CentroidalSolver(PARAMS)
    log = run(sc, solver, duration_s=1.2, keep_problems=True)
    assert all(s.ok for s in log.solutions[1:])
    # The second plan (one warm-up tick) already lifts off and lands as planned.
    pr, sol = log.problems[1], log.solutions[1]
    checker(sol, pr)
    t = sol.t_knots
    flight = (t[:-1] >= 0.35 - 1e-9) & (t[1:] <= 0.55 + 1e-9)
    assert flight.sum() >= 2
    assert np.all(np.abs(sol.f_world[flight]) < 1e-3)
    # ballistic: no force, so the CoM accelerates with gravity alone
    dt = np.diff(t)[flight]
    k = np.nonzero(flight)[0]
    v_pred = sol.v_world[k] + dt[:, None] * np.array([0.0, 0.0, -9.81])
    assert np.allclose(sol.v_world[k + 1], v_pred, atol=1e-6)
    # Closed loop: it leaves the ground (apex well above standing) and comes back to its height.
    z = np.array([s.p_world[2] for s in log.states])
    assert z.max() > z[0] + 0.06
    assert abs(z[-1] - z[0]) < 0.02
    _assert_matches_clarabel(solver, solver.solve(sc.problem_at(log.states[-1])))


def test_three_leg_stance_with_a_waving_leg(model, checker):
    sc = three_leg(model, leg=0)
    solver = CentroidalSolver(PARAMS)
    log = run(sc, solver, duration_s=1.4, keep_problems=True)
    assert all(s.ok for s in log.solutions[1:])
    for k in (10, 40, 60):
        pr, sol = log.problems[k], log.solutions[k]
        checker(sol, pr)
        waving = (sol.t_knots[:-1] >= 0.5 - 1e-9) & (sol.t_knots[1:] <= 1.7 + 1e-9)
        assert np.all(np.abs(sol.f_world[waving, 0]) < 1e-3)
        assert np.all(sol.f_world[waving][:, 1:, 2] >= pr.fz_min_N - 1e-3)
    sol = solver.solve(sc.problem_at(log.states[-1]))
    _assert_matches_clarabel(solver, sol)
    # While FL is up, the CoM stands over the triangle of the other three feet.
    feet = np.array([[0.3, -0.165], [-0.3, 0.165], [-0.3, -0.165]])
    for st in log.states[35:70]:
        x, y = st.p_world[:2]
        for a, b in ((0, 1), (1, 2), (2, 0)):
            e = feet[b] - feet[a]
            c = feet[3 - a - b]
            side = np.sign(e[0] * (c[1] - feet[a][1]) - e[1] * (c[0] - feet[a][0]))
            assert side * (e[0] * (y - feet[a][1]) - e[1] * (x - feet[a][0])) > 0.0
    assert abs(log.states[-1].p_world[2] - sc.keyframes[1][1][2]) < 0.02


@pytest.mark.parametrize("make", [standing, trot, jump, three_leg])
def test_forces_match_the_reference_across_ticks(model, make):
    sc = make(model)
    solver = CentroidalSolver(PARAMS)
    log = run(sc, solver, duration_s=0.6, tick_s=0.05, keep_problems=True)
    errs = []
    for pr in log.problems[::3]:
        sol = solver.solve(pr)
        errs.append(_assert_matches_clarabel(solver, sol))
    assert max(errs) < 1.0


def test_smaller_robot_stands_and_shifts(checker):
    """The go1 model (13 kg, 0.3 m tall): same solver, its own geometry."""
    import math

    from planning.centroidal.problem import BodyModel, BodyState, BodyTargets, CentroidalProblem, ContactPhase
    from planning.centroidal.timegrid import make_time_grid
    from planning.robot import load_robot

    robot = load_robot("go1")
    m = BodyModel.from_robot(robot)
    feet = robot.nominal_foot_body.copy()
    feet[:, 2] = 0.0
    z = robot.standing_height_m + m.p_body_com[2]
    st = BodyState(0.0, np.array([m.p_body_com[0], 0.0, z]), np.zeros(3), np.eye(3), np.zeros(3))
    t = make_time_grid(0.0, [], 1.0)
    tg = BodyTargets.hold(t.size, st.p_world + [0.02, 0.01, -0.03], np.eye(3), 200.0, 200.0)
    phases = tuple(ContactPhase(i, -1.0, math.inf, feet[i]) for i in range(4))
    pr = CentroidalProblem(t, st, phases, tg, m, fz_max_N=250.0)
    solver = CentroidalSolver(PARAMS)
    for _ in range(3):
        sol = solver.solve(pr)
    assert sol.ok, sol.message
    checker(sol, pr)
    dt = np.diff(sol.t_knots)
    mean_fz = float(np.sum(sol.f_world[..., 2].sum(axis=1) * dt) / dt.sum())
    assert mean_fz == pytest.approx(m.mass_kg * 9.81, rel=0.1)  # on average it carries its weight
    assert np.linalg.norm(sol.p_world[-1] - tg.p_world[-1]) < 0.01
