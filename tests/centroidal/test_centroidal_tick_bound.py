"""A tick's work is bounded: ADMM iterations and QP solves per tick never exceed the parameters, and a trot
driven by ticks that run out of work (the last good plan drives on) still trots."""

from __future__ import annotations

import math

import pytest

from planning.centroidal.scenarios import run, trot
from planning.centroidal.solver import CentroidalParams, CentroidalSolver


@pytest.mark.parametrize(("iterations", "solves", "ok_rate"), [(30, 2, 0.3), (60, 3, 0.9)])
def test_tick_work_stays_within_its_bound(model, iterations: int, solves: int, ok_rate: float) -> None:
    solver = CentroidalSolver(
        CentroidalParams(time_budget_ms=math.inf, max_tick_iterations=iterations, max_tick_solves=solves)
    )
    sc = trot(model, vx=0.5)
    log = run(sc, solver, duration_s=1.5)
    used = [s.qp_iterations for s in log.solutions[1:]]
    assert max(used) <= iterations + 1  # a tick out of work may take one last iteration to close a fallback
    assert max(s.cut_iterations for s in log.solutions) <= solves - 1
    ok = sum(s.ok for s in log.solutions[1:]) / len(used)
    assert ok >= ok_rate, f"only {ok:.0%} of the ticks solved within the bound"
    # the plan that drives (the last good one) keeps the trot going forward
    assert log.states[-1].p_world[0] == pytest.approx(0.5 * 1.5, abs=0.12)
