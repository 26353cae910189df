"""The contact schedule on the grid: slots per leg in time order, a step's windows, and overlapping phases."""

from __future__ import annotations

import math

import numpy as np

from planning.centroidal._schedule import build_schedule
from planning.centroidal.problem import (
    BodyState,
    BodyTargets,
    CentroidalProblem,
    ContactPhase,
    phase_event_times,
)
from planning.centroidal.scenarios import nominal_feet
from planning.centroidal.timegrid import make_time_grid


def _problem(model, phases):
    t = make_time_grid(0.0, phase_event_times(phases), 1.2, base_dt=0.05, max_knots=40)
    s0 = BodyState(0.0, np.array([0.0, 0.0, 0.52]), np.zeros(3), np.eye(3), np.zeros(3))
    return CentroidalProblem(
        t, s0, tuple(phases), BodyTargets.hold(t.size, [0, 0, 0.52], np.eye(3)), model
    ), t


def test_slots_count_per_leg_and_windows_of_consecutive_steps(model):
    """Two steps of FL (a liftoff window, then a touchdown window): the slots of FL count 0, 1 in time order, the
    other legs have one slot each, c order rows point the right way, and no interval is claimed twice."""
    feet = nominal_feet()
    phases = [ContactPhase(i, -1.0, math.inf, feet[i]) for i in (1, 2, 3)]
    phases += [
        ContactPhase(0, -1.0, 0.3, feet[0], liftoff_window_s=(0.0, 0.1)),
        ContactPhase(
            0, 0.7, math.inf, feet[0] + [0.1, 0.0, 0.0], touchdown_window_s=(0.1, 0.1), adjust_radius_m=0.05
        ),
    ]
    pr, t = _problem(model, phases)
    sch = build_schedule(pr, 2, 8)
    assert not isinstance(sch, str)
    tm = 0.5 * (t[:-1] + t[1:])
    assert np.all(sch.slot[tm < 0.3, 0] == 0) and np.all(sch.slot[tm > 0.6, 0] == 1)
    assert np.all(sch.slot[(tm > 0.4) & (tm < 0.6), 0] == -1)  # in the air between the windows
    assert np.all(sch.slot[:, 1:] == 0)
    pair = tm[:-1]  # c_{k+1} vs c_k
    assert np.all(sch.mono[(pair >= 0.3) & (tm[1:] < 0.4), 0] == -1)  # liftoff window: c non-increasing
    assert np.all(sch.mono[(pair >= 0.6) & (tm[1:] < 0.8), 0] == 1)  # touchdown window: c non-decreasing
    assert np.all(sch.mono[:, 1:] == 0)
    assert [s.var for s in sch.slots[0]] == [-1, 0]  # only the touchdown is adjustable (the first is planted)


def test_overlapping_phases_of_one_leg_are_reported(model):
    feet = nominal_feet()
    phases = [ContactPhase(i, -1.0, math.inf, feet[i]) for i in (0, 1, 3)]
    phases += [ContactPhase(2, 0.2, 0.6, feet[2]), ContactPhase(2, 0.5, math.inf, feet[2])]
    pr, _ = _problem(model, phases)
    msg = build_schedule(pr, 2, 8)
    assert isinstance(msg, str)
    assert "leg RL" in msg and "0.500" in msg  # the later phase, named by its leg and time
