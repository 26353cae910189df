"""Timing adjustment never hurts: with windows ON a problem is feasible whenever it is with them OFF, costs no more,
and never loads a foot that is out of reach (the window's kinematic rows only hold once the foot is down)."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from planning.centroidal import _so3
from planning.centroidal._schedule import build_schedule
from planning.centroidal.problem import (
    BodyState,
    BodyTargets,
    CentroidalProblem,
    ContactPhase,
    CostWeights,
    phase_event_times,
)
from planning.centroidal.scenarios import nominal_feet
from planning.centroidal.solver import CentroidalParams, CentroidalSolver
from planning.centroidal.timegrid import make_time_grid

PARAMS = CentroidalParams(time_budget_ms=math.inf)


def _swing_problem(model, x_td: float, t_td: float, window: float, t0: float = 0.5, vx: float = 0.05):
    """FL lifted off before t0 and lands at (x_td, 0.165) at t_td ± window (the early edge may be before t0);
    the body creeps forward at vx m/s on the three other legs. The maneuver-shaped problem of a long step."""
    feet = nominal_feet()
    phases = (
        ContactPhase(0, t_td, math.inf, np.array([x_td, 0.165, 0.0]), touchdown_window_s=(window, window)),
        *(ContactPhase(i, -1.0, math.inf, feet[i]) for i in (1, 2, 3)),
    )
    R = _so3.rpy_to_R(np.zeros(3))
    p0 = np.array([vx * t0, 0.0, 0.52]) + R @ model.p_body_com
    state = BodyState(t0, p0, np.array([vx, 0.0, 0.0]), R, np.zeros(3))
    end = t0 + 1.0
    grid = make_time_grid(t0, phase_event_times(phases), end, 0.05, max_knots=24)
    p_end = p0 + [vx * (end - t0), 0.0, 0.0]
    tg = BodyTargets.from_keyframes(grid, state, ((end, p_end, R, 20.0),), 20.0)
    w = CostWeights(touchdown_time=1000.0)
    return CentroidalProblem(grid, state, phases, tg, model, weights=w)


def _solve(pr, timing: bool, ticks: int = 3):
    solver = CentroidalSolver(replace(PARAMS, timing_adjustment=timing))
    for _ in range(ticks):
        sol = solver.solve(pr)
    return sol


@pytest.mark.parametrize(
    ("x_td", "t_td", "window"),
    [
        (0.9, 0.75, 0.4),  # the window reaches 0.15 s into the past; the body only just gets there in time
        (0.8, 0.9, 0.3),
        (0.95, 0.9, 0.3),
        (0.7, 0.6, 0.2),  # an easy step, landing soon
    ],
)
def test_timing_on_is_feasible_and_no_dearer_than_off(model, checker, x_td, t_td, window):
    pr = _swing_problem(model, x_td, t_td, window)
    off = _solve(pr, False)
    on = _solve(pr, True)
    assert off.ok, off.message  # the nominal timing works ...
    assert on.ok, on.message  # ... so the timing ON, which has it among its choices, works too
    assert on.cost <= off.cost + 1e-3 * max(1.0, off.cost)
    checker(on, pr)  # in particular: no loaded foot beyond the legs' reach
    td = next(t for t in on.touchdowns if t.leg == 0)
    assert pr.t_knots[0] <= td.t <= t_td + window + 1e-9  # never touched down in the past


def test_unreachable_nominal_touchdown_lands_later(model, checker):
    """Too far to reach at the nominal time from where the body is: OFF fails, ON lands later within its window
    and keeps every loaded foot within reach (a relaxed contact variable may not buy reach)."""
    pr = _swing_problem(model, 0.95, 0.75, 0.4)
    off = _solve(pr, False)
    on = _solve(pr, True)
    assert not off.ok
    assert on.ok, on.message
    td = next(t for t in on.touchdowns if t.leg == 0)
    assert 0.75 + 0.05 < td.t <= 1.15 + 1e-9
    checker(on, pr)


def test_overlapping_windows_are_shared_not_rejected(model):
    """A touchdown window that reaches back over the previous liftoff's window is a valid problem: the schedule
    shares the gap between them, and the nominal timing stays one of the choices."""
    feet = nominal_feet()
    phases = (
        ContactPhase(0, -1.0, 0.3, feet[0], liftoff_window_s=(0.0, 0.2)),
        ContactPhase(0, 0.5, math.inf, feet[0] + [0.1, 0.0, 0.0], touchdown_window_s=(0.3, 0.1)),
        *(ContactPhase(i, -1.0, math.inf, feet[i]) for i in (1, 2, 3)),
    )
    st = BodyState(0.0, np.array([0.0, 0.0, 0.52]), np.zeros(3), np.eye(3), np.zeros(3))
    t = make_time_grid(0.0, phase_event_times(phases), 1.0)
    pr = CentroidalProblem(t, st, phases, BodyTargets.hold(t.size, st.p_world, np.eye(3)), model)
    assert pr.validate() == []
    sch = build_schedule(pr, 2, 8)
    assert not isinstance(sch, str), sch
    lo_span, td_span = sch.slots[0][0].lo_window, sch.slots[0][1].td_window
    assert lo_span[1] <= td_span[0]  # no interval in both windows
    tm = 0.5 * (t[:-1] + t[1:])
    nominal = ((tm < 0.3) | (tm >= 0.5)).astype(float)
    assert np.all((sch.c_lo[:, 0] <= nominal) & (nominal <= sch.c_hi[:, 0]))
    # Nominal stances that overlap are still an error, naming the phase.
    bad = replace(pr, phases=(replace(phases[0], t_liftoff=0.6), *phases[1:]))
    assert any("phases[1] (FL)" in m and "overlaps" in m for m in bad.validate())
