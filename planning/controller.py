"""The one stateful object per simulated robot: composes the stages each tick and produces joint torques."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from planning.balance import BalanceController, BalanceParams, BodyTarget
from planning.robot import RobotModel
from planning.sim.loop import Stage
from planning.sim.world import RobotState
from planning.stance import StanceHandler

BodyReferenceFn = Callable[[float], BodyTarget]


@dataclass(frozen=True)
class ControllerParams:
    """Rates (Hz) of the stages and the parameters of each, composed at the top."""

    balance_rate_hz: float = 500.0
    balance: BalanceParams = field(default_factory=BalanceParams)
    stance_damping: float = 0.5  # N·m·s/rad, joint damping on stance legs (quiets the legs' own modes)


class Controller:
    """Body-reference tracking with all feet down: balance (wrench → forces) and the stance handler (→ torques).

    Stages declare their rates; the loop calls them in simulated time. ``actuate`` runs every physics step.
    """

    def __init__(
        self, robot: RobotModel, body_reference: BodyReferenceFn, params: ControllerParams | None = None
    ):
        self.robot = robot
        self.params = params or ControllerParams()
        self.body_reference = body_reference
        self.balance = BalanceController(robot, self.params.balance)
        self.stance_handler = StanceHandler()
        self.stance = np.ones(4, dtype=bool)
        self.f_des = np.zeros((4, 3))
        self.tau = np.zeros((4, 3))
        self.target: BodyTarget | None = None
        self.stages = [Stage("balance", self.params.balance_rate_hz, self._balance)]

    def _balance(self, s: RobotState) -> None:
        self.target = self.body_reference(s.t)
        self.stance[:] = s.contact | self.stance  # all-feet-down maneuvers: keep every leg loaded
        self.f_des[:] = self.balance.contact_forces(s, self.target, self.stance)

    def actuate(self, s: RobotState) -> np.ndarray:
        """Returns joint torques (4,3) for this physics step."""
        r = self.balance.r_com_foot
        tau = self.stance_handler.solve(
            self.f_des,
            s.J_world_foot,
            self.stance,
            self.robot.tau_max,
            tau_bias_leg=s.tau_bias,
            mu=self.params.balance.mu,
            p_com_foot_world=r,
        )
        np.subtract(tau, self.params.stance_damping * s.qd, out=self.tau)
        np.clip(self.tau, -self.robot.tau_max, self.robot.tau_max, out=self.tau)
        return self.tau
