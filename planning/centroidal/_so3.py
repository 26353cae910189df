"""Rotation helpers, vectorized over leading axes: hat, exp, log, left Jacobians, roll-pitch-yaw.

Rotation vectors are world-frame ("left") perturbations: R = exp(θ) R̄. Angles in radians.
"""

from __future__ import annotations

import numpy as np

_SMALL = 1e-6


def hat(v: np.ndarray) -> np.ndarray:
    """Returns the skew matrices (..., 3, 3) with hat(a) @ b == cross(a, b) for vectors a (..., 3)."""
    v = np.asarray(v, dtype=float)
    out = np.zeros(v.shape[:-1] + (3, 3))
    out[..., 0, 1] = -v[..., 2]
    out[..., 0, 2] = v[..., 1]
    out[..., 1, 0] = v[..., 2]
    out[..., 1, 2] = -v[..., 0]
    out[..., 2, 0] = -v[..., 1]
    out[..., 2, 1] = v[..., 0]
    return out


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Returns a × b over the last axis (broadcast); np.cross without its per-call overhead."""
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    out = np.empty(a.shape if a.shape == b.shape else np.broadcast_shapes(a.shape, b.shape))
    out[..., 0] = a1 * b2 - a2 * b1
    out[..., 1] = a2 * b0 - a0 * b2
    out[..., 2] = a0 * b1 - a1 * b0
    return out


_EYE = np.eye(3)
_DIAG = [0, 4, 8]  # of a flattened 3×3
_SKEW_P, _SKEW_M = [7, 2, 3], [5, 6, 1]  # (R21, R02, R10) − (R12, R20, R01)


def norm(v: np.ndarray) -> np.ndarray:
    """Returns |v| over the last axis; np.linalg.norm(v, axis=-1) without its per-call overhead."""
    return np.sqrt(np.einsum("...i,...i->...", v, v))


def _coeffs(theta: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Returns (sin θ/θ, (1-cos θ)/θ², (θ - sin θ)/θ³) with Taylor series near zero."""
    t2 = theta * theta
    small = theta < _SMALL * 100
    if not small.any():  # the usual case: no angle near zero, no series needed
        s = np.sin(theta)
        return s / theta, (1.0 - np.cos(theta)) / t2, (theta - s) / (t2 * theta)
    ts = np.where(small, 1.0, theta)
    a = np.where(small, 1.0 - t2 / 6.0, np.sin(ts) / ts)
    b = np.where(small, 0.5 - t2 / 24.0, (1.0 - np.cos(ts)) / (ts * ts))
    c = np.where(small, 1.0 / 6.0 - t2 / 120.0, (ts - np.sin(ts)) / (ts * ts * ts))
    return a, b, c


# Rows: the flattened [e_0]×, [e_1]×, [e_2]× and I, so that [u_0:3]× + u_3 I is one product u @ _HAT_EYE.
_HAT_EYE = np.zeros((4, 9))
_HAT_EYE[0, [5, 7]] = (-1.0, 1.0)
_HAT_EYE[1, [2, 6]] = (1.0, -1.0)
_HAT_EYE[2, [1, 3]] = (-1.0, 1.0)
_HAT_EYE[3, [0, 4, 8]] = 1.0


def _poly(w: np.ndarray, t2: np.ndarray, x: np.ndarray | float, y: np.ndarray) -> np.ndarray:
    """Returns I + x [w]× + y [w]×² (..., 3, 3), using [w]×² = w wᵀ − |w|² I (few numpy calls: small batches)."""
    u = np.empty(w.shape[:-1] + (4,))
    np.multiply(np.asarray(x)[..., None], w, out=u[..., :3])
    u[..., 3] = 1.0 - y * t2
    out = (u @ _HAT_EYE).reshape(w.shape[:-1] + (3, 3))
    out += (y[..., None, None] * w[..., :, None]) * w[..., None, :]
    return out


def exp(w: np.ndarray) -> np.ndarray:
    """Returns rotation matrices (..., 3, 3) = exp(hat(w)) for rotation vectors w (..., 3)."""
    w = np.asarray(w, dtype=float)
    t2 = np.einsum("...i,...i->...", w, w)
    theta = np.sqrt(t2)
    if (theta >= _SMALL * 100).all():
        a = np.sin(theta) / theta
        b = (1.0 - np.cos(theta)) / t2
    else:
        a, b, _ = _coeffs(theta)
    return _poly(w, t2, a, b)


def log(R: np.ndarray) -> np.ndarray:
    """Returns rotation vectors (..., 3) with exp(log(R)) == R, angle in [0, π]."""
    R = np.asarray(R, dtype=float)
    flat = R.reshape(R.shape[:-2] + (9,))
    theta = np.arccos(np.clip((flat[..., _DIAG].sum(axis=-1) - 1.0) * 0.5, -1.0, 1.0))
    v = flat[..., _SKEW_P] - flat[..., _SKEW_M]
    small = theta < 1e-5
    near_pi = theta > np.pi - 1e-4
    if not (small.any() or near_pi.any()):
        return (theta / (2.0 * np.sin(theta)))[..., None] * v
    s = np.sin(theta)
    scale = np.where(small, 0.5 + theta * theta / 12.0, theta / (2.0 * np.where(small | near_pi, 1.0, s)))
    out = scale[..., None] * v
    if np.any(near_pi):
        # Near π the antisymmetric part vanishes; the axis is the dominant column of (R + I) / 2.
        idx = np.nonzero(near_pi)
        Rp = R[idx]
        B = (Rp + np.eye(3)) * 0.5
        col = np.argmax(np.diagonal(B, axis1=-2, axis2=-1), axis=-1)
        axis = B[np.arange(len(col)), :, col]
        axis /= np.linalg.norm(axis, axis=-1, keepdims=True)
        # Pick the sign consistent with the (small) antisymmetric part.
        sign = np.where(np.sum(axis * v[idx], axis=-1) < 0.0, -1.0, 1.0)
        out[idx] = axis * (theta[idx] * sign)[..., None]
    return out


def left_jacobian(w: np.ndarray) -> np.ndarray:
    """Returns J_l(w) (..., 3, 3): exp(w + δ) ≈ exp(J_l(w) δ) exp(w)."""
    w = np.asarray(w, dtype=float)
    t2 = np.einsum("...i,...i->...", w, w)
    _, b, c = _coeffs(np.sqrt(t2))
    return _poly(w, t2, b, c)


def left_jacobian_inv(w: np.ndarray) -> np.ndarray:
    """Returns J_l(w)^-1 (..., 3, 3): log(exp(ε) exp(w)) ≈ w + J_l(w)^-1 ε."""
    w = np.asarray(w, dtype=float)
    t2 = np.einsum("...i,...i->...", w, w)
    theta = np.sqrt(t2)
    small = theta < 1e-4
    if small.any():
        ts = np.where(small, 1.0, theta)
        d = np.where(
            small, 1.0 / 12.0 + t2 / 720.0, 1.0 / (ts * ts) - (1.0 + np.cos(ts)) / (2.0 * ts * np.sin(ts))
        )
    else:
        d = 1.0 / t2 - (1.0 + np.cos(theta)) / (2.0 * theta * np.sin(theta))
    return _poly(w, t2, -0.5, d)


def rpy_to_R(rpy: np.ndarray) -> np.ndarray:
    """Returns R_world_body (..., 3, 3) = Rz(yaw) Ry(pitch) Rx(roll) for rpy (..., 3) in radians."""
    rpy = np.asarray(rpy, dtype=float)
    r, p, y = rpy[..., 0], rpy[..., 1], rpy[..., 2]
    cr, sr, cp, sp, cy, sy = np.cos(r), np.sin(r), np.cos(p), np.sin(p), np.cos(y), np.sin(y)
    R = np.empty(rpy.shape[:-1] + (3, 3))
    R[..., 0, 0] = cy * cp
    R[..., 0, 1] = cy * sp * sr - sy * cr
    R[..., 0, 2] = cy * sp * cr + sy * sr
    R[..., 1, 0] = sy * cp
    R[..., 1, 1] = sy * sp * sr + cy * cr
    R[..., 1, 2] = sy * sp * cr - cy * sr
    R[..., 2, 0] = -sp
    R[..., 2, 1] = cp * sr
    R[..., 2, 2] = cp * cr
    return R


def R_to_rpy(R: np.ndarray) -> np.ndarray:
    """Returns roll, pitch, yaw (..., 3) in radians of R_world_body = Rz(yaw) Ry(pitch) Rx(roll)."""
    R = np.asarray(R, dtype=float)
    pitch = np.arcsin(np.clip(-R[..., 2, 0], -1.0, 1.0))
    roll = np.arctan2(R[..., 2, 1], R[..., 2, 2])
    yaw = np.arctan2(R[..., 1, 0], R[..., 0, 0])
    return np.stack([roll, pitch, yaw], axis=-1)


def interpolate(R0: np.ndarray, R1: np.ndarray, alpha: np.ndarray) -> np.ndarray:
    """Returns exp(α log(R1 R0ᵀ)) R0 (..., 3, 3): geodesic interpolation, α in [0, 1]."""
    d = log(R1 @ np.swapaxes(R0, -1, -2))
    return exp(np.asarray(alpha)[..., None] * d) @ R0
