"""The solver-facing problem: validation messages, measured contacts over the plan, schedule, and no exceptions."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from planning.centroidal._schedule import build_schedule
from planning.centroidal.problem import (
    BodyModel,
    BodyState,
    BodyTargets,
    CentroidalProblem,
    ContactPhase,
    phase_event_times,
    reconcile_contacts,
)
from planning.centroidal.scenarios import nominal_feet
from planning.centroidal.solver import CentroidalParams, CentroidalSolver
from planning.centroidal.timegrid import make_time_grid


def _state(t=0.0):
    return BodyState(t, np.array([0.0, 0.0, 0.52]), np.zeros(3), np.eye(3), np.zeros(3))


def test_body_model_from_robot_is_consistent(model: BodyModel):
    assert 25.0 < model.mass_kg < 40.0
    assert np.all(np.linalg.eigvalsh(model.inertia_body) > 0.0)
    # the nominal stance is comfortably inside the leg-length limits
    hip = model.p_body_hip + model.p_body_com + [0.0, 0.0, 0.52]  # trunk at the standing height
    foot = nominal_feet() + [0.0, 0.0, model.foot_radius_m]
    d = np.linalg.norm(hip - foot, axis=1)
    assert np.all((d > model.leg_length_min_m + 0.05) & (d < model.leg_length_max_m - 0.05))


def test_event_times_include_window_edges():
    ph = ContactPhase(1, 0.5, 0.9, np.zeros(3), touchdown_window_s=(0.1, 0.05), liftoff_window_s=(0.0, 0.1))
    ts = phase_event_times([ph])
    for t in (0.4, 0.5, 0.55, 0.9, 1.0):
        assert np.min(np.abs(ts - t)) < 1e-12


def test_schedule_marks_windows_and_costs_shifts(model):
    feet = nominal_feet()
    phases = [ContactPhase(i, -1.0, math.inf, feet[i]) for i in (1, 2, 3)]
    phases.append(
        ContactPhase(0, 0.3, math.inf, feet[0], touchdown_window_s=(0.1, 0.1), adjust_radius_m=0.05)
    )
    t = make_time_grid(0.0, phase_event_times(phases), 0.8, base_dt=0.05, max_knots=40)
    pr = CentroidalProblem(
        t, _state(), tuple(phases), BodyTargets.hold(t.size, [0, 0, 0.52], np.eye(3)), model
    )
    sch = build_schedule(pr, 2, 8)
    assert not isinstance(sch, str)
    tm = 0.5 * (t[:-1] + t[1:])
    win = (tm >= 0.2) & (tm < 0.4)
    assert np.all(sch.c_lo[win, 0] == 0.0) and np.all(sch.c_hi[win, 0] == 1.0)  # optional inside the window
    assert np.all(sch.c_hi[tm < 0.2, 0] == 0.0) and np.all(sch.c_lo[tm >= 0.4, 0] == 1.0)
    assert np.all(sch.q_c[win & (tm < 0.3), 0] > 0.0)  # early contact costs
    assert np.all(sch.q_c[win & (tm > 0.3), 0] < 0.0)  # contact after the nominal time is rewarded
    assert np.all(sch.mono[(tm[:-1] >= 0.2) & (tm[1:] < 0.4), 0] == 1)
    assert sch.slots[0][0].var == 0 and sch.slots[1][0].var == -1  # only the touchdown's place is a variable


def test_late_and_early_touchdown_reconciled():
    feet = nominal_feet()
    phases = (
        ContactPhase(0, -1.0, 0.2, feet[0]),
        ContactPhase(0, 0.45, 0.7, feet[0], touchdown_window_s=(0.0, 0.1), adjust_radius_m=0.05),
    )
    measured_feet = feet + [0.02, -0.01, 0.0]
    # late: at 0.5 s the foot should be down but is not
    out = reconcile_contacts(phases, 0.5, np.zeros(4, dtype=bool), measured_feet)
    late = [p for p in out if p.t_liftoff == 0.7][0]
    assert late.t_touchdown > 0.5 and late.touchdown_window_s[1] <= 0.05 + 1e-9
    # early: at 0.4 s the foot is already down, at its measured place, and that place can no longer move
    down = np.array([True, False, False, False])
    out = reconcile_contacts(phases, 0.4, down, measured_feet)
    early = [p for p in out if p.t_liftoff == 0.7][0]
    assert early.t_touchdown == 0.4 and early.adjust_radius_m == 0.0
    assert np.allclose(early.p_world_foot, measured_feet[0])
    # early liftoff: a stance ending at 0.7 s, the foot is up at 0.65 s
    out = reconcile_contacts(phases, 0.65, np.zeros(4, dtype=bool), measured_feet)
    assert [p for p in out if p.t_touchdown == 0.45][0].t_liftoff == 0.65


def test_problem_contact_flags():
    feet = nominal_feet()
    phases = (ContactPhase(0, -1.0, 0.2, feet[0]), ContactPhase(0, 0.4, 0.8, feet[0]))
    t = np.array([0.0, 0.1, 0.2, 0.3, 0.4, 0.6, 0.8, 1.0])
    pr = CentroidalProblem(t, _state(), phases, BodyTargets.hold(t.size, [0, 0, 0.52], np.eye(3)), None)  # type: ignore[arg-type]
    assert pr.contact[:, 0].tolist() == [True, True, False, False, True, True, False]


@settings(max_examples=25, deadline=None)
@given(
    td=st.lists(st.one_of(st.floats(-1.0, 2.0), st.just(math.nan)), min_size=1, max_size=6),
    dur=st.lists(st.floats(-0.2, 1.5), min_size=6, max_size=6),
    legs=st.lists(st.integers(-1, 4), min_size=6, max_size=6),
    z=st.one_of(st.floats(-1.0, 2.0), st.sampled_from([math.nan, math.inf])),
    mu=st.floats(-1.0, 2.0),
)
def test_solver_never_raises(model, td, dur, legs, z, mu):
    phases = tuple(
        ContactPhase(int(legs[j] % 5 if legs[j] >= 0 else 0), t, t + dur[j], np.array([0.3, 0.1, 0.0]))
        for j, t in enumerate(td)
        if not math.isnan(t)
    )
    state = BodyState(0.0, np.array([0.0, 0.0, z]), np.zeros(3), np.eye(3), np.zeros(3))
    t = make_time_grid(0.0, [], 0.6)
    pr = CentroidalProblem(t, state, phases, BodyTargets.hold(t.size, [0, 0, 0.52], np.eye(3)), model, mu=mu)
    sol = SOLVER.solve(pr)
    assert isinstance(sol.ok, bool) and isinstance(sol.status, str) and sol.message
    if not sol.ok:
        assert sol.status != "solved"


SOLVER = CentroidalSolver(CentroidalParams(time_budget_ms=math.inf, max_knots=16))


def test_previous_forces_are_averaged_onto_the_new_grid():
    from planning.centroidal.solver import _interval_average

    t_old = np.array([0.0, 0.1, 0.3])
    x_old = np.array([[1.0], [3.0]])
    avg = _interval_average(t_old, x_old, np.array([0.05, 0.15, 0.35, 0.5]))
    assert np.allclose(avg[:, 0], [2.0, 3.0, 3.0])
