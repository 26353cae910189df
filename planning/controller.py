"""The one stateful object per simulated robot: composes the stages each tick and produces joint torques."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from planning.balance import BalanceController, BalanceParams, BodyTarget
from planning.centroidal.driver import SolverDriver
from planning.centroidal.problem import BodyState
from planning.centroidal.solver import CentroidalSolution
from planning.handler import ContactPlan, Handler, HandlerParams
from planning.maneuver.generator import ProblemGenerator
from planning.robot import RobotModel
from planning.sim.loop import Stage
from planning.sim.world import RobotState

BodyReferenceFn = Callable[[float], BodyTarget]


class _AllStance:
    """The contact plan of a maneuver whose feet never leave the ground."""

    def swing_at(self, leg: int, t: float) -> None:
        return None


@dataclass(frozen=True)
class ControllerParams:
    """Rates (Hz) of the stages and the parameters of each, composed at the top."""

    balance_rate_hz: float = 500.0  # phases + force distribution
    swing_rate_hz: float = 1000.0 / 3.0  # swing replanning every 3 ms
    centroidal_rate_hz: float = 50.0  # the centroidal solver (one linearization a tick)
    use_centroidal: bool = True  # False: the balance controller alone drives (no solver)
    solution_max_age_s: float = 0.05  # an ok solution older than this no longer drives
    # wall-clock budget of a solver tick (ms); over it the backup drives. None: no budget, so headless runs are
    # deterministic whatever the machine's load; live sessions that must keep real time set one.
    solver_time_budget_ms: float | None = None
    balance: BalanceParams = field(default_factory=BalanceParams)
    handler: HandlerParams = field(default_factory=HandlerParams)


class Controller:
    """Carries out a contact plan and a body reference: phases, forces, swings, torques.

    Stages declare their rates; the loop calls them in simulated time; ``actuate`` runs every physics step.
    The force source is the balance controller; the centroidal solver replaces it when its solution is good.
    """

    def __init__(
        self,
        robot: RobotModel,
        body_reference: BodyReferenceFn,
        params: ControllerParams | None = None,
        contact_plan: ContactPlan | None = None,
        generator: ProblemGenerator | None = None,
    ) -> None:
        self.robot = robot
        self.params = params or ControllerParams()
        self.body_reference = body_reference
        self.contact_plan: ContactPlan = contact_plan or _AllStance()
        self.balance = BalanceController(robot, self.params.balance)
        self.handler = Handler(robot, params=self.params.handler)
        self.f_des = np.zeros((4, 3))
        self.target: BodyTarget | None = None
        self._last_state: RobotState | None = None
        self.stages = [
            Stage("balance", self.params.balance_rate_hz, self._balance),
            Stage("swing", self.params.swing_rate_hz, self._swing),
        ]
        # the centroidal solver: its solution drives when good, the balance controller (backup) otherwise
        self.generator = generator if self.params.use_centroidal else None
        self.driver = (
            SolverDriver(robot, self.params.solver_time_budget_ms, self.params.solution_max_age_s)
            if self.generator is not None
            else None
        )
        if self.generator is not None:
            self.stages.insert(0, Stage("centroidal", self.params.centroidal_rate_hz, self._centroidal))

    @property
    def stance(self) -> np.ndarray:
        return self.handler.stance

    def _centroidal(self, s: RobotState) -> None:
        assert self.generator is not None and self.driver is not None
        if s.t == 0.0:
            self.handler.update_phases(s, self.contact_plan)
        state = BodyState(
            s.t, s.p_world_com.copy(), s.v_world_com.copy(), s.R_world_body.copy(), s.omega_world.copy()
        )
        feet = s.p_world_foot - np.array([0.0, 0.0, self.robot.foot_radius_m])
        sol = self.driver.solve(self.generator.problem_at(state, self.handler.stance.copy(), feet), s.t)
        if sol.ok:
            # the solver may move the touchdown of a swinging foot (within its adjust window): steer the swing there
            for td in sol.touchdowns:
                sw = self.contact_plan.swing_at(td.leg, s.t)
                if not td.planted and sw is not None and abs(td.t_nominal - sw.t_touchdown) < 1e-6:
                    moved = td.t if abs(td.t - td.t_nominal) > 0.005 else None
                    self.handler.set_touchdown(td.leg, td.p_world, moved)

    def _balance(self, s: RobotState) -> None:
        self.handler.update_phases(s, self.contact_plan)
        self.target = self.body_reference(s.t)
        stance = self.handler.stance
        if self.driver is not None and self.driver.forces(s.t, stance, self.f_des):
            np.subtract(s.p_world_foot, s.p_world_com, out=self.balance.r_com_foot)
            self.balance.r_com_foot[:, 2] -= self.robot.foot_radius_m
        else:
            mu = self.balance.params.mu * self.handler.friction_scale  # lowered after foot slips
            self.f_des[:] = self.balance.contact_forces(s, self.target, stance, mu=mu)

    def _swing(self, s: RobotState) -> None:
        v = None if self.target is None else self.target.v_world_body
        self.handler.plan_swings(s, v)

    @property
    def solution(self) -> CentroidalSolution | None:
        return None if self.driver is None else self.driver.solution

    def plan_overlays(self) -> dict[str, dict[str, Any]]:
        """Returns the studio's overlays: swing trajectories, contact forces, the solver's body plan and footholds."""
        s = self._last_state
        if s is None:
            return {}
        out = self.handler.overlays(self.f_des, s.p_world_foot)
        sol = self.solution
        if sol is not None and sol.p_world.shape[0] > 1:
            out["centroidal_com"] = {
                "kind": "polyline",
                "points": np.round(sol.p_world, 4).tolist(),
                "color": [0.6, 0.4, 1.0],
            }
            tds = [np.round(td.p_world, 4).tolist() for td in sol.touchdowns if not td.planted]
            out["solver_footholds"] = {"kind": "points", "points": tds, "color": [0.2, 0.8, 1.0]}
        return out

    def actuate(self, s: RobotState) -> np.ndarray:
        """Returns joint torques (4,3) for this physics step."""
        self._last_state = s
        return self.handler.torques(s, self.f_des, self.balance.r_com_foot)
