"""Shared fixtures for the centroidal tests: the robot's body model and a constraint checker for solutions."""

from __future__ import annotations

import numpy as np
import pytest

from planning.centroidal.problem import BodyModel, CentroidalProblem
from planning.centroidal.scenarios import default_model
from planning.centroidal.solver import CentroidalSolution


@pytest.fixture(scope="session")
def model() -> BodyModel:
    return default_model()


def _leg_lengths(sol: CentroidalSolution, pr: CentroidalProblem) -> list[tuple[int, int, float]]:
    """(knot, leg, hip-to-foot-center distance) for every knot >= 1 where the leg has a foot on the ground."""
    m = pr.model
    out = []
    hips = sol.p_world[:, None, :] + np.einsum("kij,lj->kli", sol.R_world_body, m.p_body_hip)
    for k in range(1, sol.t_knots.size):
        for i in range(4):
            # the foot of the interval ending or starting at knot k
            ks = [j for j in (k - 1, k) if j < sol.in_contact.shape[0] and sol.in_contact[j, i]]
            if not ks:
                continue
            foot = sol.p_world_foot[ks[-1], i] + m.foot_radius_m * np.array([0.0, 0.0, 1.0])
            out.append((k, i, float(np.linalg.norm(hips[k, i] - foot))))
    return out


def check_solution(sol: CentroidalSolution, pr: CentroidalProblem, tol_n: float = 0.5) -> None:
    """Asserts the plan respects its constraints: forces, friction cone, swing legs, leg lengths, dynamics."""
    assert sol.f_world.shape[0] == pr.n_knots - 1, sol.message
    f = sol.f_world
    fz = f[..., 2]
    ft = np.linalg.norm(f[..., :2], axis=-1)
    stance = pr.contact  # nominal; with no timing windows the schedule equals it
    air = ~sol.in_contact
    assert np.all(np.abs(f[air]) < 1e-3 + 1e-6 * pr.fz_max_N), "force on a foot in the air"
    assert np.all(fz[stance & sol.in_contact] >= pr.fz_min_N - tol_n), "stance foot below fz_min"
    assert np.all(fz <= pr.fz_max_N + tol_n)
    # The pyramid refined by cuts: within a couple of percent of the cone.
    assert np.all(ft <= pr.mu * fz * 1.03 + tol_n), (
        f"friction cone: max ratio {np.max(ft / np.maximum(fz, 1e-9))}"
    )
    for k, i, dist in _leg_lengths(sol, pr):
        assert pr.model.leg_length_min_m - 0.006 <= dist <= pr.model.leg_length_max_m + 0.006, (k, i, dist)
    assert sol.linearization_error < 0.02


@pytest.fixture
def checker():
    return check_solution
