"""Benchmarks of the stance handler and the force distributor on realistic standing/trotting inputs.

Inputs: Spot's nominal-stance Jacobians and foot positions (planning.robot), or random well-conditioned ones when
the robot model cannot be loaded; contact masks cycling through standing and the two trot pairs; desired wrenches
near gravity compensation with noise, and desired forces from the distributor (so the handler sees what the
planner would hand it), a tenth of them scaled past the torque limits.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from planning.forces import N_LEGS, ForceDistributor
from planning.stance import StanceHandler, StanceHandlerParams

GRAVITY_MPS2 = 9.81
_MASKS = np.array(
    [
        [True, True, True, True],  # stand
        [True, False, False, True],  # trot: FL + RR
        [False, True, True, False],  # trot: FR + RL
    ]
)


class _TimedSolver:
    """Wraps an OSQP object and records the wall time of each `.solve()` (the bare solver time)."""

    def __init__(self, inner: Any):
        self.inner = inner
        self.times_s: list[float] = []

    def solve(self, *args: Any, **kwargs: Any) -> Any:
        t0 = time.perf_counter()
        res = self.inner.solve(*args, **kwargs)
        self.times_s.append(time.perf_counter() - t0)
        return res

    def __getattr__(self, name: str) -> Any:
        return getattr(self.inner, name)


def _robot_inputs(seed: int) -> tuple[float, np.ndarray, np.ndarray, np.ndarray, str]:
    """Return mass [kg], J_world_leg (4,3,3), p_com_foot_world (4,3) [m], tau_max (4,3) [N·m], source name."""
    try:
        from planning.robot import load_robot

        robot = load_robot("spot")
        J = np.empty((N_LEGS, 3, 3))
        for leg in range(N_LEGS):
            p_body_center = robot.nominal_foot_body[leg] + np.array([0.0, 0.0, robot.foot_radius_m])
            J[leg] = robot.jacobian_leg(leg, robot.ik_leg(leg, p_body_center))
        return (
            float(robot.mass_kg),
            J,
            np.array(robot.nominal_foot_body, float),
            np.array(robot.tau_max),
            "spot",
        )
    except Exception:  # the robot package is optional for this benchmark; fall back to synthetic legs
        rng = np.random.default_rng(seed)
        J = np.empty((N_LEGS, 3, 3))
        for leg in range(N_LEGS):
            Q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
            J[leg] = Q * rng.uniform(0.2, 0.5, size=3)  # singular values 0.2–0.5 m: well conditioned
        p = np.array([[0.3, 0.165, -0.52], [0.3, -0.165, -0.52], [-0.3, 0.165, -0.52], [-0.3, -0.165, -0.52]])
        return 32.0, J, p, np.tile([45.0, 45.0, 115.0], (N_LEGS, 1)), "random"


def _summary(times_s: list[float], cpu_s: list[float], bare_s: list[float], source: str) -> dict[str, Any]:
    """Wall-time percentiles; p99_cpu_ms (this thread's CPU time) tells the code's tail from preemption on a busy
    machine."""
    t = np.asarray(times_s) * 1e3
    b = np.asarray(bare_s) * 1e3
    return {
        "p50_ms": float(np.percentile(t, 50)),
        "p99_ms": float(np.percentile(t, 99)),
        "p99_cpu_ms": float(np.percentile(np.asarray(cpu_s) * 1e3, 99)),
        "bare_solver_p50_ms": float(np.percentile(b, 50)) if b.size else float("nan"),
        "n": int(t.size),
        "inputs": source,
    }


def _wrenches(n: int, mass_kg: float, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    mg = mass_kg * GRAVITY_MPS2
    force = np.array([0.0, 0.0, mg]) + rng.normal(scale=[0.1 * mg, 0.1 * mg, 0.2 * mg], size=(n, 3))
    torque = rng.normal(scale=[5.0, 8.0, 3.0], size=(n, 3))
    return force, torque


def bench_force_distribution(n: int = 500, seed: int = 0) -> dict[str, Any]:
    """Return {"p50_ms", "p99_ms", "bare_solver_p50_ms", ...} of ForceDistributor.solve over n ticks."""
    mass, _, p_com_foot, _, source = _robot_inputs(seed)
    rng = np.random.default_rng(seed)
    force, torque = _wrenches(n, mass, rng)
    dist = ForceDistributor(mass)
    timed = _TimedSolver(dist._solver)
    dist._solver = timed  # type: ignore[assignment]
    times: list[float] = []
    cpu: list[float] = []
    for k in range(n):
        t0, c0 = time.perf_counter(), time.thread_time()
        dist.solve(
            force[k], torque[k], p_com_foot, _MASKS[(k // 20) % 3], mu=0.6, fz_min_n=5.0, fz_max_n=600.0
        )
        times.append(time.perf_counter() - t0)
        cpu.append(time.thread_time() - c0)
    return _summary(times, cpu, timed.times_s, source)


def bench_stance_handler(n: int = 500, seed: int = 0, skip_feasible: bool = False) -> dict[str, Any]:
    """Return {"p50_ms", "p99_ms", "bare_solver_p50_ms", ...} of StanceHandler.solve over n ticks.

    skip_feasible=False times the QP path on every tick (the bare solver's problem); True times what the loop runs,
    where plans that already meet every limit skip the solve.
    """
    mass, J, p_com_foot, tau_max, source = _robot_inputs(seed)
    rng = np.random.default_rng(seed)
    force, torque = _wrenches(n, mass, rng)
    dist = ForceDistributor(mass)
    masks = [_MASKS[(k // 20) % 3] for k in range(n)]
    f_des = np.empty((n, N_LEGS, 3))
    for k in range(n):
        f_des[k] = dist.solve(force[k], torque[k], p_com_foot, masks[k])[0]
    f_des[::10] *= 4.0  # a tenth of the ticks ask for more than the joints can give
    J_ticks = J[None] * (1.0 + 0.05 * rng.normal(size=(n, N_LEGS, 3, 3)))  # the legs move a little
    handler = StanceHandler(StanceHandlerParams(skip_feasible=skip_feasible))
    timed = _TimedSolver(handler._solver)
    handler._solver = timed  # type: ignore[assignment]
    times: list[float] = []
    cpu: list[float] = []
    for k in range(n):
        t0, c0 = time.perf_counter(), time.thread_time()
        handler.solve(f_des[k], J_ticks[k], masks[k], tau_max, mu=0.6, p_com_foot_world=p_com_foot)
        times.append(time.perf_counter() - t0)
        cpu.append(time.thread_time() - c0)
    return _summary(times, cpu, timed.times_s, source)


if __name__ == "__main__":
    print("force distribution", bench_force_distribution())
    print("stance handler", bench_stance_handler())
