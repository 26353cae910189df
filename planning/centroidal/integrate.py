"""The integrated solution: a plan's forces run through nonlinear SRB dynamics, and how far the plan is from it.

``linearization_error`` (FIG. 2D, [0057]) compares the QP's trajectory with the nonlinear discrete map driven by
the same forces at the same contact points: the two share their discretization, so what is left is the error of
the linearization alone, which shrinks quadratically as the linearization point approaches the solution.
``model_error`` compares instead with the continuous equations (RK4, fine steps): the discretization error of the
model, which does not shrink with iterations and is reported separately.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from planning.centroidal import _so3
from planning.centroidal.dynamics import rollout_continuous, rollout_discrete
from planning.centroidal.problem import BodyModel, BodyState


@dataclass(frozen=True)
class TrajectoryError:
    """Per-knot distances between two trajectories: position (m), orientation (rad), ω (rad/s); and the metric.

    metric: max over knots of position + error_length_m × orientation, in meters (a rotation error counts as
    the displacement it causes at a hip about error_length_m from the CoM).
    """

    position_m: np.ndarray
    orientation_rad: np.ndarray
    omega_rad_s: np.ndarray
    metric: float


def compare(
    p_a: np.ndarray,
    R_a: np.ndarray,
    w_a: np.ndarray,
    p_b: np.ndarray,
    R_b: np.ndarray,
    w_b: np.ndarray,
    error_length_m: float = 0.35,
) -> TrajectoryError:
    """Returns the distances between trajectories a and b (K knots each)."""
    e_p = _so3.norm(p_a - p_b)
    e_r = _so3.norm(_so3.log(R_a @ np.swapaxes(R_b, -1, -2)))
    e_w = _so3.norm(w_a - w_b)
    return TrajectoryError(e_p, e_r, e_w, float(np.max(e_p + error_length_m * e_r)))


def integrate_plan(
    initial: BodyState,
    f_world: np.ndarray,
    p_world_foot: np.ndarray,
    t_knots: np.ndarray,
    model: BodyModel,
    gravity: np.ndarray,
    continuous: bool = False,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Returns knot states (p, v, R, ω) from the initial state under piecewise-constant forces (N,4,3) N applied at
    contact points (N,4,3); the discrete map of the QP (default) or the continuous equations."""
    fn = rollout_continuous if continuous else rollout_discrete
    return fn(
        initial.p_world,
        initial.v_world,
        initial.R_world_body,
        initial.omega_world,
        f_world,
        p_world_foot,
        t_knots[1:] - t_knots[:-1],
        model.mass_kg,
        model.inertia_body,
        gravity,
    )


def linearization_error(solution, problem, error_length_m: float = 0.35) -> TrajectoryError:  # noqa: ANN001
    """Returns how far the solution's trajectory is from the nonlinear discrete rollout of its own forces."""
    P, V, R, W = integrate_plan(
        problem.initial,
        solution.f_world,
        solution.p_world_foot,
        solution.t_knots,
        problem.model,
        problem.gravity,
    )
    return compare(solution.p_world, solution.R_world_body, solution.omega_world, P, R, W, error_length_m)


def model_error(solution, problem, error_length_m: float = 0.35) -> TrajectoryError:  # noqa: ANN001
    """Returns how far the solution's trajectory is from the continuous SRB equations under its forces."""
    P, V, R, W = integrate_plan(
        problem.initial,
        solution.f_world,
        solution.p_world_foot,
        solution.t_knots,
        problem.model,
        problem.gravity,
        continuous=True,
    )
    return compare(solution.p_world, solution.R_world_body, solution.omega_world, P, R, W, error_length_m)


def advance(
    state: BodyState,
    solution,  # noqa: ANN001
    dt: float,
    model: BodyModel,
    gravity: np.ndarray,
    f_disturbance: np.ndarray | None = None,
) -> BodyState:
    """Returns the state dt seconds later when the plan's forces drive a rigid body (the continuous equations).

    A stand-in plant for tests and the bench: the forces of the plan's intervals that overlap [t, t + dt] act at
    their contact points; f_disturbance (3,) N optionally pushes at the CoM.
    """
    t0 = state.t
    tk = solution.t_knots
    cuts = np.unique(np.concatenate([[t0, t0 + dt], tk[(tk > t0) & (tk < t0 + dt)]]))
    mids = 0.5 * (cuts[:-1] + cuts[1:])
    ks = np.clip(np.searchsorted(tk, mids, side="right") - 1, 0, solution.f_world.shape[0] - 1)
    f = solution.f_world[ks].copy()
    feet = solution.p_world_foot[ks].copy()
    if f_disturbance is not None:
        # A push at the CoM: an extra "foot" would add a torque; add it to the force sum through gravity instead.
        gravity = gravity + np.asarray(f_disturbance, dtype=float) / model.mass_kg
    P, V, R, W = rollout_continuous(
        state.p_world,
        state.v_world,
        state.R_world_body,
        state.omega_world,
        f,
        feet,
        np.diff(cuts),
        model.mass_kg,
        model.inertia_body,
        gravity,
    )
    return BodyState(t0 + dt, P[-1], V[-1], R[-1], W[-1])
