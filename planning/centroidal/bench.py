"""Benchmark of the centroidal tick: linearize + assemble + solve (+ cuts) + integrate, on a trot with pushes.

``bench_centroidal_tick()`` runs a closed loop (rigid-body plant, 50 Hz ticks) of a 0.3 m/s trot with sideways
pushes, so the plan keeps rotating and re-linearizing, and reports per-tick times beside the time spent inside
OSQP, the contact-force error against a tight reference solve (Clarabel, 1e-9) of the same QPs, and the
linearization error of the first four solutions after a cold start from a disturbed state.
"""

from __future__ import annotations

import time
from dataclasses import replace

import numpy as np

from planning.centroidal import _so3
from planning.centroidal.problem import BodyState
from planning.centroidal.scenarios import Scenario, default_model, run, standing, trot
from planning.centroidal.solver import CentroidalParams, CentroidalSolver


def _push(t: float) -> np.ndarray:
    """Sideways and fore-aft pushes of 60 N for 0.1 s every 0.7 s, alternating direction."""
    k = int(t / 0.7)
    if t - 0.7 * k < 0.1 and k > 0:
        return np.array([30.0 * (-1) ** k, 60.0 * (-1) ** (k // 2), 0.0])
    return np.zeros(3)


def bench_centroidal_tick(n_ticks: int = 300, max_knots: int = 21, reference_every: int = 10) -> dict:
    """Returns tick and solver timings (ms), knots, force error vs Clarabel (N) and convergence of the error."""
    model = default_model()
    params = CentroidalParams(max_knots=max_knots)
    sc: Scenario = replace(
        trot(model, vx=0.3, duration_s=n_ticks * 0.02 + 1.0), max_knots=max_knots, horizon_s=1.8
    )
    solver = CentroidalSolver(params)
    # Warm-up (imports, first factorization), not timed.
    run(sc, solver, duration_s=0.1)
    solver.reset()

    ticks: list[float] = []
    qps: list[float] = []
    cpu: list[float] = []
    knots: list[int] = []
    errs: list[float] = []
    lin: list[float] = []
    ok = 0
    state = sc.start
    from planning.centroidal.integrate import advance

    reference = None
    try:
        import clarabel  # noqa: F401 - reference_forces imports it only when called

        from planning.centroidal.reference import reference_forces

        reference = reference_forces
    except ImportError:  # clarabel is a development dependency: `footfall bench` runs without it
        reference = None
    for i in range(n_ticks):
        pr = sc.problem_at(state)
        c0 = time.process_time()
        sol = solver.solve(pr)
        cpu.append((time.process_time() - c0) * 1e3)
        ticks.append(sol.tick_ms)
        qps.append(sol.qp_ms)
        knots.append(pr.n_knots)
        lin.append(sol.linearization_error)
        ok += int(sol.ok)
        if reference is not None and i % reference_every == 0 and sol.f_world.shape[0]:
            f_ref, _ = reference(solver)
            errs.append(float(np.max(np.abs(f_ref - sol.f_world))))
        if sol.f_world.shape[0] == 0:
            break
        state = _advance_checked(advance, state, sol, sc, pr, _push(state.t))

    conv_loop, conv_fixed = _convergence(model)
    t = np.array(ticks)
    q = np.array(qps)
    return {
        "p50_ms": float(np.percentile(t, 50)),
        "p99_ms": float(np.percentile(t, 99)),
        "bare_solver_p50_ms": float(np.percentile(q, 50)),
        "bare_solver_p99_ms": float(np.percentile(q, 99)),
        "cpu_p50_ms": float(np.percentile(cpu, 50)),
        "overhead_ratio_p50": float(np.percentile(t / np.maximum(q, 1e-9), 50)),
        "knots": int(np.median(knots)),
        "ticks": len(ticks),
        "ok_fraction": ok / max(len(ticks), 1),
        "force_error_p50_N": float(np.percentile(errs, 50)) if errs else None,
        "force_error_max_N": float(np.max(errs)) if errs else None,
        "linearization_error_p50_m": float(np.percentile(lin, 50)),
        "linearization_error_by_iteration": conv_loop,
        "linearization_error_by_iteration_fixed_problem": conv_fixed,
    }


def _advance_checked(advance, state, sol, sc, pr, push):  # noqa: ANN001
    return advance(state, sol, 0.02, sc.model, pr.gravity, push)


def _convergence(model) -> tuple[list[float], list[float]]:  # noqa: ANN001
    """Linearization error (m) of the 1st..4th solutions after a cold start from a disturbed stand.

    First in the loop (the state moves on between ticks), then re-solving one problem (pure iterations).
    """
    start = BodyState(
        0.0,
        np.array([0.02, -0.01, 0.50]),
        np.array([0.3, -0.2, 0.1]),
        _so3.rpy_to_R(np.radians([8.0, -6.0, 4.0])),
        np.array([1.0, -0.8, 0.5]),
    )
    sc = replace(standing(model), start=start)
    params = CentroidalParams(time_budget_ms=1e3)
    log = run(sc, CentroidalSolver(params), duration_s=0.08, tick_s=0.02)
    loop = [float(s.linearization_error) for s in log.solutions[:4]]
    solver = CentroidalSolver(params)
    pr = sc.problem_at(start)
    fixed = [float(solver.solve(pr).linearization_error) for _ in range(4)]
    return loop, fixed


if __name__ == "__main__":
    import json

    print(json.dumps(bench_centroidal_tick(), indent=2))
