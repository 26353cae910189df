"""Single-rigid-body dynamics: the discrete map the QP uses, its linearization, and rollouts.

State at a knot: CoM position p (m), velocity v (m/s), orientation R_world_body, angular velocity ω (rad/s, world).
Over an interval of length dt the contact forces f_i (N, world) are constant and act at fixed contact points
p_foot_i. The discrete map (exact for the translation, second order for the rotation):

    a     = Σ f_i / m + g
    p⁺    = p + dt v + ½ dt² a
    v⁺    = v + dt a
    c     = p + ½ dt v + dt²/6 g               (the mean CoM over the interval; the f × f part drops out)
    τ     = Σ p_foot_i × f_i − c × Σ f_i       (= Σ (p_foot_i − mean CoM) × f_i, exactly)
    ω⁺    = ω + dt I_w⁻¹ (τ − ω × I_w ω),      I_w = R I_body Rᵀ
    κ     = dt³/12 · I_w⁻¹ ((v + ½ dt g) × Σ f_i)
    R⁺    = exp(dt (ω + ω⁺)/2 + κ) R

κ corrects the trapezoid for the torque drifting as the CoM moves under constant forces (its moment arm changes
linearly and quadratically in time): with it the rotation increment is exact for that drift, which matters on the
coarse far steps of a moving robot (a 0.15 s step at 0.4 m/s moves the CoM 6 cm).

Orientation is parametrized about a reference R̄ (the linearization point) by a world-frame rotation vector:
R = exp(θ) R̄. The products in τ (force × position, both unknown) are linearized about the previous solution, so
the error of the linear model is Σ δp_foot_i × δf_i − δc × δF: the product of the two estimates' errors.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from planning.centroidal import _so3

_E_XY = np.array([[1.0, 0.0], [0.0, 1.0], [0.0, 0.0]])  # (3,2): a horizontal foothold shift into world


_INVERSES: dict[bytes, np.ndarray] = {}


def _inverse(inertia_body: np.ndarray) -> np.ndarray:
    """Returns the inverse of a (3,3) inertia, remembered (a model's inertia is inverted once, not every tick)."""
    key = inertia_body.tobytes()
    inv = _INVERSES.get(key)
    if inv is None:
        if len(_INVERSES) > 64:
            _INVERSES.clear()
        inv = _INVERSES[key] = np.linalg.inv(inertia_body)
    return inv


def torque(p: np.ndarray, v: np.ndarray, f: np.ndarray, p_feet: np.ndarray, dt: np.ndarray, g: np.ndarray):
    """Returns (τ (N,3) N·m, ΣF (N,3) N, c (N,3) m): interval torques about the mean CoM, vectorized over N."""
    F = f.sum(axis=1)
    c = p + 0.5 * dt[:, None] * v + (dt * dt / 6.0)[:, None] * g
    tau = _so3.cross(p_feet, f).sum(axis=1) - _so3.cross(c, F)
    return tau, F, c


def discrete_step(
    p: np.ndarray,
    v: np.ndarray,
    R: np.ndarray,
    w: np.ndarray,
    f: np.ndarray,
    p_feet: np.ndarray,
    dt: np.ndarray,
    mass: float,
    inertia_body: np.ndarray,
    g: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Returns (p⁺, v⁺, R⁺, ω⁺) of the nonlinear discrete map, vectorized over N intervals.

    p, v, w: (N,3); R: (N,3,3); f, p_feet: (N,4,3); dt: (N,) s.
    """
    dt = np.asarray(dt, dtype=float)
    tau, F, _ = torque(p, v, f, p_feet, dt, g)
    a = F / mass + g
    p1 = p + dt[:, None] * v + 0.5 * (dt * dt)[:, None] * a
    v1 = v + dt[:, None] * a
    Iw = R @ inertia_body @ np.swapaxes(R, -1, -2)
    Iw_inv = R @ _inverse(inertia_body) @ np.swapaxes(R, -1, -2)
    h = _so3.cross(w, np.einsum("nij,nj->ni", Iw, w))
    w1 = w + dt[:, None] * np.einsum("nij,nj->ni", Iw_inv, tau - h)
    kappa = (dt**3 / 12.0)[:, None] * np.einsum(
        "nij,nj->ni", Iw_inv, _so3.cross(v + 0.5 * dt[:, None] * g, F)
    )
    R1 = _so3.exp(0.5 * dt[:, None] * (w + w1) + kappa) @ R
    return p1, v1, R1, w1


def rollout_discrete(
    p0: np.ndarray,
    v0: np.ndarray,
    R0: np.ndarray,
    w0: np.ndarray,
    f: np.ndarray,
    p_feet: np.ndarray,
    dt: np.ndarray,
    mass: float,
    inertia_body: np.ndarray,
    g: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Returns knot states (p (N+1,3), v, R (N+1,3,3), ω) of the nonlinear discrete map from one start state.

    The translation is linear in the forces and done in closed form for all intervals at once; only the
    rotation runs knot by knot.
    """
    N = dt.size
    F = f.sum(axis=1)
    a = F / mass + g
    v = np.empty((N + 1, 3))
    v[0] = v0
    np.cumsum(dt[:, None] * a, axis=0, out=v[1:])
    v[1:] += v0
    p = np.empty((N + 1, 3))
    p[0] = p0
    np.cumsum(dt[:, None] * v[:-1] + 0.5 * (dt * dt)[:, None] * a, axis=0, out=p[1:])
    p[1:] += p0
    tau, _, _ = torque(p[:-1], v[:-1], f, p_feet, dt, g)
    drift = (dt**3 / 12.0)[:, None] * _so3.cross(v[:-1] + 0.5 * dt[:, None] * g, F)
    R, w = _rotate(np.asarray(R0, dtype=float), np.asarray(w0, dtype=float), tau, drift, dt, inertia_body)
    return p, v, R, w


def _rotate(
    R0: np.ndarray,
    w0: np.ndarray,
    tau: np.ndarray,
    drift: np.ndarray,
    dt: np.ndarray,
    inertia_body: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """Returns R (N+1,3,3), ω (N+1,3) of the rotation part of the discrete map under torques tau (N,3); drift
    (N,3) is dt³/12 · (v + ½ dt g) × ΣF, which I_w⁻¹ turns into the increment correction κ.

    Plain floats: the loop is sequential and tiny, where numpy's per-call cost would dominate.
    """
    N = dt.size
    I = inertia_body.tolist()
    Ii = _inverse(inertia_body).tolist()
    (i00, i01, i02), (i10, i11, i12), (i20, i21, i22) = I
    (j00, j01, j02), (j10, j11, j12), (j20, j21, j22) = Ii
    (r00, r01, r02), (r10, r11, r12), (r20, r21, r22) = R0.tolist()
    wx, wy, wz = w0.tolist()
    R_out = np.empty((N + 1, 3, 3))
    w_out = np.empty((N + 1, 3))
    R_out[0] = R0
    w_out[0] = w0
    taus = tau.tolist()
    drifts = drift.tolist()
    dts = dt.tolist()
    rows = []
    for k in range(N):
        h = dts[k]
        tx, ty, tz = taus[k]
        # body-frame rate and torque: I_w⁻¹ x = R I⁻¹ Rᵀ x
        bx = r00 * wx + r10 * wy + r20 * wz
        by = r01 * wx + r11 * wy + r21 * wz
        bz = r02 * wx + r12 * wy + r22 * wz
        lx = i00 * bx + i01 * by + i02 * bz
        ly = i10 * bx + i11 * by + i12 * bz
        lz = i20 * bx + i21 * by + i22 * bz
        ux = r00 * tx + r10 * ty + r20 * tz - (by * lz - bz * ly)
        uy = r01 * tx + r11 * ty + r21 * tz - (bz * lx - bx * lz)
        uz = r02 * tx + r12 * ty + r22 * tz - (bx * ly - by * lx)
        ax = j00 * ux + j01 * uy + j02 * uz
        ay = j10 * ux + j11 * uy + j12 * uz
        az = j20 * ux + j21 * uy + j22 * uz
        nx = wx + h * (r00 * ax + r01 * ay + r02 * az)
        ny = wy + h * (r10 * ax + r11 * ay + r12 * az)
        nz = wz + h * (r20 * ax + r21 * ay + r22 * az)
        # κ = R I⁻¹ Rᵀ drift; R ← exp(h (ω + ω⁺)/2 + κ) R (Rodrigues)
        sx, sy, sz = drifts[k]
        ux = r00 * sx + r10 * sy + r20 * sz
        uy = r01 * sx + r11 * sy + r21 * sz
        uz = r02 * sx + r12 * sy + r22 * sz
        ax = j00 * ux + j01 * uy + j02 * uz
        ay = j10 * ux + j11 * uy + j12 * uz
        az = j20 * ux + j21 * uy + j22 * uz
        px = 0.5 * h * (wx + nx) + r00 * ax + r01 * ay + r02 * az
        py = 0.5 * h * (wy + ny) + r10 * ax + r11 * ay + r12 * az
        pz = 0.5 * h * (wz + nz) + r20 * ax + r21 * ay + r22 * az
        th2 = px * px + py * py + pz * pz
        if th2 < 1e-12:
            A, B = 1.0 - th2 / 6.0, 0.5 - th2 / 24.0
        else:
            th = math.sqrt(th2)
            A, B = math.sin(th) / th, (1.0 - math.cos(th)) / th2
        e00 = 1.0 - B * (py * py + pz * pz)
        e11 = 1.0 - B * (px * px + pz * pz)
        e22 = 1.0 - B * (px * px + py * py)
        e01, e10 = B * px * py - A * pz, B * px * py + A * pz
        e02, e20 = B * px * pz + A * py, B * px * pz - A * py
        e12, e21 = B * py * pz - A * px, B * py * pz + A * px
        r00, r01, r02, r10, r11, r12, r20, r21, r22 = (
            e00 * r00 + e01 * r10 + e02 * r20,
            e00 * r01 + e01 * r11 + e02 * r21,
            e00 * r02 + e01 * r12 + e02 * r22,
            e10 * r00 + e11 * r10 + e12 * r20,
            e10 * r01 + e11 * r11 + e12 * r21,
            e10 * r02 + e11 * r12 + e12 * r22,
            e20 * r00 + e21 * r10 + e22 * r20,
            e20 * r01 + e21 * r11 + e22 * r21,
            e20 * r02 + e21 * r12 + e22 * r22,
        )
        wx, wy, wz = nx, ny, nz
        rows.append((r00, r01, r02, r10, r11, r12, r20, r21, r22, wx, wy, wz))
    if N:
        arr = np.array(rows)
        R_out[1:] = arr[:, :9].reshape(N, 3, 3)
        w_out[1:] = arr[:, 9:]
    return R_out, w_out


def rollout_continuous(
    p0: np.ndarray,
    v0: np.ndarray,
    R0: np.ndarray,
    w0: np.ndarray,
    f: np.ndarray,
    p_feet: np.ndarray,
    dt: np.ndarray,
    mass: float,
    inertia_body: np.ndarray,
    g: np.ndarray,
    max_substep: float = 0.002,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Returns knot states of the continuous SRB equations (RK4, substeps <= max_substep s) under the same forces.

    The reference for how good the discrete map is; not used in the tick (too slow for the hot path).
    """
    I_inv = _inverse(inertia_body)
    N = dt.size
    P = np.empty((N + 1, 3))
    V = np.empty((N + 1, 3))
    RR = np.empty((N + 1, 3, 3))
    W = np.empty((N + 1, 3))
    P[0], V[0], RR[0], W[0] = p0, v0, R0, w0
    p, v, R, w = (np.array(x, dtype=float) for x in (p0, v0, R0, w0))
    for k in range(N):
        F = f[k].sum(axis=0)
        a = F / mass + g
        m1 = _so3.cross(p_feet[k], f[k]).sum(axis=0)
        n_sub = max(1, int(np.ceil(dt[k] / max_substep - 1e-9)))
        h = dt[k] / n_sub

        def rhs(pp, vv, phi, ww, R_start, F=F, a=a, m1=m1):
            Rc = _so3.exp(phi) @ R_start
            tau = m1 - _so3.cross(pp, F)
            wb = Rc.T @ ww
            wdot = Rc @ (I_inv @ (Rc.T @ tau - _so3.cross(wb, inertia_body @ wb)))
            phidot = _so3.left_jacobian_inv(phi) @ ww
            return vv, a, phidot, wdot

        for _ in range(n_sub):
            z = np.zeros(3)
            k1 = rhs(p, v, z, w, R)
            k2 = rhs(p + 0.5 * h * k1[0], v + 0.5 * h * k1[1], 0.5 * h * k1[2], w + 0.5 * h * k1[3], R)
            k3 = rhs(p + 0.5 * h * k2[0], v + 0.5 * h * k2[1], 0.5 * h * k2[2], w + 0.5 * h * k2[3], R)
            k4 = rhs(p + h * k3[0], v + h * k3[1], h * k3[2], w + h * k3[3], R)
            p = p + h / 6.0 * (k1[0] + 2 * k2[0] + 2 * k3[0] + k4[0])
            v = v + h / 6.0 * (k1[1] + 2 * k2[1] + 2 * k3[1] + k4[1])
            phi = h / 6.0 * (k1[2] + 2 * k2[2] + 2 * k3[2] + k4[2])
            w = w + h / 6.0 * (k1[3] + 2 * k2[3] + 2 * k3[3] + k4[3])
            R = _so3.exp(phi) @ R
        P[k + 1], V[k + 1], RR[k + 1], W[k + 1] = p, v, R, w
    return P, V, RR, W


@dataclass
class Linearization:
    """Jacobian blocks of the discrete map about a point, per interval (N leading).

    Rotation rows:  θ⁺ − Jth θ − ½ Jw (ω + ω⁺) − Rv v − Σ_i Rf[i] f_i = rot_rhs
    Angular rows:   ω⁺ − ω − dt (G_th θ + G_w ω + I⁻¹ T z) = dt (ḡ − G_w ω̄ − I⁻¹ T z̄)
    with T z = T_p p + T_v v + Σ_i T_f[i] f_i + Σ_i T_d[i] d_i (d: horizontal foothold shift of leg i's foot).
    """

    Jth: np.ndarray  # (N,3,3)
    Jw: np.ndarray  # (N,3,3)   already × dt
    Rv: np.ndarray  # (N,3,3)   the drift correction's dependence on v
    Rf: np.ndarray  # (N,4,3,3) ... and on each force (per newton)
    rot_rhs: np.ndarray  # (N,3)
    I_inv: np.ndarray  # (N,3,3) world inverse inertia at the reference
    G_th: np.ndarray  # (N,3,3)
    G_w: np.ndarray  # (N,3,3)
    T_p: np.ndarray  # (N,3,3)
    T_v: np.ndarray  # (N,3,3)
    T_f: np.ndarray  # (N,4,3,3) per newton
    T_d: np.ndarray  # (N,4,3,2) per meter of shift
    ang_rhs: np.ndarray  # (N,3)
    tau: np.ndarray  # (N,3) torque at the linearization point


def linearize(
    p: np.ndarray,
    v: np.ndarray,
    R: np.ndarray,
    w: np.ndarray,
    f: np.ndarray,
    p_feet: np.ndarray,
    d: np.ndarray,
    dt: np.ndarray,
    inertia_body: np.ndarray,
    g: np.ndarray,
) -> Linearization:
    """Returns the linearization of the discrete map about knot states p, v, R, w (N+1 leading), forces f (N,4,3) N,
    contact points p_feet (N,4,3) (those the shifts d (N,4,2) already moved) and steps dt (N,)."""
    N = dt.size
    dtc = dt[:, None]
    Rk, Rk1 = R[:-1], R[1:]
    wk, wk1 = w[:-1], w[1:]
    RkT = np.swapaxes(Rk, -1, -2)
    Ib = Rk @ inertia_body @ RkT
    Ii = Rk @ _inverse(inertia_body) @ RkT
    tau, F, c = torque(p[:-1], v[:-1], f, p_feet, dt, g)
    # Rotation rows: a = dt (ω + ω⁺)/2 + κ(θ, v, f); θ⁺ = log(exp(a) exp(θ) R̄ R̄⁺ᵀ).
    c3 = (dt**3 / 12.0)[:, None, None]
    ubar = v[:-1] + 0.5 * dtc * g
    yk = _so3.cross(ubar, F)
    kappa = c3[:, :, 0] * np.einsum("nij,nj->ni", Ii, yk)
    a = 0.5 * dtc * (wk + wk1) + kappa
    Ea = _so3.exp(a)
    F0 = _so3.log(Ea @ Rk @ np.swapaxes(Rk1, -1, -2))
    Jli = _so3.left_jacobian_inv(F0)
    Ja = Jli @ _so3.left_jacobian(a)
    Jw = Ja * dt[:, None, None]
    K_th = c3 * (-_so3.hat(np.einsum("nij,nj->ni", Ii, yk)) + Ii @ _so3.hat(yk))
    Jth = Jli @ Ea + Ja @ K_th
    HF = _so3.hat(F)
    Rv = -(Ja @ (c3 * (Ii @ HF)))
    Rf1 = Ja @ (c3 * (Ii @ _so3.hat(ubar)))  # the same for every leg: ∂(u × ΣF)/∂f_i = [u]×
    Rf = np.repeat(Rf1[:, None], f.shape[1], axis=1)
    rot_rhs = (
        F0
        - np.einsum("nij,nj->ni", Jw, 0.5 * (wk + wk1))
        - np.einsum("nij,nj->ni", Rv, v[:-1])
        - np.einsum("nij,nj->ni", Rf1, F)
    )
    # Angular-velocity rows.
    Iw = np.einsum("nij,nj->ni", Ib, wk)
    y = tau - _so3.cross(wk, Iw)
    gbar = np.einsum("nij,nj->ni", Ii, y)
    H_w = _so3.hat(wk)
    H_Iw = _so3.hat(Iw)
    G_w = -Ii @ (H_w @ Ib - H_Iw)
    dIw_dth = -H_Iw + Ib @ H_w
    G_th = -_so3.hat(gbar) + Ii @ (_so3.hat(y) - H_w @ dIw_dth)
    T_p = HF
    T_v = 0.5 * dt[:, None, None] * HF
    T_f = _so3.hat(p_feet - c[:, None, :])  # (N,4,3,3)
    T_d = -_so3.hat(f) @ _E_XY  # (N,4,3,2)
    Tz = (
        np.einsum("nij,nj->ni", T_p, p[:-1])
        + np.einsum("nij,nj->ni", T_v, v[:-1])
        + np.einsum("nlij,nlj->ni", T_f, f)
        + np.einsum("nlij,nlj->ni", T_d, d)
    )
    ang_rhs = dtc * (gbar - np.einsum("nij,nj->ni", G_w, wk) - np.einsum("nij,nj->ni", Ii, Tz))
    assert Jth.shape == (N, 3, 3)
    return Linearization(Jth, Jw, Rv, Rf, rot_rhs, Ii, G_th, G_w, T_p, T_v, T_f, T_d, ang_rhs, tau)
