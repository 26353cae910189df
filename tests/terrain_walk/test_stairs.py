"""Stairs: the planning rules added for them, and the closed-loop crossing on the scene's ground-truth maps.

Rules: the riser keep-out in front of footholds, the riser pitch that paces the climb gait, the flight detection
that switches the stairs mode on (and not on a box), the rise-first swing (the foot's x and y wait until it clears
a riser ahead), liftoffs that wait rather than leave one foot down.
"""

from __future__ import annotations

import numpy as np

from planning.handler import Handler, Phase
from planning.robot import load_robot
from planning.sim.world import RobotState
from planning.swing import SwingPlanner, SwingRequest
from planning.swing.params import SwingParams
from planning.swing.policies import RISE_FIRST
from planning.swing.types import BodyMotion

RES = 0.03


def _riser_ground(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    return np.where(np.asarray(x) >= 1.0, 0.15, 0.0) + 0.0 * np.asarray(y)


def test_rise_first_swing_clears_the_riser_before_moving_over_it() -> None:
    robot = load_robot("spot")
    planner = SwingPlanner(robot)
    req = SwingRequest(
        0, np.array([0.874, 0.166, 0.0]), np.zeros(3), np.array([1.09, 0.166, 0.15]), 0.3, None
    )
    body = BodyMotion(0.0, np.array([0.6, 0.0, 0.6]), np.eye(3), np.array([0.3, 0.0, 0.0]), 0.0)
    stance = {
        1: np.array([0.6, -0.165, 0.0]),
        2: np.array([0.0, 0.165, 0.0]),
        3: np.array([0.0, -0.165, 0.0]),
    }
    plan = planner.plan(0.0, [req], _riser_ground, stance, body)[0]
    assert plan.horizontal_policy.endswith(RISE_FIRST)
    ts = np.linspace(0.0, 0.3, 121)
    pts = plan.positions(ts)
    r = robot.foot_radius_m
    # wherever the foot's front is over the riser, its bottom is above the tread
    over = pts[:, 0] + r >= 1.0
    assert np.all(pts[over, 2] >= 0.15), pts[over, 2].min()
    # it still lands on the tread on time
    assert np.allclose(plan.positions(np.array([0.3]))[0], req.p_touchdown, atol=0.01)
    # on flat ground (or with the rule off) the swing does not hold
    off = SwingPlanner(robot, SwingParams(rise_first_above_m=np.inf))
    plan_off = off.plan(0.0, [req], _riser_ground, stance, body)[0]
    assert not plan_off.horizontal_policy.endswith(RISE_FIRST)


class _Swing:
    def __init__(self, leg: int, t_lo: float, t_td: float, p: np.ndarray) -> None:
        self.leg, self.t_liftoff, self.t_touchdown, self.p_touchdown = leg, t_lo, t_td, p


class _Plan:
    def __init__(self, swings: dict[int, _Swing]) -> None:
        self.swings = swings

    def swing_at(self, leg: int, t: float) -> _Swing | None:
        sw = self.swings.get(leg)
        return sw if sw is not None and sw.t_liftoff <= t < sw.t_touchdown else None


def test_liftoffs_wait_rather_than_leave_one_foot_down() -> None:
    robot = load_robot("spot")
    h = Handler(robot)
    s = RobotState()
    s.t = 1.0
    s.p_world_foot = np.array(
        [[0.3, 0.165, 0.035], [0.3, -0.165, 0.035], [-0.3, 0.165, 0.035], [-0.3, -0.165, 0.1]]
    )
    s.contact = np.array([True, True, True, False])
    h._initialized = True
    h.phase[:] = Phase.STANCE
    h.phase[3] = Phase.SWING  # RR still in the air (its touchdown moved later)
    h.t_touchdown[3] = 1.05
    h.t_liftoff[3] = 0.8
    h.t_landed[:] = 0.0
    plan = _Plan({1: _Swing(1, 0.99, 1.3, np.zeros(3)), 2: _Swing(2, 0.99, 1.3, np.zeros(3))})
    h.update_phases(s, plan)
    # FR and RL are due, but lifting both would leave FL alone: they wait
    assert h.phase[1] == Phase.STANCE and h.phase[2] == Phase.STANCE
    s.t = 1.0 + h.params.max_liftoff_delay_s + 0.01  # ... at most max_liftoff_delay_s
    h.update_phases(s, plan)
    assert h.phase[1] == Phase.SWING and h.phase[2] == Phase.SWING


def _first_plan(planner: SwingPlanner, req: SwingRequest, t: float = 0.0):
    body = BodyMotion(t, np.array([0.6, 0.0, 0.6]), np.eye(3), np.array([0.3, 0.0, 0.0]), 0.0)
    stance = {
        1: np.array([0.6, -0.165, 0.0]),
        2: np.array([0.0, 0.165, 0.0]),
        3: np.array([0.0, -0.165, 0.0]),
    }
    return planner.plan(t, [req], _riser_ground, stance, body)[0]


def test_an_anchored_rise_first_wait_brings_a_carried_foot_back() -> None:
    """The stairs mode's rise-first wait is fixed from the lift-off place: a foot the leg carried toward the riser
    after lift-off is brought back to it, not left to wait where it drifted (the riser is at x = 1.0)."""
    robot = load_robot("spot")
    lift = np.array([0.80, 0.166, 0.0])
    target = np.array([1.09, 0.166, 0.15])
    for anchored in (False, True):
        planner = SwingPlanner(robot, SwingParams(rise_first_gap_m=0.12, rise_first_anchored=anchored))
        _first_plan(planner, SwingRequest(0, lift, np.zeros(3), target, 0.3, None))
        # 20 ms later the measured foot has been carried 10 cm forward, still low, still moving
        drifted = np.array([0.90, 0.166, 0.01])
        plan = _first_plan(
            planner, SwingRequest(0, drifted, np.array([1.0, 0.0, 0.2]), target, 0.3, None), 0.02
        )
        assert plan.horizontal_policy.endswith(RISE_FIRST)
        ts = np.linspace(0.02, 0.3, 281)
        pts = plan.positions(ts)
        # where the foot is when it has risen to the tread's height (it waits there, then moves over the riser)
        x_up = float(pts[np.argmax(pts[:, 2] >= 0.15), 0])
        wait = 1.0 - robot.foot_radius_m - 0.12  # the riser less the foot's radius and the gap
        if anchored:
            assert x_up <= wait + 0.01, x_up  # brought back to the wait point of the lift-off place's route
        else:
            assert x_up > wait + 0.04, x_up  # re-derived from the drifted foot: it waits where it drifted


def test_a_rise_first_wait_within_reach_waits_for_the_height_the_leg_reaches() -> None:
    """A hip too low to lift the foot rise_first_margin_m over the riser: without the option the swing does not
    wait (and moves into the riser); with it, it waits until the foot is as high as the leg reaches and that
    still clears the riser."""
    robot = load_robot("spot")
    req = SwingRequest(
        0, np.array([0.874, 0.166, 0.0]), np.zeros(3), np.array([1.09, 0.166, 0.15]), 0.3, None
    )
    # a margin the leg cannot give (hip 0.6 m up: the foot reaches 0.6 - min leg length - hip clearance)
    reach = 0.6 - robot.min_leg_length_m - SwingParams().hip_clearance_m
    margin = reach - 0.15 + 0.03
    plain = _first_plan(SwingPlanner(robot, SwingParams(rise_first_margin_m=margin)), req)
    assert not plain.horizontal_policy.endswith(RISE_FIRST)
    within = _first_plan(
        SwingPlanner(robot, SwingParams(rise_first_margin_m=margin, rise_first_within_reach=True)), req
    )
    assert within.horizontal_policy.endswith(RISE_FIRST)
    pts = within.positions(np.linspace(0.0, 0.3, 121))
    over = pts[:, 0] + robot.foot_radius_m >= 1.0
    assert np.all(pts[over, 2] >= 0.15), pts[over, 2].min()
