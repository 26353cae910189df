"""Joint targets for a position-controlled swing leg: IK of the planned foot, joint velocities and a feed-forward
torque through the leg Jacobian. The caller closes the loop: tau = kp (q_des − q) + kd (qd_des − qd) + tau_ff."""

from __future__ import annotations

import numpy as np

from planning.robot import ReachError, RobotModel
from planning.swing.params import SwingParams
from planning.swing.planner import SwingPlan

_G_WORLD = (0.0, 0.0, -9.81)  # m/s²
_DEFAULT = SwingParams()
_DAMP_IK = 1e-4 * np.eye(3)
_DAMP_VEL = 1e-6 * np.eye(3)


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
    # 3-vectors as Python floats: a dozen NumPy calls on (3,) arrays cost more than the arithmetic
    (r00, r01, r02), (r10, r11, r12), (r20, r21, r22) = np.asarray(R_world_body, dtype=float).tolist()
    xp, xv, xa = plan.x_heading.state(t)
    yp, yv, ya = plan.y_heading.state(t)
    zp, zv, za = plan.z.state(t)
    c, s = plan.cos_yaw, plan.sin_yaw
    bx, by, bz = np.asarray(p_world_body, dtype=float).tolist()
    ux, uy, uz = np.asarray(v_world_body, dtype=float).tolist()
    # the foot center relative to the body, world frame
    ex, ey, ez = c * xp - s * yp - bx, s * xp + c * yp - by, zp + robot.foot_radius_m - bz
    vx, vy, vz = c * xv - s * yv - ux, s * xv + c * yv - uy, zv - uz
    if w_world_body is not None:
        wx, wy, wz = np.asarray(w_world_body, dtype=float).tolist()
        vx, vy, vz = vx - (wy * ez - wz * ey), vy - (wz * ex - wx * ez), vz - (wx * ey - wy * ex)
    ax, ay, az = c * xa - s * ya - _G_WORLD[0], s * xa + c * ya - _G_WORLD[1], za - _G_WORLD[2]
    p_body = np.array(
        [r00 * ex + r10 * ey + r20 * ez, r01 * ex + r11 * ey + r21 * ez, r02 * ex + r12 * ey + r22 * ez]
    )
    v_body = (r00 * vx + r10 * vy + r20 * vz, r01 * vx + r11 * vy + r21 * vz, r02 * vx + r12 * vy + r22 * vz)
    m = pr.foot_effective_mass_kg
    f_body = (
        m * (r00 * ax + r10 * ay + r20 * az),
        m * (r01 * ax + r11 * ay + r21 * az),
        m * (r02 * ax + r12 * ay + r22 * az),
    )
    try:
        q_des = robot.ik_leg(leg, p_body)
    except ReachError:
        J = robot.jacobian_leg(leg, q)
        err = p_body - robot.fk_leg(leg, q)
        q_des = q + np.linalg.solve(J.T @ J + _DAMP_IK, J.T @ err)
        q_des = np.clip(q_des, robot.q_min[leg], robot.q_max[leg])
    # (np.linalg.solve kept: a closed-form 3×3 solve is ~20 µs cheaper but not bit-identical to LAPACK's, and the
    # stairs crossings flip on last-bit differences)
    J_des = robot.jacobian_leg(leg, q_des)
    qd_des = np.linalg.solve(J_des.T @ J_des + _DAMP_VEL, J_des.T @ np.array(v_body))
    (j00, j01, j02), (j10, j11, j12), (j20, j21, j22) = robot.jacobian_leg(leg, q).tolist()
    fx, fy, fz = f_body
    tau_ff = np.array(
        [j00 * fx + j10 * fy + j20 * fz, j01 * fx + j11 * fy + j21 * fz, j02 * fx + j12 * fy + j22 * fz]
    )
    return q_des, qd_des, tau_ff
