"""The slow gaits' support-triangle shift (planning.steps.support): pure functions over feet and the contact plan."""

from __future__ import annotations

import numpy as np
import pytest

from planning.robot import load_robot
from planning.steps.support import (
    SupportShiftParams,
    incentre,
    inside_triangle,
    liftoff_ready,
    project_into_triangle,
    shrink_triangle,
    support_target,
)


def _inside(p: np.ndarray, tri: np.ndarray, tol: float = 1e-9) -> bool:
    s = [
        (tri[(i + 1) % 3, 0] - tri[i, 0]) * (p[1] - tri[i, 1])
        - (tri[(i + 1) % 3, 1] - tri[i, 1]) * (p[0] - tri[i, 0])
        for i in range(3)
    ]
    return all(v >= -tol for v in s) or all(v <= tol for v in s)


def _feet() -> np.ndarray:
    """The robot's nominal stance feet (xy, body frame = world at the origin), FL FR RL RR."""
    return np.asarray(load_robot("spot").nominal_foot_body, dtype=np.float64)[:, :2]


def test_incentre_is_equidistant_from_the_edges() -> None:
    rng = np.random.default_rng(3)
    for _ in range(20):
        tri = rng.uniform(-1.0, 1.0, (3, 2))
        c, r = incentre(tri)
        for i in range(3):
            a, b = tri[i], tri[(i + 1) % 3]
            d = abs((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])) / np.linalg.norm(b - a)
            assert d == pytest.approx(r, rel=1e-6, abs=1e-9)
        assert _inside(c, tri)


def test_degenerate_triangle_has_zero_inradius() -> None:
    c, r = incentre(np.array([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]]))
    assert r == 0.0 and c == pytest.approx([1.0, 0.0])


def test_projection_keeps_inside_points_and_moves_outside_ones_onto_the_edge() -> None:
    rng = np.random.default_rng(5)
    for _ in range(50):
        tri = rng.uniform(-1.0, 1.0, (3, 2))
        p = rng.uniform(-2.0, 2.0, 2)
        q = project_into_triangle(p, tri)
        assert _inside(q, tri, 1e-7)
        if _inside(p, tri):
            assert q == pytest.approx(p)
        # no vertex nor random point of the triangle is closer
        for w in rng.dirichlet(np.ones(3), 20):
            assert np.linalg.norm(q - p) <= np.linalg.norm(w @ tri - p) + 1e-9


def test_shrunk_triangle_keeps_the_margin() -> None:
    tri = _feet()[[0, 1, 2]]
    c, r = incentre(tri)
    small = shrink_triangle(tri, 0.3)
    c2, r2 = incentre(small)
    assert c2 == pytest.approx(c) and r2 == pytest.approx(0.7 * r)


def test_lifting_leg_moves_target_into_the_other_three() -> None:
    """All four down, RR lifting now: the body centre (on the FR-RL diagonal) moves inside FL FR RL with the
    margin; far from the liftoff it is not moved."""
    feet = _feet()
    p = SupportShiftParams()
    stance = np.ones(4, dtype=bool)
    lo = np.array([5.0, 5.0, 5.0, 1.0])
    tri = shrink_triangle(feet[[0, 1, 2]], p.margin_fraction)
    at = support_target(np.zeros(2), feet, stance, lo, 1.0, p)
    assert _inside(at, tri, 1e-7)
    far = support_target(np.zeros(2), feet, stance, lo, 1.0 - 2.0 * p.ramp_s, p)
    assert far == pytest.approx([0.0, 0.0])
    half = support_target(np.zeros(2), feet, stance, lo, 1.0 - 0.5 * p.ramp_s, p)
    assert np.linalg.norm(half) == pytest.approx(0.5 * np.linalg.norm(at), rel=1e-6)


def test_one_leg_in_the_air_keeps_target_in_the_stance_triangle() -> None:
    """FL in the air: whatever the nominal point, the target lies in FR RL RR (shrunk), and it is pulled toward
    the coming triangle (RR lifts next) only within that."""
    feet = _feet()
    p = SupportShiftParams()
    stance = np.array([False, True, True, True])
    lo = np.array([np.nan, 3.0, 3.0, 1.05])
    tri = shrink_triangle(feet[[1, 2, 3]], p.margin_fraction)
    rng = np.random.default_rng(7)
    for _ in range(20):
        com = rng.uniform(-0.3, 0.3, 2)
        assert _inside(support_target(com, feet, stance, lo, 1.0, p), tri, 1e-7)


def test_no_shift_with_two_legs_in_the_air() -> None:
    feet = _feet()
    stance = np.array([True, False, False, True])
    lo = np.array([1.0, np.nan, np.nan, 1.0])
    assert support_target(np.array([0.1, 0.2]), feet, stance, lo, 1.0) == pytest.approx([0.1, 0.2])


def test_params_are_checked() -> None:
    with pytest.raises(ValueError):
        SupportShiftParams(margin_fraction=1.0)
    with pytest.raises(ValueError):
        SupportShiftParams(ramp_s=0.0)


def test_liftoff_waits_for_the_com_inside_the_other_three() -> None:
    feet = _feet()
    down = np.ones(4, dtype=bool)
    # RR lifting: the centre of mass on the FL side of the FR-RL diagonal may lift it, on the RR side not
    toward_fl = 0.25 * feet[0]
    toward_rr = 0.25 * feet[3]
    assert liftoff_ready(toward_fl, feet, down, down, 3)
    assert not liftoff_ready(toward_rr, feet, down, down, 3)
    # a margin asks for more than the edge
    on_diagonal = 0.5 * (feet[1] + feet[2])
    assert liftoff_ready(on_diagonal, feet, down, down, 3, 0.0)
    assert not liftoff_ready(on_diagonal, feet, down, down, 3, 0.2)


def test_liftoff_waits_for_the_landed_foot_to_carry_load() -> None:
    feet = _feet()
    down = np.ones(4, dtype=bool)
    loaded = np.array([False, True, True, True])  # FL just landed, the ground does not push it yet
    assert not liftoff_ready(0.25 * feet[0], feet, down, loaded, 3)
    assert liftoff_ready(0.25 * feet[0], feet, down, np.ones(4, dtype=bool), 3)
    # the lifting leg's own load does not matter
    assert liftoff_ready(0.25 * feet[0], feet, down, np.array([True, True, True, False]), 3)


def test_liftoff_check_does_not_apply_with_another_foot_in_the_air() -> None:
    feet = _feet()
    stance = np.array([False, True, True, True])
    assert liftoff_ready(10.0 * feet[3], feet, stance, np.zeros(4, dtype=bool), 3)


def test_inside_triangle_includes_edges() -> None:
    tri = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])
    assert inside_triangle(np.array([0.5, 0.5]), tri)
    assert inside_triangle(np.array([0.2, 0.2]), tri)
    assert not inside_triangle(np.array([0.6, 0.6]), tri)
