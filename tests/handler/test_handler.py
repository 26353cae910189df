"""The handler: the measured state wins over the plan (late and early touchdowns), trips get the table's answer."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from planning.handler import Handler, HandlerParams, Phase, stepping_down, too_few_supports
from planning.robot import load_robot
from planning.sim.world import RobotState
from planning.swing import TripKind

ROBOT = load_robot("spot")


@dataclass(frozen=True)
class _Swing:
    leg: int
    t_liftoff: float
    t_touchdown: float
    p_touchdown: np.ndarray


class _Plan:
    """FL swings from 0.1 s to 0.4 s, landing 5 cm ahead; everything else stands."""

    def swing_at(self, leg: int, t: float) -> _Swing | None:
        if leg == 0 and 0.1 <= t < 0.4:
            return _Swing(0, 0.1, 0.4, np.array([0.35, 0.165, 0.0]))
        return None


def _state(t: float, contact: tuple[bool, bool, bool, bool], knee: bool = False) -> RobotState:
    s = RobotState()
    s.t = t
    s.p_world_body[:] = (0.0, 0.0, ROBOT.standing_height_m)
    s.q[:] = ROBOT.q_nominal
    for i in range(4):
        s.p_world_foot[i] = ROBOT.fk_leg(i, ROBOT.q_nominal[i]) + s.p_world_body
        s.J_world_foot[i] = ROBOT.jacobian_leg(i, ROBOT.q_nominal[i])
    s.contact[:] = contact
    s.knee_contact[0] = knee
    return s


def test_swing_lift_late_touchdown_and_landing() -> None:
    h = Handler(ROBOT)
    plan = _Plan()
    h.update_phases(_state(0.0, (True,) * 4), plan)
    assert h.phase[0] == Phase.STANCE
    h.update_phases(_state(0.15, (False, True, True, True)), plan)
    assert h.phase[0] == Phase.SWING and not h.stance[0]
    h.update_phases(_state(0.41, (False, True, True, True)), plan)
    assert h.phase[0] == Phase.LATE and not h.stance[0]  # planned down, not down: no force on it
    h.plan_swings(_state(0.41, (False, True, True, True)))
    assert h.plans[0].vertical_policy == "LateTouchdown"
    h.update_phases(_state(0.45, (True,) * 4), plan)
    assert h.phase[0] == Phase.STANCE and h.stance[0]


def test_early_touchdown_is_taken_late_in_the_swing_only() -> None:
    h = Handler(ROBOT)
    plan = _Plan()
    h.update_phases(_state(0.12, (False, True, True, True)), plan)
    h.update_phases(_state(0.35, (True, True, True, True)), plan)
    assert h.phase[0] == Phase.STANCE  # 83 % through the swing: an early touchdown


def test_a_foot_hit_early_in_the_swing_is_a_normal_trip_and_the_foot_is_lifted() -> None:
    h = Handler(ROBOT)
    plan = _Plan()
    h.update_phases(_state(0.12, (False, True, True, True)), plan)
    h.plan_swings(_state(0.12, (False, True, True, True)))
    normal_top = float(np.max(h.plans[0].positions(np.linspace(0.12, 0.38, 30))[:, 2]))
    hit = _state(0.2, (True, True, True, True))
    h.update_phases(hit, plan)
    assert h.phase[0] == Phase.SWING  # 33 % through: not a touchdown but a trip
    assert h.trip_log and h.trip_log[-1][0] == 0 and h.trip_log[-1][1].kind == TripKind.NORMAL
    h.plan_swings(hit)
    tripped_top = float(np.max(h.plans[0].positions(np.linspace(0.2, 0.38, 30))[:, 2]))
    assert h.plans[0].trip == TripKind.NORMAL
    assert tripped_top > normal_top  # the table's answer to a normal trip: elevate


def test_a_knee_contact_is_a_knee_trip() -> None:
    h = Handler(ROBOT)
    plan = _Plan()
    h.update_phases(_state(0.12, (False, True, True, True)), plan)
    h.update_phases(_state(0.2, (False, True, True, True), knee=True), plan)
    assert h.trip_log[-1][1].kind == TripKind.KNEE


class _WalkPlan:
    """A walk's instant: FL swings 0.1–0.4 s and FR's swing is due at 0.38 s, just before FL is due down."""

    def swing_at(self, leg: int, t: float) -> _Swing | None:
        if leg == 0 and 0.1 <= t < 0.4:
            return _Swing(0, 0.1, 0.4, np.array([0.35, 0.165, 0.0]))
        if leg == 1 and 0.38 <= t < 0.68:
            return _Swing(1, 0.38, 0.68, np.array([0.35, -0.165, 0.0]))
        return None


def test_a_liftoff_due_just_before_a_touchdown_waits_for_that_foot_to_land() -> None:
    h = Handler(ROBOT)
    plan = _WalkPlan()
    h.update_phases(_state(0.0, (True,) * 4), plan)
    h.update_phases(_state(0.12, (False, True, True, True)), plan)
    assert h.phase[0] == Phase.SWING
    # FL, still high over a box, is due down in 20 ms: FR waits rather than leave the right side unsupported
    h.update_phases(_state(0.38, (False, True, True, True)), plan)
    assert h.phase[1] == Phase.STANCE and h.waiting
    h.update_phases(_state(0.45, (False, True, True, True)), plan)
    assert h.phase[0] == Phase.LATE and h.phase[1] == Phase.STANCE
    h.update_phases(_state(0.47, (True, True, True, True)), plan)  # FL lands: FR may go
    assert h.phase[0] == Phase.STANCE
    h.update_phases(_state(0.48, (True, True, True, True)), plan)
    assert h.phase[1] == Phase.SWING
    # ... and never longer than max_liftoff_delay_s
    h2 = Handler(ROBOT)
    h2.update_phases(_state(0.0, (True,) * 4), plan)
    h2.update_phases(_state(0.12, (False, True, True, True)), plan)
    h2.update_phases(_state(0.38, (False, True, True, True)), plan)
    h2.update_phases(_state(0.38 + h2.params.max_liftoff_delay_s + 0.01, (False, True, True, True)), plan)
    assert h2.phase[1] == Phase.SWING


def _replanned_height(h: Handler, off_m: float) -> tuple[float, float]:
    """FL swings; 20 ms into it the measured foot is off_m above its plan. Returns (the plan's height then, the
    height the replanned swing starts from)."""
    plan = _Plan()
    h.update_phases(_state(0.0, (True,) * 4), plan)
    s = _state(0.15, (False, True, True, True))
    h.update_phases(s, plan)
    h.plan_swings(s)
    z_plan = float(h.plans[0].sample(0.17)[0][2])
    s = _state(0.17, (False, True, True, True))
    s.p_world_foot[0, 2] = z_plan + ROBOT.foot_radius_m + off_m
    h.update_phases(s, plan)
    h.plan_swings(s)
    return z_plan, float(h.plans[0].sample(0.17)[0][2])


def test_a_swing_near_its_plan_is_replanned_from_the_plans_height_when_asked() -> None:
    """With replan_height_from_plan_m (the stairs mode's rule) a foot 2 cm over its plan is replanned from the
    plan's height, so the joint feedback keeps pulling it onto one trajectory; 5 cm off (blocked, pushed) it is
    replanned from where it is; and by default every swing starts from the measured foot."""
    z_plan, z_new = _replanned_height(
        Handler(ROBOT, params=HandlerParams(replan_height_from_plan_m=0.03)), 0.02
    )
    assert abs(z_new - z_plan) < 1e-6
    z_plan, z_new = _replanned_height(
        Handler(ROBOT, params=HandlerParams(replan_height_from_plan_m=0.03)), 0.05
    )
    assert abs(z_new - (z_plan + 0.05)) < 1e-6
    z_plan, z_new = _replanned_height(Handler(ROBOT), 0.02)
    assert abs(z_new - (z_plan + 0.02)) < 1e-6


def test_the_swing_legs_track_with_the_swing_planners_own_parameters() -> None:
    """The swing feed-forward uses the planner's SwingParams (foot_effective_mass_kg), not the defaults."""
    from planning.swing import SwingParams, SwingPlanner

    def swing_torque(params: SwingParams) -> np.ndarray:
        h = Handler(ROBOT, swing_planner=SwingPlanner(ROBOT, params))
        plan = _Plan()
        h.update_phases(_state(0.0, (True,) * 4), plan)
        s = _state(0.2, (False, True, True, True))
        h.update_phases(s, plan)
        h.plan_swings(s)
        return h.torques(s, np.zeros((4, 3)))[0].copy()

    light = swing_torque(SwingParams(foot_effective_mass_kg=0.5))
    heavy = swing_torque(SwingParams(foot_effective_mass_kg=3.0))
    # gravity alone on 2.5 kg more at the foot: ~25 N through the leg's Jacobian
    assert np.max(np.abs(heavy - light)) > 0.5
    same = swing_torque(SwingParams(foot_effective_mass_kg=0.5))
    np.testing.assert_allclose(same, light, atol=1e-9)


def test_too_few_supports_counts_the_feet_in_stance_and_in_contact_that_stay_down() -> None:
    stance = np.array([True, True, True, True])
    lifting = np.array([True, False, False, True])  # a diagonal pair lifts
    assert not too_few_supports(stance, np.array([True] * 4), lifting, 2)
    # the other diagonal in stance but one of its feet measured off the ground: one foot would carry the body
    assert too_few_supports(stance, np.array([True, False, True, True]), lifting, 2)
    # a late foot (not in stance) does not carry, even when its contact flickers on
    late = np.array([True, False, True, True])
    assert too_few_supports(late, np.array([True] * 4), lifting, 2)
    # nothing lifting, or a lower minimum
    assert not too_few_supports(late, np.array([True] * 4), np.zeros(4, dtype=bool), 2)
    assert not too_few_supports(late, np.array([True] * 4), lifting, 1)


class _PairPlan:
    """A trot down a step: FL+RR swing 0.1-0.4 s, FR+RL 0.4-0.7 s, each foot landing dz_m below where it stood."""

    def __init__(self, dz_m: float = -0.15) -> None:
        self.dz_m = dz_m

    def swing_at(self, leg: int, t: float) -> _Swing | None:
        y = 0.165 if leg in (0, 2) else -0.165
        x = 0.35 if leg < 2 else -0.25
        if leg in (0, 3) and 0.1 <= t < 0.4:
            return _Swing(leg, 0.1, 0.4, np.array([x, y, self.dz_m]))
        if leg in (1, 2) and 0.4 <= t < 0.7:
            return _Swing(leg, 0.4, 0.7, np.array([x, y, self.dz_m]))
        return None


def _pair_walk(params: HandlerParams, fl_lands_s: float, dz_m: float = -0.15) -> list[tuple[float, bool]]:
    """FL lands late (at fl_lands_s); RR lands on time. Returns (t, FR swinging) at each 10 ms tick from 0.4 s."""
    h = Handler(ROBOT, params=params)
    plan = _PairPlan(dz_m)
    h.update_phases(_state(0.0, (True,) * 4), plan)
    h.update_phases(_state(0.12, (False, True, True, False)), plan)
    assert h.phase[0] == Phase.SWING and h.phase[3] == Phase.SWING
    h.update_phases(_state(0.39, (False, True, True, True)), plan)  # RR lands
    out = []
    for k in range(40, 70):
        t = k / 100.0
        h.update_phases(_state(t, (t >= fl_lands_s, True, True, True)), plan)
        out.append((t, bool(h.phase[1] == Phase.SWING)))
    return out


def test_a_pair_liftoff_waits_for_a_late_foot_up_to_support_wait_s() -> None:
    # off: the pair lifts once max_liftoff_delay_s has passed, leaving RR alone with FL still in the air
    off = _pair_walk(HandlerParams(support_wait_s=None), fl_lands_s=0.6)
    lift_off = next(t for t, sw in off if sw)
    assert lift_off <= 0.4 + HandlerParams().max_liftoff_delay_s + 0.015
    # on: it waits for FL to land (0.6 s), then lifts
    on = _pair_walk(HandlerParams(support_wait_s=0.25), fl_lands_s=0.6)
    lift_on = next(t for t, sw in on if sw)
    assert 0.6 <= lift_on <= 0.62
    # ... but never longer than support_wait_s
    never = _pair_walk(HandlerParams(support_wait_s=0.25), fl_lands_s=1.0)
    assert next(t for t, sw in never if sw) <= 0.4 + 0.25 + 0.015
    # ... and on level ground or a climb the wait stays max_liftoff_delay_s (a longer one squeezes the swing)
    for dz in (0.0, 0.15):
        flat = _pair_walk(HandlerParams(support_wait_s=0.25), fl_lands_s=0.6, dz_m=dz)
        assert next(t for t, sw in flat if sw) <= 0.4 + HandlerParams().max_liftoff_delay_s + 0.015


def test_stepping_down_is_a_descent_of_the_moving_legs_only() -> None:
    z_from = np.array([0.3, 0.3, 0.5, 0.5])
    moving = np.array([True, False, False, True])
    assert stepping_down(z_from, np.array([0.1, 0.3, 0.5, 0.3]), moving, 0.05)  # both step down a riser
    assert stepping_down(z_from, np.array([0.1, 9.0, 9.0, 0.5]), moving, 0.05)  # one down, one level
    assert not stepping_down(z_from, np.array([0.28, 0.0, 0.0, 0.48]), moving, 0.05)  # level (2 cm)
    assert not stepping_down(z_from, np.array([0.1, 0.3, 0.5, 0.7]), moving, 0.05)  # one climbs
    assert not stepping_down(z_from, z_from - 0.2, np.zeros(4, dtype=bool), 0.05)  # nothing moves


def test_a_liftoff_waits_while_a_stance_foot_that_would_stay_has_lost_its_contact() -> None:
    plan = _PairPlan(-0.15)
    for wait, expect_waiting in ((0.25, True), (None, False)):
        h = Handler(ROBOT, params=HandlerParams(support_wait_s=wait))
        h.update_phases(_state(0.0, (True,) * 4), plan)
        # FL+RR due; FR in stance but off the ground: RL alone would carry the body
        h.update_phases(_state(0.12, (True, False, True, True)), plan)
        assert (h.phase[0] == Phase.STANCE) == expect_waiting
        h.update_phases(_state(0.14, (True, True, True, True)), plan)  # FR's contact back: the pair lifts
        assert h.phase[0] == Phase.SWING and h.phase[3] == Phase.SWING


def test_a_crawl_liftoff_waits_for_the_centre_of_mass_inside_the_other_three_feet() -> None:
    """The crawl's liftoff hold (SupportShiftParams.hold, off by default; for gaits of the crawl's duty): FL's liftoff, due at 0.1 s,
    waits while the centre of mass lies outside the triangle of FR, RL and RR (here on FL's side of the FR-RL
    diagonal), lifts as soon as it is inside, and never waits longer than max_hold_s."""
    from planning.steps import GAITS
    from planning.steps.support import SupportShiftParams

    sp = SupportShiftParams(hold=True)
    assert GAITS["crawl"].duty >= sp.min_duty > GAITS["walk"].duty > GAITS["trot"].duty

    def state(t: float, com_xy: tuple[float, float]) -> RobotState:
        s = _state(t, (True,) * 4)
        s.p_world_com[:2] = com_xy
        s.loaded[:] = True
        return s

    front_left = tuple(0.5 * ROBOT.fk_leg(0, ROBOT.q_nominal[0])[:2])  # halfway to FL's foot: outside
    plan = _Plan()
    h = Handler(ROBOT)
    h.support_hold = sp
    h.update_phases(state(0.0, front_left), plan)
    h.update_phases(state(0.1, front_left), plan)
    assert (
        h.phase[0] == Phase.STANCE and h.waiting and h.support_held
    )  # the walk holds its gait clock with it
    h.update_phases(state(0.12, (-0.05, -0.02)), plan)  # behind and right of the centre: inside FR-RL-RR
    assert h.phase[0] == Phase.SWING and not h.support_held
    h4 = Handler(ROBOT)  # the walk's clock hold used up: no more waiting
    h4.support_hold = sp
    h4.update_phases(state(0.0, front_left), plan)
    h4.support_hold_spent = True
    h4.update_phases(state(0.1, front_left), plan)
    assert h4.phase[0] == Phase.SWING
    h2 = Handler(ROBOT)
    h2.support_hold = sp
    h2.update_phases(state(0.0, front_left), plan)
    h2.update_phases(state(0.1, front_left), plan)
    h2.update_phases(state(0.1 + sp.max_hold_s + 0.01, front_left), plan)
    assert h2.phase[0] == Phase.SWING
    h3 = Handler(ROBOT)  # without the hold (the trot, the walk): lifts on time
    h3.update_phases(state(0.0, front_left), plan)
    h3.update_phases(state(0.1, front_left), plan)
    assert h3.phase[0] == Phase.SWING


def test_a_crawl_liftoff_held_for_an_unloaded_foot_says_so() -> None:
    """Handler.support_held_for_load (the walk controller's body waits on it, SupportShiftParams.hold_body): set
    while the liftoff waits because a foot staying down is not loaded, not while it waits only for the centre of
    mass."""
    from planning.steps.support import SupportShiftParams

    def state(t: float, com_xy: tuple[float, float], rr_loaded: bool) -> RobotState:
        s = _state(t, (True,) * 4)
        s.p_world_com[:2] = com_xy
        s.loaded[:] = (True, True, True, rr_loaded)
        return s

    front_left = tuple(0.5 * ROBOT.fk_leg(0, ROBOT.q_nominal[0])[:2])  # outside FR-RL-RR
    for com, rr_loaded, held, for_load in (
        (front_left, True, True, False),
        ((-0.05, -0.02), False, True, True),
        ((-0.05, -0.02), True, False, False),
    ):
        h = Handler(ROBOT)
        h.support_hold = SupportShiftParams(hold=True)
        h.update_phases(state(0.0, com, rr_loaded), _Plan())
        h.update_phases(state(0.1, com, rr_loaded), _Plan())
        assert h.support_held == held and h.support_held_for_load == for_load
