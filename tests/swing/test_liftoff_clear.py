"""The lift-off clearance (SwingParams.liftoff_clear_run_m): a foot lifting off beside a box rises before it moves."""

import dataclasses

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from planning.swing import Box, BoxGround, SwingParams, SwingPlanner, SwingRequest, flat_ground
from planning.swing.planner import liftoff_clear_height

ON = dataclasses.replace(SwingParams(), liftoff_clear_run_m=0.10, liftoff_clear_margin_m=0.03)
U = np.linspace(0.0, 1.0, 24)
STANCE = {1: np.array([0.3, -0.165, 0.0]), 2: np.array([-0.3, 0.165, 0.0]), 3: np.array([-0.3, -0.165, 0.0])}


def _route(box_from_m: float, box_to_m: float, h: float, length: float = 0.4) -> np.ndarray:
    d = U * length
    return np.where((d >= box_from_m) & (d <= box_to_m), h, 0.0)


@settings(max_examples=60, deadline=None)
@given(start=st.floats(0.0, 0.09), h=st.floats(0.04, 0.12), travelled=st.floats(0.0, 0.005))
def test_a_box_at_the_routes_start_asks_a_rise_over_the_highest_ground(start, h, travelled):
    g = _route(start, start + 0.1, h)
    if not np.any(g[U * 0.4 <= 0.10 - travelled] > 0.0):
        return  # the box falls between two samples of the first run
    assert liftoff_clear_height(g, U, 0.4, travelled, 0.0, ON) == pytest.approx(h + 0.03)


@given(start=st.floats(0.12, 0.3), h=st.floats(0.0, 0.3))
def test_ground_beyond_the_first_run_is_the_tiers_business(start, h):
    assert liftoff_clear_height(_route(start, start + 0.05, h), U, 0.4, 0.0, 0.0, ON) is None


def test_low_ground_a_foot_already_moved_on_and_the_rule_off_ask_nothing():
    g = _route(0.0, 0.1, 0.08)
    low = _route(0.0, 0.1, 0.02)
    assert liftoff_clear_height(low, U, 0.4, 0.0, 0.0, ON) is None  # under rise_first_above_m
    assert liftoff_clear_height(g, U, 0.4, 0.11, 0.0, ON) is None  # past the first run
    assert liftoff_clear_height(g, U, 0.4, 0.0, 0.0, SwingParams()) is None  # off by default
    assert liftoff_clear_height(g, U, 0.4, 0.0, 0.06, ON) is None  # standing near the box's height


def _xy_before(plan, z: float) -> float:
    """How far (m) the plan's foot moves in x and y before it first reaches height z."""
    ts = np.linspace(plan.t_start, plan.t_touchdown, 400)
    p = plan.positions(ts)
    k = int(np.argmax(p[:, 2] >= z)) if np.any(p[:, 2] >= z) else len(ts) - 1
    return float(np.linalg.norm(p[k, :2] - p[0, :2]))


def test_a_foot_beside_a_box_rises_before_it_moves_and_the_flat_swing_is_unchanged(robot, standing_body):
    """A front foot on the floor 2 cm beside a 9 cm box that runs along its route (the swing ground dilated by the
    foot): with the rule the foot reaches the box's top before it has moved 1 cm; without it, it moves several
    centimetres first (2.7 cm). On flat ground both plans are the same."""
    rf = robot.foot_radius_m
    p0 = np.array([0.30, 0.165, 0.0])
    # the box (dilated by the foot, as the swing ground is) reaches under the foot
    box = BoxGround([Box(0.25, 0.45, 0.165 - 0.10, 0.165 - 0.02 + rf, 0.09)])
    req = SwingRequest(0, p0, np.zeros(3), np.array([0.62, 0.165, 0.0]), 0.35)
    on, off = SwingPlanner(robot, ON), SwingPlanner(robot, SwingParams())
    plan_on = on.plan(0.0, [req], box, STANCE, standing_body(0.0))[0]
    plan_off = off.plan(0.0, [req], box, STANCE, standing_body(0.0))[0]
    assert _xy_before(plan_on, 0.09) < 0.01
    assert _xy_before(plan_off, 0.09) > 0.02
    assert np.linalg.norm(plan_on.sample(0.35)[0][:2] - req.p_touchdown[:2]) < 0.01  # and still lands on time
    flat_on = SwingPlanner(robot, ON).plan(0.0, [req], flat_ground, STANCE, standing_body(0.0))[0]
    flat_off = SwingPlanner(robot, SwingParams()).plan(0.0, [req], flat_ground, STANCE, standing_body(0.0))[0]
    ts = np.linspace(0.0, 0.35, 50)
    assert np.allclose(flat_on.positions(ts), flat_off.positions(ts))


def test_a_foot_whose_box_reads_higher_each_tick_still_moves_on(robot, standing_body):
    """The same foot, replanned every 10 ms from its plan, the box read 0.2 mm higher each tick (the sensor's map
    of its top moving): the foot rises to the box's top + the margin, then moves on (a foot within
    rise_first_done_m of that height has risen). Without the tolerance it stayed where it was for most of its swing,
    its clearance height always a hair above it, as in clutter draw 899, then cut the box's edge as it hurried on."""
    rf = robot.foot_radius_m
    params = dataclasses.replace(ON, rise_first_within_reach=True, rise_first_anchored=True)
    p0, target = np.array([0.30, 0.165, 0.0]), np.array([0.62, 0.165, 0.0])
    x_at = {}
    for done in (params.rise_first_done_m, 0.0):
        planner = SwingPlanner(robot, dataclasses.replace(params, rise_first_done_m=done))
        h = 0.09
        box = BoxGround([Box(0.25, 0.45, 0.165 - 0.10, 0.165 - 0.02 + rf, h)])
        plan = planner.plan(
            0.0, [SwingRequest(0, p0, np.zeros(3), target, 0.35)], box, STANCE, standing_body(0.0)
        )[0]
        for k in range(1, 21):
            t = 0.01 * k
            h += 0.0002
            box = BoxGround([Box(0.25, 0.45, 0.165 - 0.10, 0.165 - 0.02 + rf, h)])
            p, v, _ = plan.sample(t)
            plan = planner.plan(t, [SwingRequest(0, p, v, target, 0.35)], box, STANCE, standing_body(t))[0]
        x_at[done] = float(plan.sample(0.2)[0][0]) - p0[0]
    assert params.rise_first_done_m > 0.0
    assert x_at[params.rise_first_done_m] > 0.08, x_at  # on its way at 0.2 s (a third of the way and more)
    assert x_at[0.0] < 0.02, x_at  # still waiting
