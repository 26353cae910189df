"""The stance legs' joint damping about a body velocity (planning.handler.stance_damping_torques;
WalkParams.gait_stance_damping_ref): properties of the pure function on the reference robot's legs."""

from __future__ import annotations

import numpy as np

from planning.handler import stance_damping_torques
from planning.robot import load_robot

D = 0.5  # N·m·s/rad


def _legs() -> tuple[np.ndarray, np.ndarray]:
    """Jacobians (4,3,3) of the robot's legs in a standing pose (body frame = world: a level body)."""
    robot = load_robot("spot")
    q = np.array(robot.q_nominal, dtype=float)
    return q, np.array([robot.jacobian_leg(leg, q[leg]) for leg in range(4)])


def test_without_a_reference_it_is_plain_damping() -> None:
    _, J = _legs()
    qd = np.random.default_rng(0).normal(size=(4, 3))
    assert np.allclose(stance_damping_torques(qd, J, D), -D * qd)
    assert np.allclose(stance_damping_torques(qd, J, D, np.zeros(3)), -D * qd)


def test_a_foot_standing_still_under_the_reference_body_is_not_braked() -> None:
    _, J = _legs()
    v = np.array([2.5, -0.3, 0.4])  # only the horizontal part counts
    qd = np.array([np.linalg.solve(J[i], [-2.5, 0.3, 0.0]) for i in range(4)])  # the feet sweep back at v
    assert np.allclose(stance_damping_torques(qd, J, D, v), 0.0, atol=1e-9)
    # ... while damping about zero brakes a forward sweep: the ground's force on each foot points back
    fwd = np.array([np.linalg.solve(J[i], [-2.5, 0.0, 0.0]) for i in range(4)])
    tau0 = stance_damping_torques(fwd, J, D)
    for i in range(4):
        f_ground = -np.linalg.solve(J[i].T, tau0[i])  # tau = -J^T f (the stance handler's sign)
        assert f_ground[0] < 0.0


def test_motion_relative_to_the_sweep_is_damped_as_before() -> None:
    _, J = _legs()
    v = np.array([2.0, 0.0, 0.0])
    rng = np.random.default_rng(1)
    extra = rng.normal(size=(4, 3))
    sweep = np.array([np.linalg.solve(J[i], [-2.0, 0.0, 0.0]) for i in range(4)])
    assert np.allclose(stance_damping_torques(sweep + extra, J, D, v), -D * extra)


def test_a_singular_leg_is_damped_about_zero() -> None:
    _, J = _legs()
    J = J.copy()
    J[2] = 0.0
    qd = np.ones((4, 3))
    tau = stance_damping_torques(qd, J, D, np.array([1.0, 0.0, 0.0]))
    assert np.allclose(tau[2], -D * qd[2])
    assert np.all(np.isfinite(tau))


def test_the_walk_controller_sets_the_reference_in_the_listed_gaits_only() -> None:
    from dataclasses import replace

    from planning.sim.world import RobotState
    from planning.steps.gait import GaitClock
    from planning.walk import WalkController, WalkParams

    robot = load_robot("spot")
    off = WalkController(robot, WalkParams(), gait="gallop")
    off.planner.clock = GaitClock("gallop")
    s = RobotState()
    off.target.v_world_body[:] = (2.5, 0.0, 0.0)
    off.actuate(s)
    assert off.handler.stance_damping_v_ref is None  # off by default
    ctl = WalkController(
        robot, replace(WalkParams(), gait_stance_damping_ref=(("gallop", 0.3),)), gait="gallop"
    )
    ctl.target.v_world_body[:] = (2.5, 0.0, 0.0)
    ctl.planner.clock = GaitClock("gallop")
    ctl.actuate(s)
    assert np.allclose(ctl.handler.stance_damping_v_ref, (0.75, 0.0, 0.0))
    ctl.planner.clock = GaitClock("trot")
    ctl.actuate(s)
    assert ctl.handler.stance_damping_v_ref is None
