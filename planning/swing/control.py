"""Joint targets for a position-controlled swing leg: IK of the planned foot, joint velocities and a feed-forward
torque through the leg Jacobian. The caller closes the loop: tau = kp (q_des − q) + kd (qd_des − qd) + tau_ff."""

from __future__ import annotations

import numpy as np

from planning.robot import ReachError, RobotModel
from planning.swing.params import SwingParams
from planning.swing.planner import SwingPlan

_G_WORLD = np.array([0.0, 0.0, -9.81])  # m/s²
_DEFAULT = SwingParams()
_DAMP_IK = 1e-4 * np.eye(3)
_DAMP_VEL = 1e-6 * np.eye(3)


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a × b for 3-vectors (np.cross costs ~20 µs of axis bookkeeping per call)."""
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])


def swing_joint_command(
    robot: RobotModel,
    leg: int,
    q: np.ndarray,
    qd: np.ndarray,
    plan: SwingPlan,
    t: float,
    R_world_body: np.ndarray,
    p_world_body: np.ndarray,
    v_world_body: np.ndarray,
    w_world_body: np.ndarray | None = None,
    params: SwingParams | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Returns (q_des (3,) rad, qd_des (3,) rad/s, tau_ff (3,) N·m) for swing leg ``leg`` at time t (s).

    q, qd: measured joint angles and rates of the leg. The planned contact point is lifted by the foot radius to
    the foot center, expressed in the body frame (relative velocity with the body's angular velocity
    w_world_body, rad/s), and solved by the leg IK; a target out of reach takes one damped Gauss–Newton step
    from q instead. qd_des = J(q_des)⁻¹ v_body (damped); tau_ff = J(q)ᵀ m (a_body − g_body), the force that
    accelerates the lower leg's effective mass m along the plan and holds it against gravity.
    """
    pr = params or _DEFAULT
    q = np.asarray(q, dtype=float)
    R = np.asarray(R_world_body, dtype=float)
    p_w, v_w, a_w = plan.sample(t)
    r_foot = robot.foot_radius_m
    rel = p_w + (0.0, 0.0, r_foot) - np.asarray(p_world_body, dtype=float)
    p_body = R.T @ rel
    v_rel = v_w - np.asarray(v_world_body, dtype=float)
    if w_world_body is not None:
        v_rel = v_rel - _cross(np.asarray(w_world_body, dtype=float), rel)
    v_body = R.T @ v_rel
    a_body = R.T @ (a_w - _G_WORLD)
    try:
        q_des = robot.ik_leg(leg, p_body)
    except ReachError:
        J = robot.jacobian_leg(leg, q)
        err = p_body - robot.fk_leg(leg, q)
        q_des = q + np.linalg.solve(J.T @ J + _DAMP_IK, J.T @ err)
        q_des = np.clip(q_des, robot.q_min[leg], robot.q_max[leg])
    J_des = robot.jacobian_leg(leg, q_des)
    qd_des = np.linalg.solve(J_des.T @ J_des + _DAMP_VEL, J_des.T @ v_body)
    tau_ff = robot.jacobian_leg(leg, q).T @ (pr.foot_effective_mass_kg * a_body)
    return q_des, qd_des, tau_ff
