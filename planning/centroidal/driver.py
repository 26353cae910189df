"""The centroidal solver as a stage of the loop: one solve a tick, the latest good solution, the report's numbers."""

from __future__ import annotations

import math
import time
from dataclasses import replace
from typing import Any

import numpy as np

from planning.centroidal.problem import CentroidalProblem
from planning.centroidal.solver import CentroidalParams, CentroidalSolution, CentroidalSolver


class SolverDriver:
    """Solves every tick (warm-started), keeps the last ``ok`` solution and counts what the run report needs.

    A solution drives for at most max_age_s after its tick; past that, or while the solver has no good solution,
    the caller's backup controller drives (a fallback tick). budget_ms: the solver's wall-clock budget (None: no
    budget, so headless runs are deterministic whatever the machine's load).
    """

    def __init__(
        self,
        robot: Any,
        budget_ms: float | None = None,
        max_age_s: float = 0.05,
        params: CentroidalParams | None = None,
    ) -> None:
        params = replace(
            params or CentroidalParams(), time_budget_ms=math.inf if budget_ms is None else budget_ms
        )
        self.solver = CentroidalSolver(params, robot=robot)
        self.max_age_s = max_age_s
        self.solution: CentroidalSolution | None = None
        self.t_solution = -math.inf
        self.solver_ticks = 0
        self.fallback_ticks = 0
        self.statuses: dict[str, int] = {}
        self.qp_ms: list[float] = []
        self.qp_iterations: list[int] = []  # ADMM iterations of each tick (its work, alike on any load)
        self.tick_cpu_ms: list[
            float
        ] = []  # each tick's CPU time (this thread's: preemption by other work excluded)
        self.linearization_errors: list[float] = []

    def solve(self, problem: CentroidalProblem, t: float) -> CentroidalSolution:
        """Solves the tick's problem; returns the solution (kept for driving when ok)."""
        c0 = time.thread_time()
        sol = self.solver.solve(problem)
        self.tick_cpu_ms.append((time.thread_time() - c0) * 1e3)
        self.solver_ticks += 1
        self.statuses[sol.status] = self.statuses.get(sol.status, 0) + 1
        self.qp_ms.append(sol.qp_ms)
        self.qp_iterations.append(sol.qp_iterations)
        if np.isfinite(sol.linearization_error):
            self.linearization_errors.append(float(sol.linearization_error))
        if sol.ok:
            self.solution, self.t_solution = sol, t
        return sol

    def forces(self, t: float, stance: np.ndarray, out: np.ndarray) -> bool:
        """Writes the solution's contact forces (4,3) at t into out (zero off stance) and returns True, or returns
        False (a fallback tick) when no fresh good solution exists."""
        sol = self.solution
        if sol is None or t - self.t_solution > self.max_age_s:
            self.fallback_ticks += 1
            return False
        out[:] = sol.force_at(t)
        out[~stance] = 0.0
        return True

    def report(self, stage_times: dict[str, Any], balance_ticks: int) -> dict[str, Any]:
        """Returns the run report's "solver" section."""
        cen = stage_times.get("centroidal", {})
        lin = self.linearization_errors
        return {
            "tick_ms_p50": cen.get("p50_ms"),
            "tick_ms_p99": cen.get("p99_ms"),
            "qp_ms_p50": round(float(np.median(self.qp_ms)), 4) if self.qp_ms else None,
            "fallback_ticks": self.fallback_ticks,
            "balance_ticks": balance_ticks,
            "solver_ticks": self.solver_ticks,
            "statuses": dict(self.statuses),
            "linearization_error_p50": round(float(np.median(lin)), 6) if lin else None,
            "linearization_error_first4": [round(x, 6) for x in lin[:4]],
        }
