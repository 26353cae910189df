"""Small built-in scenarios for the centroidal solver: standing, trot, jump, three legs, a drop; and a loop to run them.

A scenario is a whole contact timeline plus body keyframes (what a maneuver would give after gait expansion); each
tick ``problem_at(state)`` cuts the receding horizon out of it: the time grid, the targets, the phases. ``run``
closes the loop on a rigid-body plant (``integrate.advance``), which is what the tests and the bench use; the real
loop (MuJoCo, stance handler, swing legs) lives in planning/sim.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np

from planning.centroidal import _so3
from planning.centroidal.integrate import advance
from planning.centroidal.problem import (
    BodyModel,
    BodyState,
    BodyTargets,
    CentroidalProblem,
    ContactPhase,
    CostWeights,
    Objective,
    phase_event_times,
    reconcile_contacts,
)
from planning.centroidal.solver import CentroidalSolution, CentroidalSolver
from planning.centroidal.timegrid import make_time_grid

Keyframe = tuple[float, np.ndarray, np.ndarray, float]  # t s, p_world (3,), R_world_body (3,3), weight

_SIGNS = np.array([[1.0, 1.0], [1.0, -1.0], [-1.0, 1.0], [-1.0, -1.0]])  # FL, FR, RL, RR


def default_model() -> BodyModel:
    """Returns the body model of the shipped Spot-class robot."""
    from planning.robot import load_robot

    return BodyModel.from_robot(load_robot("spot"))


def nominal_feet(x: float = 0.30, y: float = 0.165) -> np.ndarray:
    """Returns the nominal contact points (4,3) of a robot standing at the origin."""
    out = np.zeros((4, 3))
    out[:, :2] = _SIGNS * [x, y]
    return out


@dataclass(frozen=True)
class Scenario:
    """A contact timeline with keyframes, cut into a receding-horizon problem each tick."""

    name: str
    model: BodyModel
    start: BodyState
    phases: tuple[ContactPhase, ...]
    keyframes: tuple[Keyframe, ...]
    duration_s: float
    objectives: tuple[Objective, ...] = ()
    weights: CostWeights = field(default_factory=CostWeights)
    mu: float = 0.6
    fz_min_N: float = 10.0
    fz_max_N: float = 600.0
    horizon_s: float = 1.2
    base_dt: float = 0.05
    max_knots: int = 24
    running_weight: float = 20.0

    def problem_at(
        self,
        state: BodyState,
        contact_measured: np.ndarray | None = None,
        p_world_foot_measured: np.ndarray | None = None,
        timing: bool = True,
    ) -> CentroidalProblem:
        """Returns the problem for a tick at state.t; measured contacts (4,) and points (4,3) win over the plan."""
        phases = self.phases
        if not timing:
            phases = tuple(
                replace(p, touchdown_window_s=(0.0, 0.0), liftoff_window_s=(0.0, 0.0)) for p in phases
            )
        if contact_measured is not None and p_world_foot_measured is not None:
            phases = reconcile_contacts(phases, state.t, contact_measured, p_world_foot_measured)
        end = state.t + self.horizon_s
        # Only the phases that can touch the horizon (windows included) go into the problem.
        phases = tuple(
            p
            for p in phases
            if p.t_liftoff + p.liftoff_window_s[1] > state.t and p.t_touchdown - p.touchdown_window_s[0] < end
        )
        grid = make_time_grid(state.t, phase_event_times(phases), end, self.base_dt, max_knots=self.max_knots)
        targets = BodyTargets.from_keyframes(grid, state, self.keyframes, self.running_weight)
        return CentroidalProblem(
            t_knots=grid,
            initial=state,
            phases=phases,
            targets=targets,
            model=self.model,
            mu=self.mu,
            fz_min_N=self.fz_min_N,
            fz_max_N=self.fz_max_N,
            weights=self.weights,
            objectives=self.objectives,
        )


def _pose(model: BodyModel, x: float, y: float, z: float, roll_deg: float = 0.0, pitch_deg: float = 0.0,
          yaw_deg: float = 0.0) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """Returns the CoM position and orientation of a trunk pose (x, y, z m; roll, pitch, yaw degrees)."""
    R = _so3.rpy_to_R(np.radians([roll_deg, pitch_deg, yaw_deg]))
    return np.array([x, y, z]) + R @ model.p_body_com, R


def _start(model: BodyModel, z: float = 0.52, vz: float = 0.0) -> BodyState:
    """Returns the state of a level trunk at height z (m) over the origin, falling at vz m/s."""
    p, R = _pose(model, 0.0, 0.0, z)
    return BodyState(0.0, p, np.array([0.0, 0.0, vz]), R, np.zeros(3))


def standing(model: BodyModel | None = None) -> Scenario:
    """Four feet planted; the body dips, pitches and yaws to a keyframe, then returns."""
    model = model or default_model()
    feet = nominal_feet()
    phases = tuple(ContactPhase(i, -1.0, math.inf, feet[i]) for i in range(4))
    p1, R1 = _pose(model, 0.03, 0.02, 0.46, 0.0, 10.0, 8.0)
    p2, R2 = _pose(model, 0.0, 0.0, 0.52)
    return Scenario(
        "standing", model, _start(model), phases, ((0.6, p1, R1, 200.0), (1.4, p2, R2, 200.0)), 2.0
    )


def trot(
    model: BodyModel | None = None,
    cycle_s: float = 0.5,
    duration_s: float = 3.0,
    vx: float = 0.0,
    adjust_radius_m: float = 0.04,
) -> Scenario:
    """Diagonal pairs alternate (FL+RR, then FR+RL), duty 0.5, after a 0.2 s four-leg start; vx m/s forward.

    Each touchdown is planned under its hip at mid-stance; the solver may move it within adjust_radius_m.
    """
    model = model or default_model()
    feet = nominal_feet()
    half = 0.5 * cycle_s
    t_start = 0.2
    phases: list[ContactPhase] = []
    for i in range(4):
        pair_a = i in (0, 3)
        # Pair B lifts first at t_start; pair A stays down for the first half cycle.
        t = t_start + (half if pair_a else 0.0)
        phases.append(ContactPhase(i, -1.0, t, feet[i]))
        t += half
        while t < duration_s + 2.0:
            at = feet[i] + [vx * (min(t, duration_s) + 0.5 * half), 0.0, 0.0]
            phases.append(ContactPhase(i, t, t + half, at, adjust_radius_m=adjust_radius_m))
            t += 2 * half
    p, R = _pose(model, vx * duration_s, 0.0, 0.52)
    return Scenario("trot", model, _start(model), tuple(phases), ((duration_s, p, R, 20.0),), duration_s)


def jump(model: BodyModel | None = None) -> Scenario:
    """Crouch, push off at 0.35 s, 0.2 s of flight (no forces, ballistic), land at 0.55 s where planned ±5 cm."""
    model = model or default_model()
    feet = nominal_feet()
    t_off, t_land = 0.35, 0.55
    phases = []
    for i in range(4):
        phases.append(ContactPhase(i, -1.0, t_off, feet[i]))
        phases.append(ContactPhase(i, t_land, math.inf, feet[i], adjust_radius_m=0.05))
    kf = (
        (0.2, *_pose(model, 0.0, 0.0, 0.47), 50.0),
        (0.45, *_pose(model, 0.0, 0.0, 0.60), 300.0),
        (1.2, *_pose(model, 0.0, 0.0, 0.52), 100.0),
    )
    return Scenario("jump", model, _start(model), tuple(phases), kf, 1.6)


def three_leg(model: BodyModel | None = None, leg: int = 0) -> Scenario:
    """Three feet down while one leg (FL by default) waves from 0.5 s to 1.7 s; the body shifts over the others."""
    model = model or default_model()
    feet = nominal_feet()
    phases = []
    for i in range(4):
        if i == leg:
            phases.append(ContactPhase(i, -1.0, 0.5, feet[i]))
            phases.append(ContactPhase(i, 1.7, math.inf, feet[i], adjust_radius_m=0.03))
        else:
            phases.append(ContactPhase(i, -1.0, math.inf, feet[i]))
    others = feet[[j for j in range(4) if j != leg]]
    cx, cy = others[:, :2].mean(axis=0) * 0.8
    kf = (
        (0.45, *_pose(model, cx, cy, 0.50), 50.0),
        (1.7, *_pose(model, cx, cy, 0.50), 50.0),
        (2.3, *_pose(model, 0.0, 0.0, 0.52), 100.0),
    )
    return Scenario("three_leg", model, _start(model), tuple(phases), kf, 2.5, running_weight=10.0)


def drop(
    model: BodyModel | None = None,
    z0: float = 0.62,
    vz0: float = -1.0,
    t_touchdown: float = 0.25,
    early_s: float = 0.2,
    late_s: float = 0.05,
) -> Scenario:
    """Falling with all feet in the air; nominal touchdown at t_touchdown with a window (early_s, late_s).

    With the default numbers the nominal touchdown comes too late: the body would be below the legs' reach, so
    only an earlier touchdown makes the problem feasible.
    """
    model = model or default_model()
    feet = nominal_feet()
    phases = tuple(
        ContactPhase(i, t_touchdown, math.inf, feet[i], touchdown_window_s=(early_s, late_s))
        for i in range(4)
    )
    p, R = _pose(model, 0.0, 0.0, 0.52)
    return Scenario(
        "drop", model, _start(model, z0, vz0), phases, ((0.8, p, R, 100.0),), 1.5, running_weight=20.0
    )


SCENARIOS: dict[str, Callable[..., Scenario]] = {
    "standing": standing,
    "trot": trot,
    "jump": jump,
    "three_leg": three_leg,
    "drop": drop,
}


@dataclass
class RunLog:
    """What a closed-loop run recorded, one entry per tick."""

    states: list[BodyState] = field(default_factory=list)
    solutions: list[CentroidalSolution] = field(default_factory=list)
    problems: list[CentroidalProblem] = field(default_factory=list)


def run(
    scenario: Scenario,
    solver: CentroidalSolver,
    duration_s: float | None = None,
    tick_s: float = 0.02,
    push: Callable[[float], np.ndarray] | None = None,
    keep_problems: bool = False,
) -> RunLog:
    """Returns the log of a closed loop: each tick solve, then drive a rigid body with the plan's forces.

    When a solve fails the previous plan keeps driving (the backup); push(t) -> (3,) N adds a force at the CoM.
    """
    log = RunLog()
    state = scenario.start
    last: CentroidalSolution | None = None
    T = scenario.duration_s if duration_s is None else duration_s
    n = int(round(T / tick_s))
    for _ in range(n):
        pr = scenario.problem_at(state)
        sol = solver.solve(pr)
        log.states.append(state)
        log.solutions.append(sol)
        if keep_problems:
            log.problems.append(pr)
        drive = sol if sol.f_world.shape[0] else last
        if drive is None:
            break
        if sol.f_world.shape[0]:
            last = sol
        fd = push(state.t) if push is not None else None
        state = advance(state, drive, tick_s, scenario.model, pr.gravity, fd)
    return log
