"""Balance controller: body pose/velocity feedback → desired wrench → contact forces (QP).

It is both the controller of maneuvers whose feet stay down and the *backup controller* that drives while the
centroidal solver's solution is not yet good enough (dynamic-planning-controller seed). The stance handler turns its
forces into joint torques.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from planning.forces import ForceDistributor, ForceDistributorParams
from planning.geometry import so3_log
from planning.robot import RobotModel
from planning.sim.world import RobotState

GRAVITY = np.array([0.0, 0.0, -9.81])  # m/s²


@dataclass(frozen=True)
class BalanceParams:
    """Gains of the body feedback (per unit mass / inertia, so they carry across robots) and contact limits."""

    kp_pos: tuple[float, float, float] = (90.0, 90.0, 300.0)  # 1/s², position error → acceleration
    kd_pos: tuple[float, float, float] = (16.0, 16.0, 30.0)  # 1/s, velocity error → acceleration
    kp_rot: tuple[float, float, float] = (300.0, 300.0, 150.0)  # 1/s², rotation error → angular acceleration
    kd_rot: tuple[float, float, float] = (30.0, 30.0, 20.0)  # 1/s
    mu: float = 0.6  # friction coefficient assumed by the planner (MuJoCo's is 0.8)
    fz_min_n: float = 5.0  # N, minimum normal force on a stance foot
    fz_max_fraction: float = 1.5  # × body weight, maximum normal force per foot
    w_force_horizontal: float | None = None  # QP weight of the horizontal force residual (None: as vertical)


@dataclass
class BodyTarget:
    """Desired body motion at one instant (world frame)."""

    p_world_body: np.ndarray
    v_world_body: np.ndarray
    R_world_body: np.ndarray
    omega_world: np.ndarray
    a_world_body: np.ndarray | None = None


class BalanceController:
    """Turns a body target and the measured state into stance-foot contact forces (4,3), world frame."""

    def __init__(self, robot: RobotModel, params: BalanceParams | None = None) -> None:
        self.robot = robot
        self.params = params or BalanceParams()
        p = self.params
        self.kp_pos = np.array(p.kp_pos)
        self.kd_pos = np.array(p.kd_pos)
        self.kp_rot = np.array(p.kp_rot)
        self.kd_rot = np.array(p.kd_rot)
        self.mass = robot.mass_kg
        self.inertia_body = robot.inertia_body
        self.fz_max_n = p.fz_max_fraction * self.mass * 9.81
        self.distributor = ForceDistributor(
            self.mass, ForceDistributorParams(w_force_horizontal=p.w_force_horizontal)
        )
        self.wrench = np.zeros(6)
        self.r_com_foot = np.zeros((4, 3))
        self.forces = np.zeros((4, 3))

    def desired_wrench(self, s: RobotState, target: BodyTarget) -> np.ndarray:
        """Returns the wrench (6,) [force N, torque N·m about the CoM], world frame, that tracks the target."""
        e_p = target.p_world_body - s.p_world_body
        e_v = target.v_world_body - s.v_world_body
        acc = self.kp_pos * e_p + self.kd_pos * e_v
        if target.a_world_body is not None:
            acc = acc + target.a_world_body
        e_R = so3_log(target.R_world_body @ s.R_world_body.T)  # world-frame rotation error
        e_w = target.omega_world - s.omega_world
        R = s.R_world_body
        # gains act in the body frame (roll/pitch/yaw axes), inertia mapped to the world
        alpha = R @ (self.kp_rot * (R.T @ e_R) + self.kd_rot * (R.T @ e_w))
        I_world = R @ self.inertia_body @ R.T
        self.wrench[:3] = self.mass * (acc - GRAVITY)
        self.wrench[3:] = I_world @ alpha
        return self.wrench

    def contact_forces(
        self,
        s: RobotState,
        target: BodyTarget,
        stance: np.ndarray,
        p_world_contact: np.ndarray | None = None,
        mu: float | None = None,
    ) -> np.ndarray:
        """Returns contact forces (4,3) N, world frame, zero on legs not in stance; mu: the friction coefficient
        (None: BalanceParams.mu)."""
        w = self.desired_wrench(s, target)
        contact_pts = s.p_world_foot if p_world_contact is None else p_world_contact
        np.subtract(contact_pts, s.p_world_com, out=self.r_com_foot)
        self.r_com_foot[:, 2] -= self.robot.foot_radius_m
        f, self.status = self.distributor.solve(
            w[:3],
            w[3:],
            self.r_com_foot,
            stance,
            mu=self.params.mu if mu is None else mu,
            fz_min_n=self.params.fz_min_n,
            fz_max_n=self.fz_max_n,
        )
        self.forces[:] = f
        return self.forces
