"""Input generators and the clarabel reference QPs shared by the stance-area tests."""

from __future__ import annotations

import math

import clarabel
import numpy as np
import scipy.sparse as sp

from planning.forces import contact_frames, pyramid_mu

N_LEGS = 4
P_COM_FOOT_SPOT = np.array(
    [[0.3, 0.165, -0.52], [0.3, -0.165, -0.52], [-0.3, 0.165, -0.52], [-0.3, -0.165, -0.52]]
)


def random_jacobians(rng: np.random.Generator, kind: str) -> np.ndarray:
    """Return J (4,3,3): "good" (singular values 0.15–0.6 m), "singular" (rank ≤ 2), or "zero" on one leg."""
    J = np.empty((N_LEGS, 3, 3))
    for leg in range(N_LEGS):
        U, _ = np.linalg.qr(rng.normal(size=(3, 3)))
        V, _ = np.linalg.qr(rng.normal(size=(3, 3)))
        sv = rng.uniform(0.15, 0.6, size=3)
        if kind == "singular":
            sv[rng.integers(3)] = 0.0
        J[leg] = U @ np.diag(sv) @ V.T
    if kind == "zero":
        J[rng.integers(N_LEGS)] = 0.0
    return J


def random_normals(rng: np.random.Generator, max_tilt_rad: float) -> np.ndarray:
    """Return unit normals (4,3) tilted from +z by up to max_tilt_rad in random directions."""
    tilt = rng.uniform(0.0, max_tilt_rad, size=N_LEGS)
    yaw = rng.uniform(-math.pi, math.pi, size=N_LEGS)
    return np.stack([np.sin(tilt) * np.cos(yaw), np.sin(tilt) * np.sin(yaw), np.cos(tilt)], axis=1)


def forces_in_pyramid(
    rng: np.random.Generator, R: np.ndarray, mu_face: float, fn_lo: float, fn_hi: float, margin: float = 0.9
) -> np.ndarray:
    """Return forces (4,3) strictly inside the pyramid, normal parts in [fn_lo, fn_hi]."""
    fn = rng.uniform(fn_lo, fn_hi, size=N_LEGS)
    ft = rng.uniform(-margin, margin, size=(N_LEGS, 2)) * mu_face * fn[:, None]
    local = np.column_stack([ft, fn])
    return np.einsum("ijk,ik->ij", R, local)


def pyramid_constraint_rows(R: np.ndarray, mu_face: float) -> np.ndarray:
    """Return G (4,4,3): per leg the four face normals, G f ≤ 0 inside the pyramid."""
    t1, t2, n = R[:, :, 0], R[:, :, 1], R[:, :, 2]
    return np.stack([t1 - mu_face * n, -t1 - mu_face * n, t2 - mu_face * n, -t2 - mu_face * n], axis=1)


def _solve_clarabel(P: np.ndarray, q: np.ndarray, rows_eq: list, rows_ineq: list) -> np.ndarray:
    """min ½xᵀPx + qᵀx s.t. a·x = b for (a, b) in rows_eq, a·x ≤ b for (a, b) in rows_ineq."""
    A = np.array([a for a, _ in rows_eq] + [a for a, _ in rows_ineq])
    b = np.array([v for _, v in rows_eq] + [v for _, v in rows_ineq])
    cones = []
    if rows_eq:
        cones.append(clarabel.ZeroConeT(len(rows_eq)))
    if rows_ineq:
        cones.append(clarabel.NonnegativeConeT(len(rows_ineq)))
    settings = clarabel.DefaultSettings()
    settings.verbose = False
    settings.tol_gap_abs = settings.tol_gap_rel = settings.tol_feas = 1e-10
    sol = clarabel.DefaultSolver(sp.csc_matrix(np.triu(P)), q, sp.csc_matrix(A), b, cones, settings).solve()
    assert str(sol.status) in ("Solved", "AlmostSolved"), sol.status
    return np.array(sol.x)


def _friction_rows(
    contact: np.ndarray, R: np.ndarray, mu_face: float, fz_min: float, fz_max: float
) -> tuple[list, list]:
    rows_eq: list = []
    rows_ineq: list = []
    G = pyramid_constraint_rows(R, mu_face)
    for leg in range(N_LEGS):
        sel = np.zeros((3, 12))
        sel[:, 3 * leg : 3 * leg + 3] = np.eye(3)
        if not contact[leg]:
            rows_eq += [(sel[k], 0.0) for k in range(3)]
            continue
        rows_ineq += [(G[leg, k] @ sel, 0.0) for k in range(4)]
        n_row = R[leg, :, 2] @ sel
        rows_ineq.append((-n_row, -fz_min))
        if math.isfinite(fz_max):
            rows_ineq.append((n_row, fz_max))
    return rows_eq, rows_ineq


def reference_distribution(
    mass_kg: float,
    force: np.ndarray,
    torque: np.ndarray,
    r: np.ndarray,
    contact: np.ndarray,
    mu: float,
    fz_min: float,
    fz_max: float,
    normals: np.ndarray | None,
    *,
    w_force: float = 1.0,
    w_torque: float = 10.0,
    length_m: float = 1.0,
    alpha: float = 1e-2,
    f_ref: np.ndarray | None = None,
) -> np.ndarray:
    """Return the force-distribution optimum (4,3) [N] from clarabel, written from the math in N units."""
    mg = mass_kg * 9.81
    A = np.zeros((6, 12))
    for leg in range(N_LEGS):
        A[0:3, 3 * leg : 3 * leg + 3] = np.eye(3)
        rx, ry, rz = r[leg]
        A[3:6, 3 * leg : 3 * leg + 3] = [[0, -rz, ry], [rz, 0, -rx], [-ry, rx, 0]]
    S = np.diag([w_force / mg**2] * 3 + [w_torque / (mg * length_m) ** 2] * 3)
    w = np.concatenate([force, torque])
    if f_ref is None:  # the distributor's default prior: least-norm forces producing the wrench (weighted)
        Aw = np.sqrt(S) @ A * np.repeat(contact, 3)[None, :]
        f_ref = np.linalg.pinv(Aw, rcond=1e-10) @ (np.sqrt(S) @ w)
    ref = f_ref.reshape(-1)
    P = 2.0 * (A.T @ S @ A + alpha / mg**2 * np.eye(12))
    q = -2.0 * (A.T @ S @ w + alpha / mg**2 * ref)
    R = contact_frames(normals)
    eq, ineq = _friction_rows(contact, R, pyramid_mu(mu, True), fz_min, fz_max)
    return _solve_clarabel(P * 1e3, q * 1e3, eq, ineq).reshape(N_LEGS, 3)


def reference_handler(
    f_des: np.ndarray,
    J: np.ndarray,
    contact: np.ndarray,
    tau_max: np.ndarray,
    tau_bias: np.ndarray,
    mu: float,
    fz_min: float,
    normals: np.ndarray | None,
) -> np.ndarray:
    """Return the stance-handler optimum (4,3) [N] without the wrench term (equal normal/tangent weights)."""
    P = np.eye(12)
    x_des = np.where(contact[:, None], f_des, 0.0).reshape(-1)
    R = contact_frames(normals)
    eq, ineq = _friction_rows(contact, R, pyramid_mu(mu, True), fz_min, math.inf)
    for leg in range(N_LEGS):
        if not contact[leg]:
            continue
        for k in range(3):
            a = np.zeros(12)
            a[3 * leg : 3 * leg + 3] = -J[leg, :, k]  # τ_k = b_k - (Jᵀ f)_k
            ineq.append((a, tau_max[leg, k] - tau_bias[leg, k]))
            ineq.append((-a, tau_max[leg, k] + tau_bias[leg, k]))
    return _solve_clarabel(P, -x_des, eq, ineq).reshape(N_LEGS, 3)
