"""StanceHandler: torque limits and the friction pyramid hold for any input; feasible plans pass through."""

from __future__ import annotations

import math

import numpy as np
import pytest
from _stance_gen import (
    P_COM_FOOT_SPOT,
    forces_in_pyramid,
    random_jacobians,
    random_normals,
    reference_handler,
)
from hypothesis import given, settings
from hypothesis import strategies as st

from planning.forces import contact_frames, pyramid_mu, pyramid_violation
from planning.stance import StanceHandler, StanceHandlerParams

TAU_MAX_SPOT = np.tile([45.0, 45.0, 115.0], (4, 1))
FZ_MIN = StanceHandlerParams().fz_min_n
ALL = np.ones(4, dtype=bool)

# One handler across all examples: updates in place and warm starts must not leak one tick into the next.
_SHARED = StanceHandler()

masks = st.lists(st.booleans(), min_size=4, max_size=4).map(np.array)
seeds = st.integers(0, 2**32 - 1)


def assert_invariants(
    handler: StanceHandler,
    tau: np.ndarray,
    J: np.ndarray,
    contact: np.ndarray,
    tau_max: np.ndarray,
    tau_bias: np.ndarray,
    mu: float,
    normals: np.ndarray | None,
) -> None:
    f = handler.f_world_applied
    assert np.isfinite(tau).all() and np.isfinite(f).all()
    limit = np.where(np.isnan(tau_max), 0.0, np.abs(tau_max))
    assert (np.abs(tau) <= limit * (1.0 + 1e-6) + 1e-9).all(), "torque limit exceeded"
    np.testing.assert_array_equal(tau[~contact], 0.0)
    np.testing.assert_array_equal(f[~contact], 0.0)
    mu_face = pyramid_mu(mu, True)
    assert (pyramid_violation(f, contact_frames(normals), mu_face) <= 1e-9 * (1.0 + np.abs(f).max())).all()
    if not handler.last_status.torque_clipped:
        # The torques are exactly the applied forces mapped through the legs.
        tau_expected = tau_bias - np.einsum("ick,ic->ik", J, f)
        np.testing.assert_allclose(tau[contact], tau_expected[contact], atol=1e-6 * (1.0 + limit.max()))


@settings(max_examples=300, deadline=None)
@given(
    seed=seeds,
    contact=masks,
    jac=st.sampled_from(["good", "good", "singular", "zero"]),
    plan=st.sampled_from(["nominal", "huge", "negative_fz", "pulling", "sideways", "nan"]),
    bias=st.sampled_from(["zero", "gravity", "beyond_limits"]),
    mu=st.sampled_from([0.0, 0.3, 0.8, -1.0]),
    tilted=st.booleans(),
    wrench_term=st.booleans(),
)
def test_limits_and_friction_hold_for_any_input(
    seed: int,
    contact: np.ndarray,
    jac: str,
    plan: str,
    bias: str,
    mu: float,
    tilted: bool,
    wrench_term: bool,
) -> None:
    rng = np.random.default_rng(seed)
    J = random_jacobians(rng, jac)
    f_des = np.tile([0.0, 0.0, 80.0], (4, 1)) + rng.normal(scale=10.0, size=(4, 3))
    if plan == "huge":
        f_des *= 1e4
    elif plan == "negative_fz":
        f_des[:, 2] = -np.abs(f_des[:, 2])
    elif plan == "pulling":
        f_des *= -50.0
    elif plan == "sideways":
        f_des[:, 0] = 5.0 * f_des[:, 2]
    elif plan == "nan":
        f_des[rng.integers(4), rng.integers(3)] = math.nan
    tau_bias = np.zeros((4, 3))
    if bias == "gravity":
        tau_bias = rng.normal(scale=5.0, size=(4, 3))
    elif bias == "beyond_limits":
        tau_bias = rng.choice([-1.0, 1.0], size=(4, 3)) * TAU_MAX_SPOT * rng.uniform(0.5, 2.0, size=(4, 3))
    normals = random_normals(rng, 0.5) if tilted else None
    tau = _SHARED.solve(
        f_des,
        J,
        contact,
        TAU_MAX_SPOT,
        tau_bias_leg=tau_bias,
        mu=mu,
        n_world_contact=normals,
        p_com_foot_world=P_COM_FOOT_SPOT if wrench_term else None,
    )
    assert_invariants(_SHARED, tau, J, contact, TAU_MAX_SPOT, tau_bias, mu, normals)
    if plan == "nan":
        assert "f_world_des" in _SHARED.last_status.sanitized


@settings(max_examples=150, deadline=None)
@given(seed=seeds, contact=masks, tilted=st.booleans(), wrench_term=st.booleans())
def test_a_feasible_plan_is_returned_unchanged(
    seed: int, contact: np.ndarray, tilted: bool, wrench_term: bool
) -> None:
    rng = np.random.default_rng(seed)
    J = random_jacobians(rng, "good")
    mu = float(rng.uniform(0.2, 1.0))
    normals = random_normals(rng, 0.4) if tilted else None
    f_des = forces_in_pyramid(rng, contact_frames(normals), pyramid_mu(mu, True), FZ_MIN + 1.0, 300.0)
    f_des[~contact] = 0.0
    tau_bias = rng.normal(scale=5.0, size=(4, 3))
    tau_needed = np.abs(tau_bias - np.einsum("ick,ic->ik", J, f_des))
    tau_max = tau_needed * rng.uniform(1.01, 2.0, size=(4, 3)) + 0.1  # limits with a margin
    tau = _SHARED.solve(
        f_des,
        J,
        contact,
        tau_max,
        tau_bias_leg=tau_bias,
        mu=mu,
        n_world_contact=normals,
        p_com_foot_world=P_COM_FOOT_SPOT if wrench_term else None,
    )
    status = _SHARED.last_status
    assert status.ok, status
    assert np.abs(_SHARED.f_world_applied - f_des).max() < 1e-3
    assert_invariants(_SHARED, tau, J, contact, tau_max, tau_bias, mu, normals)


@settings(max_examples=60, deadline=None)
@given(seed=seeds, contact=masks)
def test_an_infeasible_plan_becomes_the_closest_feasible_one(seed: int, contact: np.ndarray) -> None:
    rng = np.random.default_rng(seed)
    J = random_jacobians(rng, "good")
    handler = StanceHandler(StanceHandlerParams(w_normal=1.0, w_tangent=1.0))
    f_des = np.tile([0.0, 0.0, 150.0], (4, 1)) + rng.normal(scale=40.0, size=(4, 3))
    tau_max = np.tile([15.0, 15.0, 30.0], (4, 1))  # too weak for most plans, strong enough for fz_min
    tau = handler.solve(f_des, J, contact, tau_max, mu=0.6)
    f_ref = reference_handler(f_des, J, contact, tau_max, np.zeros((4, 3)), 0.6, FZ_MIN, None)
    assert not handler.last_status.fallback
    assert np.abs(handler.f_world_applied - f_ref).max() < 0.05
    assert_invariants(handler, tau, J, contact, tau_max, np.zeros((4, 3)), 0.6, None)


def test_weak_joints_relax_fz_min_instead_of_leaving_the_limits() -> None:
    J = np.tile(np.diag([0.4, 0.4, 0.4]), (4, 1, 1))
    handler = StanceHandler()
    tau_max = np.full((4, 3), 1.0)  # 1 N·m over 0.4 m: at most 2.5 N < fz_min
    tau = handler.solve(np.tile([0.0, 0.0, 80.0], (4, 1)), J, ALL, tau_max)
    status = handler.last_status
    assert status.fz_min_relaxed and not status.torque_clipped
    np.testing.assert_allclose(handler.f_world_applied[:, 2], 2.5, atol=1e-6)
    assert (np.abs(tau) <= 1.0 + 1e-12).all()


def test_bias_beyond_the_limits_clips_torques_and_says_so() -> None:
    J = np.tile(np.diag([0.4, 0.4, 0.4]), (4, 1, 1))
    handler = StanceHandler()
    tau_bias = np.full((4, 3), 500.0)
    tau = handler.solve(np.tile([0.0, 0.0, 80.0], (4, 1)), J, ALL, TAU_MAX_SPOT, tau_bias_leg=tau_bias)
    assert handler.last_status.torque_clipped and not handler.last_status.ok
    assert (np.abs(tau) <= TAU_MAX_SPOT).all()
    # Pushing down (fz > 0) lowers τ = bias - Jᵀf, so the handler pushes as hard as the pyramid lets it.
    assert (handler.f_world_applied[:, 2] > 0.0).all()


def test_one_hopeless_leg_does_not_spoil_the_others() -> None:
    J = np.tile(np.diag([0.4, 0.4, 0.4]), (4, 1, 1))
    handler = StanceHandler()
    tau_bias = np.zeros((4, 3))
    tau_bias[2] = 500.0  # RL: its bias alone is beyond every limit
    f_des = np.tile([3.0, -2.0, 80.0], (4, 1))
    tau = handler.solve(f_des, J, ALL, TAU_MAX_SPOT, tau_bias_leg=tau_bias)
    status = handler.last_status
    assert not status.fallback and status.torque_clipped
    np.testing.assert_allclose(handler.f_world_applied[[0, 1, 3]], f_des[[0, 1, 3]], atol=1e-3)
    assert (np.abs(tau) <= TAU_MAX_SPOT).all()


def test_wrench_term_hands_a_saturated_legs_load_to_the_others() -> None:
    J = np.tile(np.diag([0.4, 0.4, 0.4]), (4, 1, 1))
    tau_max = TAU_MAX_SPOT.copy()
    tau_max[0] = [45.0, 45.0, 20.0]  # FL can carry only 50 N
    f_des = np.tile([0.0, 0.0, 78.0], (4, 1))
    with_wrench = StanceHandler(StanceHandlerParams(w_wrench_force=10.0))
    without = StanceHandler(StanceHandlerParams(w_wrench_force=0.0, w_wrench_torque=0.0))
    with_wrench.solve(f_des, J, ALL, tau_max, p_com_foot_world=P_COM_FOOT_SPOT)
    without.solve(f_des, J, ALL, tau_max, p_com_foot_world=P_COM_FOOT_SPOT)
    np.testing.assert_allclose(without.f_world_applied[1:, 2], 78.0, atol=1e-3)
    assert with_wrench.f_world_applied[0, 2] == pytest.approx(50.0, abs=1e-3)
    total = with_wrench.f_world_applied[:, 2].sum()
    assert total > without.f_world_applied[:, 2].sum() + 10.0


def test_timing_and_status_are_exposed() -> None:
    handler = StanceHandler()
    J = np.tile(np.diag([0.4, 0.4, 0.4]), (4, 1, 1))
    handler.solve(np.tile([0.0, 0.0, 80.0], (4, 1)), J, ALL, TAU_MAX_SPOT)
    assert handler.last_status.ok
    assert 0.0 < handler.last_solve_ms < 1000.0
    with pytest.raises(ValueError):
        handler.f_world_applied[0, 0] = 1.0  # a read-only view of the handler's buffer


def test_wrong_shapes_and_params_raise_naming_the_field() -> None:
    handler = StanceHandler()
    J = np.tile(np.eye(3), (4, 1, 1))
    with pytest.raises(ValueError, match="J_world_leg"):
        handler.solve(np.zeros((4, 3)), J[:3], ALL, TAU_MAX_SPOT)
    with pytest.raises(ValueError, match="tau_max_leg"):
        handler.solve(np.zeros((4, 3)), J, ALL, np.zeros(12))
    with pytest.raises(ValueError, match="w_normal"):
        StanceHandlerParams(w_normal=0.0)


def test_the_feasible_shortcut_gives_the_qp_answer() -> None:
    """Skipping the solve for a plan that meets every limit returns what the QP would (its zero-cost optimum)."""
    from planning.robot import load_robot
    from planning.stance import StanceHandlerParams

    robot = load_robot("spot")
    J = np.array([robot.jacobian_leg(i, robot.q_nominal[i]) for i in range(4)])
    rng = np.random.default_rng(3)
    fast, full = StanceHandler(), StanceHandler(StanceHandlerParams(skip_feasible=False))
    hits = 0
    for _ in range(50):
        f = np.zeros((4, 3))
        f[:, 2] = rng.uniform(20.0, 120.0, 4)
        f[:, :2] = rng.uniform(-0.3, 0.3, (4, 2)) * f[:, 2:3]
        contact = rng.random(4) < 0.8
        tau_fast = fast.solve(f, J, contact, robot.tau_max).copy()
        tau_full = full.solve(f, J, contact, robot.tau_max).copy()
        np.testing.assert_allclose(tau_fast, tau_full, atol=2e-3)
        hits += fast.last_status.solver == "feasible as planned"
    assert hits > 25  # the shortcut is actually taken for most of these plans
