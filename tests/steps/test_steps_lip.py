"""LIP capture points and closed-form prediction along step paths."""

from __future__ import annotations

import numpy as np
import pytest
from _steps_common import walking_reference
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import solve_ivp

from planning.steps import (
    capture_point,
    capture_point_relative,
    lip_omega,
    lip_predict,
    predict_touchdown_states,
    project_to_support,
)
from planning.steps.lip import PathBatch, predict_batch, sort_events

coord = st.floats(-5.0, 5.0, allow_nan=False)
height = st.floats(0.2, 1.5, allow_nan=False)


@given(x=coord, y=coord, z=height)
def test_capture_point_of_a_lip_at_rest_is_under_the_com(x: float, y: float, z: float) -> None:
    xi = capture_point(np.array([x, y, z]), np.zeros(3), z)
    assert np.allclose(xi, [x, y])


@given(vx=st.floats(-3, 3), vy=st.floats(-3, 3), z=height)
def test_pushed_lip_capture_point_moves_by_v_over_omega(vx: float, vy: float, z: float) -> None:
    p = np.array([0.2, -0.1, z])
    xi = capture_point(p, np.array([vx, vy, 0.0]), z)
    w = np.sqrt(9.81 / z)
    assert np.allclose(xi - p[:2], np.array([vx, vy]) / w)
    assert lip_omega(z) == pytest.approx(w)


def test_bad_height_is_rejected() -> None:
    with pytest.raises(ValueError, match="z"):
        lip_omega(0.0)


def _integrate(x0, v0, cop, t_end, omega):
    """Integrates x'' = ω²(x - cop(t)) from 0 to t_end (s) with a tight-tolerance ODE solver."""

    def f(t, s):
        return np.concatenate([s[2:], omega**2 * (s[:2] - cop(t))])

    sol = solve_ivp(
        f, (0.0, t_end), np.concatenate([x0, v0]), method="DOP853", rtol=1e-10, atol=1e-12, max_step=0.01
    )
    return sol.y[:2, -1], sol.y[2:, -1]


@settings(max_examples=20, deadline=None)
@given(
    x0=st.tuples(st.floats(-0.3, 0.3), st.floats(-0.3, 0.3)),
    v0=st.tuples(st.floats(-1, 1), st.floats(-1, 1)),
    u0=st.tuples(st.floats(-0.3, 0.3), st.floats(-0.3, 0.3)),
    u1=st.tuples(st.floats(-0.3, 0.3), st.floats(-0.3, 0.3)),
    tau=st.floats(0.01, 0.5),
)
def test_lip_closed_form_matches_integration(x0, v0, u0, u1, tau) -> None:
    w = lip_omega(0.5)
    u0a, u1a = np.array(u0), np.array(u1)
    x, v = lip_predict(np.array(x0), np.array(v0), u0a, tau, w)
    xn, vn = _integrate(x0, v0, lambda t: u0a, tau, w)
    assert np.allclose(x, xn, atol=1e-6) and np.allclose(v, vn, atol=1e-5)
    x, v = lip_predict(np.array(x0), np.array(v0), u0a, tau, w, u1=u1a)
    xn, vn = _integrate(x0, v0, lambda t: u0a + (u1a - u0a) * t / tau, tau, w)
    assert np.allclose(x, xn, atol=1e-6) and np.allclose(v, vn, atol=1e-5)


@pytest.mark.parametrize("gait", ["trot", "walk", "pace", "bound"])
def test_cof_prediction_matches_integration_along_a_path(gait: str) -> None:
    ref, state, _ = walking_reference(gait, (0.4, 0.1, 0.2), v_state=(0.3, 0.2))
    w = lip_omega(0.52)

    def cof(t: float) -> np.ndarray:
        c = ref.contact_at(t, state.contact)
        pos = state.p_world_feet[:, :2].copy()
        for i in range(ref.n_touchdowns):
            if t >= ref.t_touchdown[i]:
                pos[ref.leg[i]] = ref.p_world_touchdown[i, :2]
        return pos[c].mean(axis=0)

    pred = predict_touchdown_states(ref, state, w, estimate="cof")
    x, v, t = state.p_world_com[:2], state.v_world_com[:2], state.t
    for k in range(min(ref.n_touchdowns, 4)):  # the LIP diverges; compare where both stay meaningful
        x, v = _integrate(x, v, lambda s, t=t: cof(t + s), ref.t_touchdown[k] - t, w)
        t = ref.t_touchdown[k]
        assert np.allclose(pred.p_com[k], x, atol=2e-3), k
        assert np.allclose(pred.v_com[k], v, atol=2e-2), k
        assert np.allclose(pred.xi[k], x + v / w, atol=5e-3), k


def test_tracking_estimate_stays_nearer_the_plan_than_cof() -> None:
    ref, state, _ = walking_reference("trot", (0.5, 0.0, 0.0))
    w = lip_omega(0.52)
    plan = ref.body.position(ref.t_touchdown) + ref.body.velocity_world(ref.t_touchdown) / w
    err = {}
    for est in ("cof", "tracking"):
        xi = predict_touchdown_states(ref, state, w, estimate=est).xi
        err[est] = np.abs(xi - plan).max()
    assert err["tracking"] < 0.25 < err["cof"]


def test_relative_capture_points_are_eq2() -> None:
    ref, state, _ = walking_reference("trot", (0.5, 0.0, 0.0))
    pred = predict_touchdown_states(ref, state, lip_omega(0.52))
    for k in range(ref.n_touchdowns):
        leg = ref.leg[k]
        assert np.allclose(pred.xi_rel[k, leg], pred.xi[k] - ref.p_world_touchdown[k, :2])
    assert np.allclose(capture_point_relative(np.array([1.0, 2.0]), np.array([0.5, 0.5, 9.0])), [0.5, 1.5])


def test_batch_rows_are_independent() -> None:
    ref, state, _ = walking_reference("trot", (0.5, 0.0, 0.0))
    moved = ref.with_touchdowns(ref.p_world_touchdown + [0.05, -0.02, 0.0], "offset")
    w = lip_omega(0.52)
    both = predict_batch(PathBatch.of([ref, moved]), state, w)
    alone = predict_batch(PathBatch.of([moved]), state, w)
    assert np.allclose(both.xi_td[1], alone.xi_td[0])
    assert not np.allclose(both.xi_td[0], both.xi_td[1])
    ev = sort_events(PathBatch.of([ref]), state)
    assert np.all(np.diff(ev.times, axis=1) >= 0)


feet_st = st.lists(st.tuples(st.floats(-1, 1), st.floats(-1, 1)), min_size=4, max_size=4)


@settings(max_examples=60, deadline=None)
@given(
    feet=feet_st,
    mask=st.lists(st.booleans(), min_size=4, max_size=4),
    q=st.tuples(st.floats(-2, 2), st.floats(-2, 2)),
)
def test_projection_onto_the_support_polygon(feet, mask, q) -> None:
    f = np.array(feet)[None]
    m = np.array(mask)[None]
    qa = np.array(q)[None]
    p = project_to_support(qa, f, m)[0]
    if not m.any():
        assert np.allclose(p, q)
        return
    # Idempotent, and no farther than any stance foot or any point on an edge between stance feet.
    assert np.allclose(project_to_support(p[None], f, m)[0], p, atol=1e-9)
    d = np.linalg.norm(p - qa[0])
    sf = f[0][m[0]]
    assert d <= np.linalg.norm(sf - qa[0], axis=1).min() + 1e-9
    for i in range(len(sf)):
        for j in range(len(sf)):
            for s in np.linspace(0, 1, 11):
                assert d <= np.linalg.norm(sf[i] + s * (sf[j] - sf[i]) - qa[0]) + 1e-9
