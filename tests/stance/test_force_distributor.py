"""ForceDistributor: standing wrench, agreement with clarabel, constraint invariants, odd inputs."""

from __future__ import annotations

import math

import numpy as np
import pytest
from _stance_gen import (
    P_COM_FOOT_SPOT,
    forces_in_pyramid,
    random_normals,
    reference_distribution,
)
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from planning.forces import (
    ForceDistributor,
    ForceDistributorParams,
    contact_frames,
    pyramid_mu,
    pyramid_violation,
)

MASS_KG = 32.0
MG = MASS_KG * 9.81
ALL = np.ones(4, dtype=bool)

# One distributor for the property tests: it must stay right across calls with changing masks, normals and μ,
# which is what in-place updates and warm starts have to get right.
_SHARED = ForceDistributor(MASS_KG)

masks = st.lists(st.booleans(), min_size=4, max_size=4).map(np.array)
seeds = st.integers(0, 2**32 - 1)


def wrench_of(f: np.ndarray, r: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    return f.sum(axis=0), np.cross(r, f).sum(axis=0)


def test_standing_gravity_only_gives_a_quarter_weight_per_leg() -> None:
    dist = ForceDistributor(MASS_KG)
    f, status = dist.solve(np.array([0.0, 0.0, MG]), np.zeros(3), P_COM_FOOT_SPOT, ALL)
    assert status.ok, status
    np.testing.assert_allclose(f[:, 2], MG / 4, atol=1e-3)
    np.testing.assert_allclose(f[:, :2], 0.0, atol=1e-3)


def test_two_leg_stance_reproduces_an_achievable_wrench() -> None:
    dist = ForceDistributor(MASS_KG)
    contact = np.array([True, False, False, True])  # trot pair FL + RR
    f_true = np.array([[4.0, -2.0, 0.55 * MG], [0, 0, 0], [0, 0, 0], [1.0, -1.0, 0.45 * MG]])
    force, torque = wrench_of(f_true, P_COM_FOOT_SPOT)
    f, status = dist.solve(force, torque, P_COM_FOOT_SPOT, contact)
    assert status.ok, status
    got_force, got_torque = wrench_of(f, P_COM_FOOT_SPOT)
    np.testing.assert_allclose(got_force, force, atol=0.5)
    np.testing.assert_allclose(got_torque, torque, atol=0.2)
    np.testing.assert_array_equal(f[[1, 2]], 0.0)


def test_regularizes_toward_the_reference_forces() -> None:
    dist = ForceDistributor(MASS_KG, ForceDistributorParams(alpha=1.0))
    f_ref = np.tile([0.0, 0.0, MG / 4], (4, 1))
    f_ref[0, 2] += 40.0  # lopsided reference: FL carries more
    f, _ = dist.solve(np.array([0.0, 0.0, MG]), np.zeros(3), P_COM_FOOT_SPOT, ALL, f_world_ref=f_ref)
    f_plain, _ = ForceDistributor(MASS_KG, ForceDistributorParams(alpha=1.0)).solve(
        np.array([0.0, 0.0, MG]), np.zeros(3), P_COM_FOOT_SPOT, ALL
    )
    assert f[0, 2] > f_plain[0, 2] + 5.0


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=seeds, contact=masks, tilted=st.booleans())
def test_matches_clarabel_on_random_feasible_problems(seed: int, contact: np.ndarray, tilted: bool) -> None:
    rng = np.random.default_rng(seed)
    r = P_COM_FOOT_SPOT + rng.normal(scale=0.05, size=(4, 3))
    mu = float(rng.uniform(0.3, 1.0))
    normals = random_normals(rng, 0.4) if tilted else None
    fz_min, fz_max = 5.0, float(rng.choice([400.0, math.inf]))
    force = np.array([0.0, 0.0, MG]) + rng.normal(scale=[30.0, 30.0, 60.0])
    torque = rng.normal(scale=10.0, size=3)
    f, status = _SHARED.solve(
        force, torque, r, contact, mu=mu, fz_min_n=fz_min, fz_max_n=fz_max, n_world_contact=normals
    )
    f_ref = reference_distribution(MASS_KG, force, torque, r, contact, mu, fz_min, fz_max, normals)
    assert status.solver == "solved" and not status.fallback, status
    assert np.abs(f - f_ref).max() < 0.5


@settings(max_examples=200, deadline=None)
@given(
    seed=seeds,
    contact=masks,
    scale=st.sampled_from([1.0, 1e3, 1e6, -1.0]),
    mu=st.sampled_from([0.0, 0.2, 0.8, 5.0, -1.0, math.nan]),
    fz=st.sampled_from([(5.0, math.inf), (5.0, 50.0), (60.0, 10.0), (-3.0, 100.0), (math.nan, math.nan)]),
    nan_in=st.sampled_from(["none", "force", "torque", "r", "ref"]),
)
def test_never_raises_and_keeps_every_constraint(
    seed: int, contact: np.ndarray, scale: float, mu: float, fz: tuple[float, float], nan_in: str
) -> None:
    rng = np.random.default_rng(seed)
    force = rng.normal(scale=MG, size=3) * scale
    torque = rng.normal(scale=50.0, size=3) * scale
    r = P_COM_FOOT_SPOT + rng.normal(scale=0.1, size=(4, 3))
    f_ref = rng.normal(scale=100.0, size=(4, 3))
    normals = random_normals(rng, 0.6)
    if nan_in == "force":
        force[0] = math.nan
    elif nan_in == "torque":
        torque[2] = math.inf
    elif nan_in == "r":
        r[1, 1] = math.nan
    elif nan_in == "ref":
        f_ref[3, 0] = math.nan
    f, status = _SHARED.solve(
        force,
        torque,
        r,
        contact,
        mu=mu,
        fz_min_n=fz[0],
        fz_max_n=fz[1],
        n_world_contact=normals,
        f_world_ref=f_ref,
    )
    assert np.isfinite(f).all()
    swing = ~contact
    if nan_in == "r":
        swing = swing.copy()
        swing[1] = True  # a leg with an unknown position carries nothing
        assert "p_com_foot_world" in status.sanitized
    np.testing.assert_array_equal(f[swing], 0.0)
    R = contact_frames(normals)
    mu_face = pyramid_mu(mu, True)
    assert (pyramid_violation(f, R, mu_face) <= 1e-9 * (1.0 + np.abs(f).max())).all()
    fn = np.einsum("ij,ij->i", R[:, :, 2], f)
    lo = fz[0] if math.isfinite(fz[0]) and fz[0] >= 0 else 0.0
    hi = fz[1] if fz[1] >= lo else lo  # NaN compares False: no upper bound
    if math.isnan(fz[1]):
        hi = math.inf
    stance = ~swing
    assert (fn[stance] >= lo - 1e-9).all() and (fn[stance] <= hi + 1e-9 * (1.0 + hi)).all()


def test_odd_inputs_are_named_in_the_status() -> None:
    dist = ForceDistributor(MASS_KG)
    _, status = dist.solve(
        np.array([math.nan, 0.0, MG]),
        np.zeros(3),
        P_COM_FOOT_SPOT,
        ALL,
        mu=-1.0,
        fz_min_n=50.0,
        fz_max_n=10.0,
    )
    assert set(status.sanitized) == {"force_world_des", "mu", "fz_max_n"}
    assert not status.ok


def test_wrong_shapes_raise_naming_the_field() -> None:
    dist = ForceDistributor(MASS_KG)
    with pytest.raises(ValueError, match="p_com_foot_world"):
        dist.solve(np.zeros(3), np.zeros(3), np.zeros((3, 3)), ALL)
    with pytest.raises(ValueError, match="contact"):
        dist.solve(np.zeros(3), np.zeros(3), P_COM_FOOT_SPOT, np.ones(3, bool))
    with pytest.raises(ValueError, match="mass_kg"):
        ForceDistributor(-1.0)


def test_a_feasible_wrench_from_pyramid_forces_is_reproduced() -> None:
    rng = np.random.default_rng(7)
    dist = ForceDistributor(MASS_KG)
    R = contact_frames(None)
    for _ in range(20):
        f_true = forces_in_pyramid(rng, R, pyramid_mu(0.6, True), 40.0, 120.0)
        force, torque = wrench_of(f_true, P_COM_FOOT_SPOT)
        f, status = dist.solve(force, torque, P_COM_FOOT_SPOT, ALL)
        got_force, got_torque = wrench_of(f, P_COM_FOOT_SPOT)
        assert status.ok
        assert np.abs(got_force - force).max() < 0.5
        assert np.abs(got_torque - torque).max() < 0.2
