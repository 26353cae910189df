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
_DAMP_VEL_LAMBDA = 1e-6


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
    qd_des = np.array(_damped_solve(robot.jacobian_leg(leg, q_des).tolist(), v_body, _DAMP_VEL_LAMBDA))
    (j00, j01, j02), (j10, j11, j12), (j20, j21, j22) = robot.jacobian_leg(leg, q).tolist()
    fx, fy, fz = f_body
    tau_ff = np.array(
        [j00 * fx + j10 * fy + j20 * fz, j01 * fx + j11 * fy + j21 * fz, j02 * fx + j12 * fy + j22 * fz]
    )
    return q_des, qd_des, tau_ff


def _damped_solve(
    J: list[list[float]], b: tuple[float, float, float], lam: float
) -> tuple[float, float, float]:
    """Returns x solving (JᵀJ + λI) x = Jᵀb for a 3×3 J, in closed form (Cramer's rule on the symmetric matrix;
    np.linalg.solve costs ~20 µs of dispatch for a 3×3)."""
    (j00, j01, j02), (j10, j11, j12), (j20, j21, j22) = J
    b0, b1, b2 = b
    a00 = j00 * j00 + j10 * j10 + j20 * j20 + lam
    a01 = j00 * j01 + j10 * j11 + j20 * j21
    a02 = j00 * j02 + j10 * j12 + j20 * j22
    a11 = j01 * j01 + j11 * j11 + j21 * j21 + lam
    a12 = j01 * j02 + j11 * j12 + j21 * j22
    a22 = j02 * j02 + j12 * j12 + j22 * j22 + lam
    r0 = j00 * b0 + j10 * b1 + j20 * b2
    r1 = j01 * b0 + j11 * b1 + j21 * b2
    r2 = j02 * b0 + j12 * b1 + j22 * b2
    c00 = a11 * a22 - a12 * a12
    c01 = a02 * a12 - a01 * a22
    c02 = a01 * a12 - a02 * a11
    det = a00 * c00 + a01 * c01 + a02 * c02
    c11 = a00 * a22 - a02 * a02
    c12 = a01 * a02 - a00 * a12
    c22 = a00 * a11 - a01 * a01
    return (
        (c00 * r0 + c01 * r1 + c02 * r2) / det,
        (c01 * r0 + c11 * r1 + c12 * r2) / det,
        (c02 * r0 + c12 * r1 + c22 * r2) / det,
    )
