"""SRB dynamics: rotations, the linearization's Jacobians, its quadratic error, and the discrete map's accuracy."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from planning.centroidal import _so3
from planning.centroidal.dynamics import _E_XY, discrete_step, linearize, rollout_continuous, rollout_discrete

G = np.array([0.0, 0.0, -9.81])
MASS = 31.6
INERTIA = np.array([[0.59, 0.0, -0.11], [0.0, 2.5, 0.0], [-0.11, 0.0, 2.52]])


@settings(max_examples=50, deadline=None)
@given(st.lists(st.floats(-3.0, 3.0), min_size=3, max_size=3))
def test_exp_log_roundtrip(w):
    w = np.asarray(w)
    if np.linalg.norm(w) > np.pi - 1e-3:
        w = w / np.linalg.norm(w) * (np.pi - 1e-3)
    R = _so3.exp(w)
    assert np.allclose(R @ R.T, np.eye(3), atol=1e-12)
    assert np.allclose(_so3.log(R), w, atol=1e-8)


def test_left_jacobian_matches_finite_differences():
    rng = np.random.default_rng(1)
    for _ in range(5):
        w = rng.normal(size=3)
        d = rng.normal(size=3) * 1e-6
        lhs = _so3.exp(w + d)
        rhs = _so3.exp(_so3.left_jacobian(w) @ d) @ _so3.exp(w)
        assert np.allclose(lhs, rhs, atol=1e-11)
        assert np.allclose(_so3.left_jacobian_inv(w) @ _so3.left_jacobian(w), np.eye(3), atol=1e-10)


def test_rpy_convention_pitch_positive_lowers_the_nose():
    R = _so3.rpy_to_R(np.radians([0.0, 20.0, 0.0]))
    assert (R @ [1.0, 0.0, 0.0])[2] < 0.0
    rpy = np.radians([10.0, -25.0, 140.0])
    assert np.allclose(_so3.R_to_rpy(_so3.rpy_to_R(rpy)), rpy)


def _random_point(rng):
    p = np.array([[0.02, -0.01, 0.5]]) + rng.normal(size=(1, 3)) * 0.05
    v = rng.normal(size=(1, 3)) * 0.5
    R = _so3.exp(rng.normal(size=(1, 3)) * 0.3)
    w = rng.normal(size=(1, 3))
    f = rng.normal(size=(1, 4, 3)) * 20 + [0.0, 0.0, 80.0]
    feet = np.array([[[0.3, 0.17, 0.0], [0.3, -0.17, 0.0], [-0.3, 0.17, 0.0], [-0.3, -0.17, 0.0]]])
    return p, v, R, w, f, feet


def _true_and_linear(base, dirs, eps, dt):
    """The discrete map vs its linearization about `base`, at base + eps * dirs; returns (true, linear)."""
    p, v, R, w, f, feet = base
    dp, dv, dth, dw, df, dd = (eps * x for x in dirs)
    R1, w1 = discrete_step(p, v, R, w, f, feet, dt, MASS, INERTIA, G)[2:]
    Rs = np.concatenate([R, R1])
    ws = np.concatenate([w, w1])
    ps = np.concatenate([p, p])
    lz = linearize(ps, np.concatenate([v, v]), Rs, ws, f, feet, np.zeros((1, 4, 2)), dt, INERTIA, G)
    feet_new = feet + dd @ _E_XY.T
    R1t, w1t = discrete_step(
        p + dp, v + dv, _so3.exp(dth) @ R, w + dw, f + df, feet_new, dt, MASS, INERTIA, G
    )[2:]
    th1_true = _so3.log(R1t[0] @ R1[0].T)
    Tz = (
        lz.T_p[0] @ (p + dp)[0]
        + lz.T_v[0] @ (v + dv)[0]
        + np.einsum("lij,lj->i", lz.T_f[0], (f + df)[0])
        + np.einsum("lij,lj->i", lz.T_d[0], dd[0])
    )
    wk = (w + dw)[0]
    w1_lin = wk + dt[0] * (lz.G_th[0] @ dth[0] + lz.G_w[0] @ wk + lz.I_inv[0] @ Tz) + lz.ang_rhs[0]
    th1_lin = (
        lz.Jth[0] @ dth[0]
        + 0.5 * lz.Jw[0] @ (wk + w1t[0])
        + lz.Rv[0] @ (v + dv)[0]
        + np.einsum("lij,lj->i", lz.Rf[0], (f + df)[0])
        + lz.rot_rhs[0]
    )
    return (th1_true, w1t[0]), (th1_lin, w1_lin)


def test_linearization_error_shrinks_quadratically():
    """The linear model's error is the product of the estimates' errors: halve them, the error drops 4×."""
    rng = np.random.default_rng(7)
    base = _random_point(rng)
    dirs = [rng.normal(size=s) for s in [(1, 3), (1, 3), (1, 3), (1, 3), (1, 4, 3), (1, 4, 2)]]
    dirs[4] *= 20.0  # force errors in newtons
    dt = np.array([0.08])
    errs = []
    for eps in (0.1, 0.05, 0.025, 0.0125):
        (th_t, w_t), (th_l, w_l) = _true_and_linear(base, dirs, eps, dt)
        errs.append(np.linalg.norm(w_t - w_l) + np.linalg.norm(th_t - th_l))
    ratios = np.array(errs[:-1]) / np.array(errs[1:])
    assert np.all(ratios > 3.3) and np.all(ratios < 5.0), ratios
    # and it vanishes at the linearization point
    (th_t, w_t), (th_l, w_l) = _true_and_linear(base, dirs, 0.0, dt)
    assert np.linalg.norm(w_t - w_l) + np.linalg.norm(th_t - th_l) < 1e-12


def test_moment_error_is_the_product_of_force_and_foot_errors():
    """τ_true − τ_lin = Σ δp_foot × δf exactly when only feet and forces move."""
    rng = np.random.default_rng(3)
    p, v, R, w, f, feet = _random_point(rng)
    dt = np.array([0.05])
    Rs = np.concatenate([R, R])
    lz = linearize(np.concatenate([p, p]), np.concatenate([v, v]), Rs, np.concatenate([w, w]), f, feet,
                   np.zeros((1, 4, 2)), dt, INERTIA, G)  # fmt: skip
    df = rng.normal(size=(1, 4, 3)) * 10
    dd = rng.normal(size=(1, 4, 2)) * 0.03
    from planning.centroidal.dynamics import torque

    tau_true = torque(p, v, f + df, feet + dd @ _E_XY.T, dt, G)[0][0]
    tau_lin = lz.tau[0] + np.einsum("lij,lj->i", lz.T_f[0], df[0]) + np.einsum("lij,lj->i", lz.T_d[0], dd[0])
    expected = np.cross(dd[0] @ _E_XY.T, df[0]).sum(axis=0)
    assert np.allclose(tau_true - tau_lin, expected, atol=1e-9)


def test_discrete_map_is_close_to_the_continuous_equations():
    rng = np.random.default_rng(5)
    N = 10
    dt = np.full(N, 0.05)
    f = np.tile([[0, 0, 77.5]] * 4, (N, 1, 1)) + rng.normal(size=(N, 4, 3)) * 5
    feet = np.tile([[0.3, 0.17, 0.0], [0.3, -0.17, 0.0], [-0.3, 0.17, 0.0], [-0.3, -0.17, 0.0]], (N, 1, 1))
    args = (np.array([0, 0, 0.52]), np.array([0.05, 0.0, 0.0]), np.eye(3), np.array([0.1, -0.1, 0.1]), f, feet, dt,
            MASS, INERTIA, G)  # fmt: skip
    P1, V1, R1, W1 = rollout_discrete(*args)
    P2, V2, R2, W2 = rollout_continuous(*args, max_substep=0.001)
    assert np.max(np.abs(P1 - P2)) < 1e-3  # translation is exact up to the moment-arm drift inside a step
    e_rot = np.linalg.norm(_so3.log(R1 @ np.swapaxes(R2, -1, -2)), axis=-1)
    assert e_rot[1] < 5e-5  # one 50 ms step
    assert np.max(e_rot) < 1e-2  # half a second of them
    assert np.max(np.abs(W1 - W2)) < 0.03 * np.max(np.abs(W2))  # a few percent of rates near 1 rad/s


def test_rollout_discrete_matches_step_by_step():
    rng = np.random.default_rng(9)
    N = 6
    p, v, R, w, f1, feet1 = _random_point(rng)
    f = np.repeat(f1, N, axis=0) + rng.normal(size=(N, 4, 3))
    feet = np.repeat(feet1, N, axis=0)
    dt = np.array([0.05, 0.05, 0.1, 0.1, 0.15, 0.02])
    P, V, RR, W = rollout_discrete(p[0], v[0], R[0], w[0], f, feet, dt, MASS, INERTIA, G)
    x = (p, v, R, w)
    for k in range(N):
        x = discrete_step(*x, f[k : k + 1], feet[k : k + 1], dt[k : k + 1], MASS, INERTIA, G)
        assert (
            np.allclose(x[0][0], P[k + 1])
            and np.allclose(x[2][0], RR[k + 1])
            and np.allclose(x[3][0], W[k + 1])
        )


@pytest.mark.parametrize("seed", [0, 1])
def test_jacobian_blocks_match_finite_differences(seed):
    rng = np.random.default_rng(seed)
    base = _random_point(rng)
    dt = np.array([0.05])
    h = 1e-6
    names = ["p", "v", "th", "w"]
    for j, name in enumerate(names):
        for a in range(3):
            dirs = [np.zeros((1, 3)) for _ in range(4)] + [np.zeros((1, 4, 3)), np.zeros((1, 4, 2))]
            dirs[j][0, a] = 1.0
            (th_t, w_t), (th_l, w_l) = _true_and_linear(base, dirs, h, dt)
            assert np.linalg.norm(w_t - w_l) < 1e-8, (name, a)
            assert np.linalg.norm(th_t - th_l) < 1e-8, (name, a)
