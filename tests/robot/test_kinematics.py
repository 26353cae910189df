"""Leg kinematics: FK/IK round trips over the workspace, Jacobians against finite differences, clear reach errors."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from planning.robot import LEGS, ReachError, RobotDescriptionError, load_robot

SPOT = load_robot("spot")
GO1 = load_robot("go1")


def _q_in_range(robot, leg: int, u: tuple[float, float, float]) -> np.ndarray:
    """Maps u in [0,1]^3 to joint angles inside the leg's ranges."""
    lo, hi = robot.q_min[leg], robot.q_max[leg]
    return lo + np.asarray(u) * (hi - lo)


unit = st.floats(0.0, 1.0)


@settings(max_examples=300, deadline=None)
@given(leg=st.integers(0, 3), u=st.tuples(unit, unit, unit), robot_name=st.sampled_from(["spot", "go1"]))
def test_fk_ik_round_trip(leg: int, u: tuple[float, float, float], robot_name: str) -> None:
    robot = SPOT if robot_name == "spot" else GO1
    q = _q_in_range(robot, leg, u)
    p = robot.fk_leg(leg, q)
    # The IK returns the branch with the foot below the hip's abduction plane (every standing and swinging pose);
    # configurations with the foot above it belong to the other branch.
    below = -robot.l_upper * np.cos(q[1]) - robot.l_lower * np.cos(q[1] + q[2]) < -1e-3
    assume(below)
    q2 = robot.ik_leg(leg, p)
    np.testing.assert_allclose(robot.fk_leg(leg, q2), p, atol=1e-9)
    np.testing.assert_allclose(q2, q, atol=1e-7)


@settings(max_examples=200, deadline=None)
@given(leg=st.integers(0, 3), u=st.tuples(unit, unit, unit))
def test_jacobian_matches_finite_differences(leg: int, u: tuple[float, float, float]) -> None:
    q = SPOT.q_min[leg] + np.asarray(u) * (SPOT.q_max[leg] - SPOT.q_min[leg])
    J = SPOT.jacobian_leg(leg, q)
    eps = 1e-6
    Jn = np.column_stack(
        [(SPOT.fk_leg(leg, q + eps * e) - SPOT.fk_leg(leg, q - eps * e)) / (2 * eps) for e in np.eye(3)]
    )
    np.testing.assert_allclose(J, Jn, atol=1e-7)


@pytest.mark.parametrize("leg", range(4))
def test_fk_agrees_with_mujoco(leg: int) -> None:
    m = SPOT.model
    d = mujoco.MjData(m)
    d.qpos[:] = SPOT.home_qpos()
    q = np.array([0.2, 0.6, -1.3])
    d.qpos[SPOT.qpos_idx[leg]] = q
    mujoco.mj_kinematics(m, d)
    p_mj = d.site_xpos[SPOT.foot_site_ids[leg]] - d.xpos[SPOT.body_id]
    np.testing.assert_allclose(SPOT.fk_leg(leg, q), p_mj, atol=1e-9)
    knee_mj = d.xpos[SPOT.legs[leg].knee_body]
    np.testing.assert_allclose(SPOT.knee_body(leg, q), knee_mj - d.xpos[SPOT.body_id], atol=1e-9)


def test_nominal_stance_is_reachable_and_symmetric() -> None:
    for robot in (SPOT, GO1):
        for i in range(4):
            p = robot.fk_leg(i, robot.q_nominal[i])
            np.testing.assert_allclose(p, robot.nominal_foot_body[i] + [0, 0, robot.foot_radius_m], atol=1e-9)
        np.testing.assert_allclose(robot.q_nominal[0], robot.q_nominal[3], atol=1e-12)


def test_spot_dimensions_are_spot_class() -> None:
    assert 30.0 <= SPOT.mass_kg <= 34.0
    np.testing.assert_allclose(np.abs(SPOT.p_body_hip[:, :2]), [[0.30, 0.055]] * 4)
    assert SPOT.l_upper == pytest.approx(0.32) and SPOT.l_lower == pytest.approx(0.34)
    assert SPOT.foot_radius_m == pytest.approx(0.035)
    np.testing.assert_allclose(SPOT.tau_max[0], [45, 45, 115])
    assert GO1.mass_kg < 15.0


def test_out_of_reach_is_a_clear_error() -> None:
    with pytest.raises(ReachError, match=r"FL: .* from the hip; the leg reaches"):
        SPOT.ik_leg(0, SPOT.p_body_hip[0] + [0.0, 0.11, -0.9])
    with pytest.raises(ReachError, match="RR"):
        SPOT.ik_leg(3, SPOT.p_body_hip[3] + [0.0, -0.11, -0.05])


def test_broken_description_names_the_missing_joint(tmp_path) -> None:
    src = (SPOT.mjcf_path.parent / "spot.yaml").read_text().replace("FL_hy", "FL_hip_pitch", 1)
    (tmp_path / "spot.xml").write_text(SPOT.mjcf_xml)
    (tmp_path / "broken.yaml").write_text(src)
    with pytest.raises(
        RobotDescriptionError, match=r"legs\.FL\.joints: joint 'FL_hip_pitch' is not in spot\.xml"
    ):
        load_robot(tmp_path / "broken.yaml")


def test_unknown_robot_lists_shipped_ones() -> None:
    with pytest.raises(RobotDescriptionError, match="shipped: go1, spot"):
        load_robot("atlas")


def test_leg_order_is_canonical() -> None:
    assert LEGS == ("FL", "FR", "RL", "RR")
    assert SPOT.p_body_hip[0, 0] > 0 and SPOT.p_body_hip[0, 1] > 0
    assert SPOT.p_body_hip[3, 0] < 0 and SPOT.p_body_hip[3, 1] < 0


@pytest.mark.parametrize("robot", [SPOT, GO1], ids=["spot", "go1"])
def test_vectorized_ik_and_knees_are_bit_identical_to_the_scalar_ones(robot) -> None:
    """ik_leg_many/knee_body_many: the same angles and knees as ik_leg/knee_body, bit for bit, and the same rows
    out of reach (where ik_leg raises), for batches of every length the swing planner uses."""
    rng = np.random.default_rng(3)
    reachable = unreachable = 0
    for leg in range(4):
        for K in (1, 2, 5, 8, 9, 17):
            p = robot.nominal_foot_body[leg] + rng.normal(0.0, 0.15, (K, 3))
            q, ok = robot.ik_leg_many(leg, p)
            knees = robot.knee_body_many(leg, q)
            for k in range(K):
                try:
                    q_one = robot.ik_leg(leg, p[k])
                except ReachError:
                    assert not ok[k]
                    unreachable += 1
                    continue
                assert ok[k]
                assert np.array_equal(q[k], q_one)
                assert np.array_equal(knees[k], robot.knee_body(leg, q_one))
                reachable += 1
    assert reachable > 50 and unreachable > 5


@pytest.mark.parametrize("robot", [SPOT, GO1], ids=["spot", "go1"])
def test_knee_of_foot_is_the_knee_of_the_ik(robot) -> None:
    """knee_of_foot (floats, the math module): the knee of ik_leg's angles to a micrometer, and None exactly where
    ik_leg raises."""
    rng = np.random.default_rng(5)
    reachable = unreachable = 0
    for leg in range(4):
        for p in robot.nominal_foot_body[leg] + rng.normal(0.0, 0.15, (150, 3)):
            got = robot.knee_of_foot(leg, *p.tolist())
            try:
                want = robot.knee_body(leg, robot.ik_leg(leg, p))
            except ReachError:
                assert got is None
                unreachable += 1
                continue
            assert got is not None
            assert np.abs(np.array(got) - want).max() < 1e-6
            reachable += 1
    assert reachable > 200 and unreachable > 20
