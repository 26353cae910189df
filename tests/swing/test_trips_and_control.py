"""Trips (seed FIG. 16) and the joint command of a position-controlled swing leg."""

import numpy as np
import pytest

from planning.swing import (
    Box,
    BoxGround,
    SwingParams,
    SwingRequest,
    Tier,
    TripEvent,
    TripKind,
    classify_trip,
    flat_ground,
    legs_crossed,
    swing_joint_command,
)

P = SwingParams()
STANCE = {1: np.array([0.3, -0.165, 0.0]), 2: np.array([-0.3, 0.165, 0.0]), 3: np.array([-0.3, -0.165, 0.0])}


def _req(trip=None, t_td=0.35, p=(0.35, 0.165, 0.05), v=(1.0, 0.0, 0.3)):
    return SwingRequest(0, np.array(p), np.array(v), np.array([0.50, 0.165, 0.0]), t_td, trip)


def test_normal_trip_stops_forward_motion_and_elevates(planner, standing_body):
    plan = planner.plan(
        0.1, [_req(TripEvent(TripKind.NORMAL, 0.1))], flat_ground, STANCE, standing_body(0.1)
    )[0]
    assert plan.policy_names == ("Trip:StopForward", "Elevate")
    assert plan.trip is TripKind.NORMAL
    p_end, v_end, _ = plan.sample(0.3)
    assert p_end[0] == pytest.approx(0.35 + 1.0 / (2 * P.a_max_xy_mps2))  # braked to a stop, no further
    assert v_end[0] == pytest.approx(0.0)
    assert p_end[2] == pytest.approx(0.05 + P.trip_lift_m, abs=1e-3)  # raised and held
    assert np.all(np.diff(plan.positions(np.linspace(0.1, 0.3, 50))[:, 2]) >= -1e-12)


def test_normal_trip_on_a_riser_elevates_over_it(planner, standing_body):
    """A foot that stubs a riser (mapped ground on its way higher than where it tripped + trip_lift_m) rises over
    the riser's top by the foot radius and the clearance margin, not only trip_lift_m above where it tripped."""
    riser = BoxGround([Box(0.40, 1.0, -1.0, 1.0, 0.15)])
    req = SwingRequest(
        0,
        np.array([0.35, 0.165, 0.03]),
        np.zeros(3),
        np.array([0.55, 0.165, 0.15]),
        0.5,
        TripEvent(TripKind.NORMAL, 0.1),
    )
    plan = planner.plan(0.1, [req], riser, STANCE, standing_body(0.1))[0]
    assert plan.vertical_policy == "Elevate"
    z_top = float(plan.positions(np.linspace(0.1, 0.5, 80))[:, 2].max())
    robot_r = planner.robot.foot_radius_m
    assert z_top >= 0.15 + robot_r + P.clearance_margin_m - 1e-6
    assert z_top > 0.03 + P.trip_lift_m + 0.01  # more than the flat-ground response


def test_recent_normal_trip_elevates_then_it_expires(planner, standing_body):
    t_trip = 0.1
    planner.plan(
        t_trip, [_req(TripEvent(TripKind.NORMAL, t_trip))], flat_ground, STANCE, standing_body(t_trip)
    )
    for t in np.arange(t_trip + 0.003, t_trip + P.trip_response_s, 0.003):  # the loop replans every 3 ms
        plan = planner.plan(t, [_req(t_td=0.7)], flat_ground, STANCE, standing_body(t))[0]
        assert plan.horizontal_policy == "Trip:StopForward"
    t = t_trip + P.trip_response_s + 0.003
    plan = planner.plan(t, [_req(t_td=0.7)], flat_ground, STANCE, standing_body(t))[0]
    assert not plan.horizontal_policy.startswith("Trip:")
    assert plan.vertical_policy == "Aggressive"  # recent normal trip: elevate the foot
    # Keep replanning until the trip is no longer recent: the foot goes back to the gentlest vertical.
    for tk in np.arange(t + 0.003, t_trip + P.recent_trip_s + 0.01, 0.003):
        plan = planner.plan(tk, [_req(t_td=0.9)], flat_ground, STANCE, standing_body(tk))[0]
    assert plan.vertical_policy.startswith("Gentle")


def test_knee_trip_moves_on_slowly(planner, standing_body):
    req = _req(TripEvent(TripKind.KNEE, 0.1), v=(0.0, 0.0, 0.0))
    plan = planner.plan(0.1, [req], flat_ground, STANCE, standing_body(0.1))[0]
    assert plan.horizontal_policy == "Trip:Knee"
    v = plan.derivatives(np.linspace(0.1, 0.6, 300), 1)
    assert np.abs(v[:, :2]).max() <= P.knee_trip_speed_frac * P.v_max_xy_mps + 1e-9
    assert plan.sample(0.6)[0][0] == pytest.approx(0.50)


def test_crossed_self_collision_disentangles_to_its_own_side(planner, standing_body):
    # FL's foot ended up right of FR's (crossed): go back left of FR first, then on to the target.
    stance = dict(STANCE)
    stance[1] = np.array([0.35, 0.0, 0.0])
    req = SwingRequest(
        0,
        np.array([0.35, -0.06, 0.05]),
        np.zeros(3),
        np.array([0.50, 0.165, 0.0]),
        0.5,
        TripEvent(TripKind.SELF_CROSSED, 0.1, other_leg=1),
    )
    plan = planner.plan(0.1, [req], flat_ground, stance, standing_body(0.1))[0]
    assert plan.horizontal_policy == "Trip:Disentangle"
    pts = plan.positions(np.linspace(0.1, 0.6, 400))
    clear_y = 0.0 + P.keepout_radius_m + P.disentangle_margin_m
    i_clear = int(np.argmax(pts[:, 1] >= clear_y - 1e-9))
    assert i_clear > 0
    assert np.abs(pts[:i_clear, 0] - 0.35).max() < 1e-9  # no x motion until back on its own side


def test_uncrossed_self_collision_side_steps_away(planner, standing_body):
    stance = dict(STANCE)
    stance[1] = np.array([0.35, 0.0, 0.0])
    req = SwingRequest(
        0,
        np.array([0.30, 0.08, 0.05]),
        np.zeros(3),
        np.array([0.50, 0.165, 0.0]),
        0.5,
        TripEvent(TripKind.SELF_UNCROSSED, 0.1, other_leg=1),
    )
    plan = planner.plan(0.1, [req], flat_ground, stance, standing_body(0.1))[0]
    assert plan.horizontal_policy == "Trip:SideStep"
    ys = plan.positions(np.linspace(0.1, 0.6, 400))[:, 1]
    assert ys.max() >= 0.08 + P.disentangle_margin_m - 1e-9
    assert plan.sample(0.6)[0][:2] == pytest.approx([0.50, 0.165])


def test_simulated_contacts_classify_into_the_table(robot):
    feet = robot.nominal_foot_body.copy()
    assert classify_trip(robot, 0, 1.0, feet, foot_hit=True).kind is TripKind.NORMAL
    assert classify_trip(robot, 0, 1.0, feet, foot_hit=True, knee_hit=True).kind is TripKind.KNEE
    assert classify_trip(robot, 0, 1.0, feet, other_leg=1).kind is TripKind.SELF_UNCROSSED
    feet[0, 1] = -0.25  # FL's foot right of FR's
    assert legs_crossed(robot, 0, 1, feet)
    ev = classify_trip(robot, 0, 1.0, feet, other_leg=1)
    assert (ev.kind, ev.other_leg) == (TripKind.SELF_CROSSED, 1)
    assert classify_trip(robot, 0, 1.0, feet) is None


def test_trip_event_drives_the_response_through_the_planner(planner, robot, standing_body):
    ev = classify_trip(robot, 0, 0.1, robot.nominal_foot_body, foot_hit=True)
    plan = planner.plan(0.1, [_req(ev)], flat_ground, STANCE, standing_body(0.1))[0]
    assert plan.policy_names == ("Trip:StopForward", "Elevate")


def test_joint_command_tracks_the_plan(planner, robot, standing_body):
    req = SwingRequest(0, np.array([0.30, 0.165, 0.0]), np.zeros(3), np.array([0.45, 0.165, 0.0]), 0.3)
    body = standing_body()
    plan = planner.plan(0.0, [req], flat_ground, STANCE, body)[0]
    assert plan.tier == Tier.SUCCESS
    R, p_b = body.R_world_body, body.p_world_body
    for t in (0.05, 0.15, 0.25):
        q = robot.q_nominal[0]
        q_des, qd_des, tau_ff = swing_joint_command(robot, 0, q, np.zeros(3), plan, t, R, p_b, np.zeros(3))
        p, v, a = plan.sample(t)
        np.testing.assert_allclose(
            robot.fk_leg(0, q_des), R.T @ (p + (0, 0, robot.foot_radius_m) - p_b), atol=1e-9
        )
        np.testing.assert_allclose(robot.jacobian_leg(0, q_des) @ qd_des, R.T @ v, atol=1e-4)
        f = P.foot_effective_mass_kg * (a + (0, 0, 9.81))
        np.testing.assert_allclose(tau_ff, robot.jacobian_leg(0, q).T @ f, atol=1e-9)


def test_joint_command_out_of_reach_steps_toward_it(planner, robot, standing_body):
    req = SwingRequest(0, np.array([0.30, 0.165, 0.0]), np.zeros(3), np.array([1.5, 0.165, 0.0]), 0.3)
    plan = planner.plan(0.0, [req], flat_ground, STANCE, standing_body())[0]
    q = robot.q_nominal[0]
    q_des, _, _ = swing_joint_command(
        robot, 0, q, np.zeros(3), plan, 0.3, np.eye(3), np.array([0, 0, 0.52]), np.zeros(3)
    )
    assert np.all(q_des >= robot.q_min[0] - 1e-12) and np.all(q_des <= robot.q_max[0] + 1e-12)
    assert robot.fk_leg(0, q_des)[0] > robot.fk_leg(0, q)[0]  # moved toward the far target
