"""The one stateful object per simulated robot: composes the stages each tick and produces joint torques."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from planning.balance import BalanceController, BalanceParams, BodyTarget
from planning.handler import ContactPlan, Handler, HandlerParams
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
    ) -> None:
        self.robot = robot
        self.params = params or ControllerParams()
        self.body_reference = body_reference
        self.contact_plan: ContactPlan = contact_plan or _AllStance()
        self.balance = BalanceController(robot, self.params.balance)
        self.handler = Handler(robot, params=self.params.handler)
        self.f_des = np.zeros((4, 3))
        self.target: BodyTarget | None = None
        self.stages = [
            Stage("balance", self.params.balance_rate_hz, self._balance),
            Stage("swing", self.params.swing_rate_hz, self._swing),
        ]

    @property
    def stance(self) -> np.ndarray:
        return self.handler.stance

    def _balance(self, s: RobotState) -> None:
        self.handler.update_phases(s, self.contact_plan)
        self.target = self.body_reference(s.t)
        self.f_des[:] = self.balance.contact_forces(s, self.target, self.handler.stance)

    def _swing(self, s: RobotState) -> None:
        v = None if self.target is None else self.target.v_world_body
        self.handler.plan_swings(s, v)

    def actuate(self, s: RobotState) -> np.ndarray:
        """Returns joint torques (4,3) for this physics step."""
        return self.handler.torques(s, self.f_des, self.balance.r_com_foot)
