"""Swing selection: invariants over random states, the tier order, the seed's FIG. 8 cases, crossing legs."""

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from planning.swing import Box, BoxGround, SwingParams, SwingPlanner, SwingRequest, Tier, flat_ground
from planning.swing.policies import HORIZONTAL_POLICIES, after_hold

P = SwingParams()


def _heading(vec, yaw):
    c, s = math.cos(yaw), math.sin(yaw)
    return np.column_stack((c * vec[:, 0] + s * vec[:, 1], -s * vec[:, 0] + c * vec[:, 1], vec[:, 2]))


def _check_limits(plan, req, yaw):
    ts = np.linspace(plan.t_start, plan.t_touchdown + 0.3, 1500)
    v = _heading(plan.derivatives(ts, 1), yaw)
    a = _heading(plan.derivatives(ts, 2), yaw)
    v0 = _heading(req.v_world_foot[None, :], yaw)[0]
    v_xy = max(P.v_max_xy_mps, abs(v0[0]), abs(v0[1])) + 1e-6
    assert np.abs(v[:, :2]).max() <= v_xy
    assert np.abs(a[:, :2]).max() <= P.a_max_xy_mps2 + 1e-6
    assert v[:, 2].max() <= max(P.v_max_up_mps, v0[2]) + 1e-6
    assert v[:, 2].min() >= -max(P.v_max_down_mps, P.v_max_up_mps, -v0[2]) - 1e-6
    assert np.abs(a[:, 2]).max() <= P.a_max_z_mps2 + 1e-6


leg_st = st.integers(0, 3)
off = st.floats(-0.15, 0.15)
vxy = st.floats(-1.5, 1.5)


@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(
    leg=leg_st,
    dx0=off,
    dy0=off,
    z0=st.floats(0.0, 0.12),
    vx=vxy,
    vy=vxy,
    vz=st.floats(-0.5, 1.0),
    dx1=st.floats(-0.25, 0.25),
    dy1=st.floats(-0.1, 0.1),
    z1=st.floats(0.0, 0.05),
    T=st.floats(0.08, 0.6),
    yaw=st.floats(-math.pi, math.pi),
    boxed=st.booleans(),
)
def test_random_swings_keep_the_invariants(
    planner, robot, leg, dx0, dy0, z0, vx, vy, vz, dx1, dy1, z1, T, yaw, boxed, standing_body
):
    body = standing_body(yaw=yaw)
    c, s = math.cos(yaw), math.sin(yaw)
    Rz = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1.0]])
    nominal = robot.nominal_foot_body[leg] * (1, 1, 0)
    p0 = Rz @ (nominal + (dx0, dy0, z0))
    p1 = Rz @ (nominal + (dx1, dy1, z1))
    ground = (
        BoxGround([Box(p0[0] + 0.06, p0[0] + 0.1, p0[1] - 0.1, p0[1] + 0.1, 0.06)]) if boxed else flat_ground
    )
    stance = {j: robot.nominal_foot_body[j] * (1, 1, 0) @ Rz.T for j in range(4) if j != leg}
    v0 = np.array([vx, vy, vz])
    req = SwingRequest(leg, p0, v0, p1, T)
    plan = planner.plan(0.0, [req], ground, stance, body)[leg]

    # Starts at the current position and velocity.
    p, v, _ = plan.sample(0.0)
    np.testing.assert_allclose(p, p0, atol=1e-9)
    np.testing.assert_allclose(v, v0, atol=1e-9)
    # Success ends on the target, on time, at rest.
    if plan.tier == Tier.SUCCESS:
        p, v, _ = plan.sample(T)
        np.testing.assert_allclose(p, p1, atol=1e-6)
        np.testing.assert_allclose(v, 0.0, atol=1e-6)
    # Limits hold in every selectable tier.
    assert plan.tier != Tier.VIOLATES_CONSTRAINTS
    _check_limits(plan, req, yaw)
    # At most M + N evaluations.
    assert 2 <= plan.evaluations <= planner.max_evaluations
    # The tier order is respected: no policy would have landed in a better tier (on a step up over terrain that
    # must be cleared first, the candidates are the policies after the rise-first hold, as in the planner).
    prob = planner._problem(
        0.0, req, ground, planner._stance_obstacles(stance, body, 0.0, c, s), body, {}, c, s
    )
    tiers = []
    for _, fn in HORIZONTAL_POLICIES:
        hp = fn(prob.ctx if prob.hold is None else prob.hold.ctx)
        if hp is not None:
            if prob.hold is not None:
                hp = after_hold(prob.hold, hp)
            tiers.append(planner.analyzer.analyze(prob, hp, 0.0).tier)
    best = min((t for t in tiers if t != Tier.VIOLATES_CONSTRAINTS), default=Tier.DEFAULT)
    assert plan.tier == best


def _fig8(standing_body, box_x, height=0.12, T=0.35):
    ground = BoxGround([Box(box_x[0], box_x[1], -0.1, 0.1, height) for box_x in box_x])
    req = SwingRequest(0, np.zeros(3), np.zeros(3), np.array([0.4, 0.0, 0.0]), T)
    body = standing_body(x=0.2, y=-0.11)
    return req, ground, body


@pytest.mark.parametrize(
    ("boxes", "winner"),
    [
        ([(0.05, 0.10)], "WaitBangBang"),  # obstacle near the start: wait for the foot to rise
        ([(0.30, 0.35)], "BangBangWait"),  # obstacle near the end: get there first, then come down
    ],
)
def test_fig8_obstacle_picks_the_policy(robot, boxes, winner, standing_body):
    # The scene is sized for a foot whose horizontal motion takes most of the swing (3 m/s, 40 m/s²): with
    # faster limits the waiting policies have so much slack that the box's margins decide instead.
    planner = SwingPlanner(robot, SwingParams(v_max_xy_mps=3.0, a_max_xy_mps2=40.0))
    req, ground, body = _fig8(standing_body, boxes)
    plan = planner.plan(0.0, [req], ground, {}, body)[0]
    assert plan.tier == Tier.SUCCESS
    assert plan.horizontal_policy == winner
    pts = plan.positions(np.linspace(0.0, 0.35, 400))
    assert np.all(pts[:, 2] >= ground(pts[:, 0], pts[:, 1]) - 1e-9)


def test_fig8_both_obstacles_leave_no_success(planner, standing_body):
    req, ground, body = _fig8(standing_body, [(0.05, 0.10), (0.30, 0.35)])
    plan = planner.plan(0.0, [req], ground, {}, body)[0]
    assert plan.tier > Tier.SUCCESS
    assert plan.tier != Tier.VIOLATES_CONSTRAINTS


def test_flat_ground_takes_cubic_at_once_with_the_gentlest_vertical(planner, robot, standing_body):
    req = SwingRequest(0, np.array([0.3, 0.165, 0.0]), np.zeros(3), np.array([0.45, 0.165, 0.0]), 0.3)
    stance = {j: robot.nominal_foot_body[j] * (1, 1, 0) for j in (1, 2, 3)}
    plan = planner.plan(0.0, [req], flat_ground, stance, standing_body())[0]
    assert (plan.tier, plan.policy_names, plan.evaluations) == (Tier.SUCCESS, ("Cubic", "Gentle0"), 2)
    pts = plan.points(10)
    assert pts.shape == (10, 3)
    assert pts[:, 2].max() == pytest.approx(0.06, abs=0.005)


def test_too_short_a_swing_cannot_reach(planner, standing_body):
    req = SwingRequest(0, np.array([0.3, 0.165, 0.0]), np.zeros(3), np.array([0.8, 0.165, 0.0]), 0.1)
    plan = planner.plan(0.0, [req], flat_ground, {}, standing_body())[0]
    assert plan.tier == Tier.XY_CANT_REACH
    assert plan.horizontal_policy in ("BangBangWait", "BBW-x+Cubic-y", "BBW→Cubic")


def test_touchdown_too_high_for_the_time_is_z_impossible(planner, standing_body):
    req = SwingRequest(0, np.array([0.3, 0.165, 0.0]), np.zeros(3), np.array([0.33, 0.165, 0.1]), 0.07)
    plan = planner.plan(0.0, [req], flat_ground, {}, standing_body())[0]
    assert plan.tier == Tier.XY_SUCCESS_Z_IMPOSSIBLE
    assert plan.vertical_policy == "Aggressive"


def _crossing(robot, standing_body):
    # FR stands in FL's way: FL must swing from behind FR's foot to beyond it.
    stance = {
        1: np.array([0.30, 0.0, 0.0]),
        2: np.array([-0.3, 0.165, 0.0]),
        3: np.array([-0.3, -0.165, 0.0]),
    }
    req = SwingRequest(0, np.array([0.12, 0.0, 0.0]), np.zeros(3), np.array([0.50, 0.0, 0.0]), 0.45)
    return req, stance, standing_body(x=0.05)


def test_crossing_leg_goes_around_the_keepout(planner, robot, standing_body):
    req, stance, body = _crossing(robot, standing_body)
    plan = planner.plan(0.0, [req], flat_ground, stance, body)[0]
    assert plan.tier == Tier.SUCCESS
    assert plan.horizontal_policy.startswith(("SwingAround", "Wiggle"))
    pts = plan.positions(np.linspace(0.0, 0.45, 300))
    fr = np.array([0.30, 0.0])
    assert np.hypot(*(pts[:, :2] - fr).T).min() >= P.keepout_radius_m - 1e-3
    # The straight route would have hit the other leg.
    c, s = 1.0, 0.0
    prob = planner._problem(
        0.0, req, flat_ground, planner._stance_obstacles(stance, body, 0.0, c, s), body, {}, c, s
    )
    cubic = HORIZONTAL_POLICIES[0][1](prob.ctx)
    assert planner.analyzer.analyze(prob, cubic, 0.0).tier == Tier.SELF_COLLISION


def test_later_leg_avoids_the_earlier_legs_lower_leg(planner, robot, standing_body):
    # FL lands first right beside FR's straight route; FR (later) must pass its lower leg, over or around.
    fl = SwingRequest(0, np.array([0.30, 0.165, 0.0]), np.zeros(3), np.array([0.40, -0.06, 0.0]), 0.2)
    fr = SwingRequest(1, np.array([0.25, -0.10, 0.0]), np.zeros(3), np.array([0.55, -0.10, 0.0]), 0.45)
    stance = {2: np.array([-0.3, 0.165, 0.0]), 3: np.array([-0.3, -0.165, 0.0])}
    body = standing_body(x=0.05)
    plans = planner.plan(0.0, [fr, fl], flat_ground, stance, body)
    assert plans[0].policy_names == ("Cubic", "Gentle0")
    assert plans[1].tier == Tier.SUCCESS
    assert plans[1].policy_names != ("Cubic", "Gentle0")  # the plain swing would hit FL's shin
    # FL's lower leg after touchdown: foot center to knee, through the IK.
    p_b, R = body.pose_at(0.2)
    fc = np.array([0.40, -0.06, robot.foot_radius_m])
    knee = p_b + R @ robot.knee_body(0, robot.ik_leg(0, R.T @ (fc - p_b)))
    ts = np.linspace(0.2, 0.45, 300)
    pts = plans[1].positions(ts) + (0, 0, robot.foot_radius_m)
    s = np.clip((pts - fc) @ (knee - fc) / ((knee - fc) @ (knee - fc)), 0, 1)
    d = np.linalg.norm(pts - (fc + s[:, None] * (knee - fc)), axis=1)
    assert d.min() >= P.keepout_radius_m - 2e-3
    naive = planner.plan(0.0, [fr], flat_ground, stance, body)[1]
    pts = naive.positions(ts) + (0, 0, robot.foot_radius_m)
    s = np.clip((pts - fc) @ (knee - fc) / ((knee - fc) @ (knee - fc)), 0, 1)
    assert np.linalg.norm(pts - (fc + s[:, None] * (knee - fc)), axis=1).min() < P.keepout_radius_m


def test_late_touchdown_keeps_descending(planner, standing_body):
    req = SwingRequest(0, np.array([0.45, 0.165, 0.03]), np.zeros(3), np.array([0.45, 0.165, 0.0]), 0.2)
    plan = planner.plan(0.25, [req], flat_ground, {}, standing_body(0.25))[0]
    assert plan.vertical_policy == "LateTouchdown"
    _, v, _ = plan.sample(0.5)
    assert v[2] == pytest.approx(-P.late_descent_mps)
    assert plan.sample(1.0)[0][2] < 0.0  # keeps going until contact stops it


def test_replanning_every_3ms_from_the_plans_own_state_keeps_the_plan(planner, standing_body):
    req = SwingRequest(0, np.array([0.3, 0.165, 0.0]), np.zeros(3), np.array([0.45, 0.165, 0.0]), 0.3)
    first = planner.plan(0.0, [req], flat_ground, {}, standing_body())[0]
    for t in np.arange(0.003, 0.29, 0.003):
        p, v, _ = first.sample(t)
        again = planner.plan(
            t, [SwingRequest(0, p, v, req.p_touchdown, 0.3)], flat_ground, {}, standing_body(t)
        )[0]
        assert again.policy_names == first.policy_names
        ts = np.linspace(t, 0.3, 20)
        np.testing.assert_allclose(again.positions(ts), first.positions(ts), atol=1e-7)


def test_bad_requests_name_the_field():
    with pytest.raises(ValueError, match="p_touchdown"):
        SwingRequest(0, np.zeros(3), np.zeros(3), np.zeros(2), 0.3)
    with pytest.raises(ValueError, match="leg"):
        SwingRequest(7, np.zeros(3), np.zeros(3), np.zeros(3), 0.3)
    with pytest.raises(ValueError, match="v_max_xy_mps"):
        SwingParams(v_max_xy_mps=0.0)


def test_duplicate_legs_are_rejected(robot):
    req = SwingRequest(0, np.zeros(3), np.zeros(3), np.zeros(3), 0.3)
    with pytest.raises(ValueError, match="twice"):
        SwingPlanner(robot).plan(0.0, [req, req])


def _beside(robot, standing_body):
    stance = {
        1: np.array([0.3, -0.165, 0.0]),
        2: np.array([-0.3, 0.165, 0.0]),
        3: np.array([-0.3, -0.165, 0.0]),
    }
    req = SwingRequest(0, np.array([0.2, 0.165, 0.0]), np.zeros(3), np.array([0.5, 0.165, 0.0]), 0.35)
    return req, stance, standing_body(x=0.05)


def test_a_wall_alongside_is_cliff_scraping(planner, robot, standing_body):
    req, stance, body = _beside(robot, standing_body)
    wall = BoxGround([Box(0.0, 0.8, 0.185, 0.4, 0.5)])  # 2 cm beside the foot's path, taller than the swing
    plan = planner.plan(0.0, [req], wall, stance, body)[0]
    assert plan.tier == Tier.CLIFF_SCRAPING


def test_terrain_under_the_knee_is_a_knee_terrain_collision(planner, robot, standing_body):
    req, stance, body = _beside(robot, standing_body)
    ledge = BoxGround([Box(0.05, 0.15, 0.0, 0.4, 0.35)])  # behind the foot, where the knee is
    plan = planner.plan(0.0, [req], ledge, stance, body)[0]
    assert plan.tier == Tier.KNEE_TERRAIN_COLLISION


def test_tier_colors_cover_every_tier():
    from planning.swing import TIER_RGB

    assert set(TIER_RGB) == set(Tier)


def test_earlier_leg_is_replanned_when_the_later_one_cannot_avoid_it(planner, standing_body):
    # FL steps in place (touchdown later); FR lands first and its straight route runs through FL's foot, and
    # FR's slanted shin hangs over FL's spot: FL cannot dodge, so FR is replanned around FL.
    fr = SwingRequest(1, np.array([0.10, 0.0, 0.0]), np.zeros(3), np.array([0.5, 0.0, 0.0]), 0.25)
    fl = SwingRequest(0, np.array([0.30, 0.0, 0.0]), np.zeros(3), np.array([0.30, 0.0, 0.0]), 0.5)
    stance = {2: np.array([-0.3, 0.165, 0.0]), 3: np.array([-0.3, -0.165, 0.0])}
    body = standing_body(x=0.1)
    alone = planner.plan(0.0, [fr], flat_ground, stance, body)[1]
    assert alone.horizontal_policy == "Cubic"
    planner.reset()
    plans = planner.plan(0.0, [fr, fl], flat_ground, stance, body)
    assert plans[1].horizontal_policy.startswith(("SwingAround", "Wiggle"))
    assert plans[0].tier == plans[1].tier == Tier.SUCCESS


def test_close_to_touchdown_the_last_plan_is_kept(planner, standing_body):
    req = SwingRequest(0, np.array([0.3, 0.165, 0.0]), np.zeros(3), np.array([0.45, 0.165, 0.0]), 0.3)
    first = planner.plan(0.29, [req], flat_ground, {}, standing_body(0.29))[0]
    p, v, _ = first.sample(0.295)
    noisy = SwingRequest(0, p + 0.003, v, req.p_touchdown, 0.3)
    assert planner.plan(0.295, [noisy], flat_ground, {}, standing_body(0.295))[0] is first
