"""Steering mode's problem generator: the selected step path → the centroidal solver's contact schedule, footholds
and body targets (capture-point-step-path seed: "the selected path's next touchdowns become the contact schedule").
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from planning.centroidal.problem import (
    BodyModel,
    BodyState,
    BodyTargets,
    CentroidalProblem,
    ContactPhase,
    CostWeights,
)
from planning.centroidal.timegrid import make_time_grid
from planning.robot import RobotModel
from planning.steps.state import StepPath


@dataclass(frozen=True)
class WalkProblemParams:
    """Horizon, grid and weights of steering-mode problems."""

    # The horizon and its knots (the QP's size; WalkParams.centroidal's max_knots matches). 0.4 s (10 knots) in place
    # of 0.8 s (20): the centroidal tick 3.85 -> 3.3 ms CPU p50, the same tracking (trot 0.5 / 1.0 m/s and 0.3 m/s
    # at 0.4 rad/s, velocity RMS within 0.002 m/s; docs/agility-notes.md). The peer's MPC plans one gait period
    # (0.33 s, 16 knots).
    horizon_s: float = 0.4  # s
    base_dt_s: float = 0.05  # s
    max_knots: int = 10
    # an event this close after the knot before it moves onto a knot (make_time_grid): no ms-long QP steps
    min_event_gap_s: float = 0.012
    w_position_xy: float = 1.0  # per m²: the command is about velocity, so position is held loosely
    w_position_z: float = 200.0  # per m²
    w_orientation: float = 200.0  # per rad²
    adjust_radius_m: float = 0.02  # the solver may refine each selected foothold this much
    fz_min_n: float = 8.0
    fz_max_n: float = 600.0
    mu: float = 0.6
    w_velocity: float = 40.0  # per (m/s)²·s: steering commands a velocity


class StepPathProblems:
    """Builds a centroidal problem from the latest step path, the measured contacts and the body height target."""

    def __init__(self, robot: RobotModel, params: WalkProblemParams | None = None) -> None:
        self.params = params or WalkProblemParams()
        self.model = BodyModel.from_robot(robot)
        self.weights = CostWeights(velocity=self.params.w_velocity)

    def problem_at(
        self,
        state: BodyState,
        path: StepPath,
        stance: np.ndarray,
        p_world_contact: np.ndarray,
        height_m: float,
    ) -> CentroidalProblem:
        """Returns the problem at state.t: current stances from the measured feet, then the path's touchdowns."""
        pr = self.params
        t = state.t
        end = t + pr.horizon_s
        phases: list[ContactPhase] = []
        for leg in range(4):
            if stance[leg]:
                lo = float(path.t_liftoff_now[leg])
                lo = math.inf if not np.isfinite(lo) else max(lo, t + 1e-3)
                phases.append(ContactPhase(leg, t - 1.0, lo, p_world_contact[leg], key=f"{leg}@now"))
        for k in range(path.n_touchdowns):
            td = float(path.t_touchdown[k])
            if td >= end:
                continue
            lo = float(path.t_liftoff[k])
            lo = math.inf if not np.isfinite(lo) else lo
            phases.append(
                ContactPhase(
                    int(path.leg[k]),
                    max(td, t + 1e-3),
                    lo,
                    path.p_world_touchdown[k],
                    adjust_radius_m=pr.adjust_radius_m,
                )
            )
        events = sorted(
            {p.t_touchdown for p in phases if p.t_touchdown > t}
            | {p.t_liftoff for p in phases if t < p.t_liftoff < end}
        )
        grid = make_time_grid(
            t, np.array(events), end, pr.base_dt_s, max_knots=pr.max_knots, min_event_gap_s=pr.min_event_gap_s
        )
        body = path.body
        K = grid.size
        xy = body.position(grid)
        yaw = body.yaw(grid)
        vxy = body.velocity_world(grid)
        ground = (
            float(np.mean(p_world_contact[stance, 2]))
            if stance.any()
            else float(np.min(p_world_contact[:, 2]))
        )
        cx, cy, cz = self.model.p_body_com.tolist()
        # yaw_R per knot, stacked: [[c, -s, 0], [s, c, 0], [0, 0, 1]]
        c, sn = np.cos(yaw), np.sin(yaw)
        R = np.zeros((K, 3, 3))
        R[:, 0, 0] = c
        R[:, 0, 1] = -sn
        R[:, 1, 0] = sn
        R[:, 1, 1] = c
        R[:, 2, 2] = 1.0
        p = np.empty((K, 3))
        p[:, 0] = xy[:, 0] + (c * cx - sn * cy)
        p[:, 1] = xy[:, 1] + (sn * cx + c * cy)
        p[:, 2] = ground + height_m + cz
        v = np.zeros((K, 3))
        v[:, :2] = vxy
        om = np.zeros((K, 3))
        om[:, 2] = body.yaw_rate
        wp = np.tile([pr.w_position_xy, pr.w_position_xy, pr.w_position_z], (K, 1))
        wo = np.full((K, 3), pr.w_orientation)
        return CentroidalProblem(
            t_knots=grid,
            initial=state,
            phases=tuple(phases),
            targets=BodyTargets(p, R, wp, wo, v, om),
            model=self.model,
            mu=pr.mu,
            fz_min_N=pr.fz_min_n,
            fz_max_N=pr.fz_max_n,
            weights=self.weights,
        )
