"""Centroidal planning (dynamic-planning-controller seed): time grid, solver-facing problem, linearized QP solver.

One tick: ``reconcile_contacts`` (measured contacts win) → ``make_time_grid`` (events on knots) →
``CentroidalProblem`` (measured state + contact phases + targets) → ``CentroidalSolver.solve`` →
``CentroidalSolution`` (forces, body trajectory, adjusted touchdown places and times, ``ok``,
``linearization_error``). ``scenarios.Scenario.problem_at`` shows the whole chain; ``bench.bench_centroidal_tick``
times it.

Choices, in one place:
- Model: single rigid body; forces constant per interval at fixed contact points; the discrete map is exact for
  the translation and accounts for the moment arm drifting within a step (dynamics.py).
- Orientation: R = exp(θ) R̄ about the linearization point, θ a world-frame rotation vector (small by
  construction: the next tick re-centres). Jacobians are analytic and checked against finite differences.
- Real-time iteration: one linearization a tick about the previous solution (resampled in time), which is also
  the warm start. The force × moment-arm products are linearized, so the model error is the product of the two
  estimates' errors (tests: it scales with ε²).
- Cuts: leg-length circle and friction cone are checked on each solution; tangent planes go into reserved rows
  and the QP is re-solved within the tick (the pyramid also turns to face the force it must bound).
- Timing: a convex relaxation on the grid — a contact variable c ∈ [0, 1] per interval and leg, free and
  monotone inside a touchdown/liftoff window, with c·fz_min <= f_n <= c·fz_max and a linear cost that sums to
  w·Δt² for a shift Δt (_schedule.py). One QP a tick, no enumeration of schedules.
- Solver: OSQP, set up once per size (a few sizes so short problems are not padded), updated in place, polished
  (ADMM alone at 1e-4 leaves forces tens of newtons off); the forces match Clarabel at 1e-9 to well under 1 N.
"""

from planning.centroidal.integrate import TrajectoryError, linearization_error, model_error
from planning.centroidal.problem import (
    LEG_NAMES,
    BodyModel,
    BodyState,
    BodyTargets,
    CentroidalProblem,
    ContactPhase,
    CostWeights,
    Objective,
    ProblemError,
    phase_event_times,
    reconcile_contacts,
)
from planning.centroidal.solver import (
    AdjustedLiftoff,
    AdjustedTouchdown,
    CentroidalParams,
    CentroidalSolution,
    CentroidalSolver,
)
from planning.centroidal.timegrid import derive_base_dt, make_time_grid

__all__ = [
    "LEG_NAMES",
    "AdjustedLiftoff",
    "AdjustedTouchdown",
    "BodyModel",
    "BodyState",
    "BodyTargets",
    "CentroidalParams",
    "CentroidalProblem",
    "CentroidalSolution",
    "CentroidalSolver",
    "ContactPhase",
    "CostWeights",
    "Objective",
    "ProblemError",
    "TrajectoryError",
    "derive_base_dt",
    "linearization_error",
    "make_time_grid",
    "model_error",
    "phase_event_times",
    "reconcile_contacts",
]
