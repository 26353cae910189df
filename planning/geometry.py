"""Rotations and small geometric helpers shared by the stages (radians, right-handed, R_world_body)."""

from __future__ import annotations

from typing import Any

import numpy as np


def clip_scalar(x: Any, lo: Any, hi: Any) -> Any:
    """np.clip(x, lo, hi) of one number without NumPy's dispatch (~5 µs a call): the same value, signed zeros, NaN
    and lo > hi (hi) included; a NaN bound goes through np.clip itself. x is returned as given (a float or NumPy
    scalar) when it lies within the bounds."""
    if x != x or lo != lo or hi != hi:
        return np.clip(x, lo, hi)
    y = lo if x < lo else x
    return hi if y > hi else y


def rpy_to_R(rpy: np.ndarray) -> np.ndarray:
    """Returns R_world_body (3,3) of roll, pitch, yaw (rad), applied as Rz(yaw) @ Ry(pitch) @ Rx(roll)."""
    r, p, y = rpy
    cr, sr, cp, sp, cy, sy = np.cos(r), np.sin(r), np.cos(p), np.sin(p), np.cos(y), np.sin(y)
    return np.array(
        [
            [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
            [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
            [-sp, cp * sr, cp * cr],
        ]
    )


def R_to_rpy(R: np.ndarray) -> np.ndarray:
    """Returns roll, pitch, yaw (rad) of R_world_body (inverse of rpy_to_R away from pitch = ±90°)."""
    pitch = np.arcsin(np.clip(-R[2, 0], -1.0, 1.0))
    roll = np.arctan2(R[2, 1], R[2, 2])
    yaw = np.arctan2(R[1, 0], R[0, 0])
    return np.array([roll, pitch, yaw])


def so3_log(R: np.ndarray) -> np.ndarray:
    """Returns the rotation vector (3,) w with exp([w]) = R."""
    c = clip_scalar((np.trace(R) - 1.0) / 2.0, -1.0, 1.0)
    angle = np.arccos(c)
    v = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    if angle < 1e-6:
        return 0.5 * v
    if np.pi - angle < 1e-4:
        # near π: take the axis from the diagonal
        d = np.sqrt(np.maximum((np.diag(R) + 1.0) / 2.0, 0.0))
        k = int(np.argmax(d))
        axis = R[:, k] + np.eye(3)[k]
        axis /= np.linalg.norm(axis)
        return angle * axis
    return angle / (2.0 * np.sin(angle)) * v


def yaw_R(yaw: float) -> np.ndarray:
    """Returns the rotation (3,3) about z by yaw (rad)."""
    c, s = np.cos(yaw), np.sin(yaw)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def rpy_rates_to_omega(rpy: np.ndarray, rpy_dot: np.ndarray) -> np.ndarray:
    """Returns the world-frame angular velocity (3,) of roll/pitch/yaw rates for the ZYX convention."""
    r, p, y = rpy
    dr, dp, dy = rpy_dot
    cy, sy, cp, sp = np.cos(y), np.sin(y), np.cos(p), np.sin(p)
    # ω = ez*dy + Rz(y) ey*dp + Rz(y)Ry(p) ex*dr
    return np.array(
        [
            -sy * dp + cy * cp * dr,
            cy * dp + sy * cp * dr,
            dy - sp * dr,
        ]
    )
