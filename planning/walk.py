"""Steering mode: velocity commands (or a goal) → capture-point step selection → the handler's contact plan.

The step planner (capture-point-step-path seed) replans at its own rate (≥ 100 Hz); its selected path's next
touchdowns become the handler's contact schedule and the swing legs' targets, so a push changes the next steps before
the swing foot lands. The body reference follows the filtered command.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any

import numpy as np

from planning.balance import BalanceController, BalanceParams, BodyTarget
from planning.centroidal.driver import SolverDriver
from planning.centroidal.problem import BodyState
from planning.centroidal.solver import CentroidalParams
from planning.geometry import rpy_to_R, yaw_R
from planning.handler import Handler, HandlerParams
from planning.robot import RobotModel
from planning.sim.loop import Stage
from planning.sim.world import RobotState
from planning.steps import SteeringCommand, StepPlanner, StepPlannerParams, WalkState
from planning.steps.centroidal import StepPathProblems
from planning.steps.gait import get_gait
from planning.steps.select import Selection
from planning.steps.support import SupportShiftParams, support_target
from planning.swing.params import SwingParams

if TYPE_CHECKING:  # the terrain stack is imported only by the walks that use it
    from planning.terrain.decision import TerrainPipeline, TerrainView


@dataclass(frozen=True)
class _PlannedSwing:
    leg: int
    t_liftoff: float
    t_touchdown: float
    p_touchdown: np.ndarray


class StepPathPlan:
    """The handler's contact plan from the step planner's latest selection."""

    def __init__(self) -> None:
        self.selection: Selection | None = None
        self._t_td = np.full(4, np.nan)
        self._p_td = np.full((4, 3), np.nan)
        self._t_lo = np.full(4, np.inf)
        self.reference_only = False

    def update(self, sel: Selection) -> None:
        self.selection = sel
        self._t_td, self._p_td = sel.path.next_touchdowns()
        self._t_lo = sel.path.t_liftoff_now

    def swing_at(self, leg: int, t: float) -> _PlannedSwing | None:
        t_td = self._t_td[leg]
        if not np.isfinite(t_td):
            return None
        lo = self._t_lo[leg]
        if np.isnan(lo):  # swinging now
            return _PlannedSwing(leg, -np.inf, float(t_td), self._p_td[leg])
        if t >= lo:
            return _PlannedSwing(leg, float(lo), float(t_td), self._p_td[leg])
        return None

    @property
    def t_liftoff_now(self) -> np.ndarray:
        """(4,) s, the next planned liftoff of each foot down now (inf: none; nan: a foot in the air)."""
        return self._t_lo


@dataclass(frozen=True)
class WalkParams:
    """Rates and gains of steering mode."""

    step_rate_hz: float = 100.0  # step path replanning
    centroidal_rate_hz: float = 50.0  # the centroidal solver on the selected path's contact schedule
    use_centroidal: bool = (
        False  # True: the centroidal solver turns the plan into forces (see README: slower, tracks worse)
    )
    solution_max_age_s: float = 0.05
    # the centroidal solver's work per tick, bounded (see CentroidalParams: a tick that runs out keeps the last
    # good solution driving); measured: without a bound 1 tick in 100 took over 50 times the median
    centroidal: CentroidalParams = field(
        default_factory=lambda: CentroidalParams(max_tick_iterations=100, max_tick_solves=3, max_knots=10)
    )
    balance_rate_hz: float = 250.0  # phases and force distribution (500 Hz tracked no better, measured)
    swing_rate_hz: float = 1000.0 / 3.0
    goal_gain: float = 0.8  # 1/s, goal distance → speed command
    goal_speed_mps: float = 0.5  # speed cap when walking to a goal
    goal_tolerance_m: float = 0.08  # stop within this of the goal
    max_position_lead_m: float = 0.05  # the body target leads the body by at most this (m)
    # the gaits whose swings get the fast settings below (the trot above 0.9 m/s; the flight-less bound and gallop,
    # whose 0.16 s swings need them at any speed)
    fast_swing_gaits: tuple[str, ...] = ("trot_fast", "bound", "gallop")
    # the swing feet's horizontal limits while trotting fast (trot_fast): the longer steps need them (m/s, m/s²)
    fast_swing_v_max_xy_mps: float = 6.0
    fast_swing_a_max_xy_mps2: float = 120.0
    # ... per gait, in place of those two (name, m/s, m/s²). The gallop's: at 2.5 m/s its swing feet cover a stride
    # of v·cycle in (1 − duty)·cycle, 6.25 m/s on average, and a swing that cruises at v_max needs v_max above
    # v / (1 − duty) at any cycle time: at 6 m/s the feet landed short and late and the gallop ran 2.2-2.3 m/s; at
    # 7.5 m/s (with its 0.30 s cycle) 2.33-2.37 (8 m/s: 1 to 5 falls in 5 walks)
    gait_swing_limits: tuple[tuple[str, float, float], ...] = (("gallop", 7.5, 120.0),)
    # ... per gait, the lowest share of the nominal friction the forces assume after foot slips (HandlerParams.
    # slip_friction_min, 0.25 otherwise; none set): the gallop at 2.5 m/s slips a few times a run and at 0.25 (μ
    # 0.15) its feet push little; 0.5 with the speed integral: 2.35-2.43 m/s, 4 of 5 walks within 5 %, pushed 3 of 5
    # fell; 0.5 alone: 1 fall in the family; 0.7: 2 falls (docs/agility-notes.md)
    gait_slip_friction_min: tuple[tuple[str, float], ...] = ()
    # ... a late foot descends this fast (m/s; 0.6 otherwise: at 2 m/s a late foot still 6 cm up left the body on
    # one diagonal for 0.1 s and it rolled over)
    fast_swing_late_descent_mps: float = 1.2
    # ... a foot that trips is elevated but not stopped (the trip's immediate "stop forward motion" response lasts
    # this long, s; 0.15 otherwise): a foot stopped at 2 m/s is left behind its hip and the diagonal breaks
    fast_trip_response_s: float = 0.0
    # ... and a swing near its plan's height is replanned from the plan's height (HandlerParams.
    # replan_height_from_plan_m, m): replanned from the measured foot, the hind feet rose 6-9 cm past their
    # planned top at 2 m/s and landed late
    fast_replan_height_from_plan_m: float = 0.03
    # The bound and the gallop (pairs front and hind): the balance QP's pitch gains softened and its horizontal
    # velocity damping raised while in them (BalanceParams' own otherwise). With the default gains the QP held the
    # pitch first and gave up the forward force the hind pair can push with: the mean speed lagged its command by
    # 10-20 % from 1.8 m/s on (measured: forward force asked 34 N more than delivered at 2.5 m/s). 1/s², 1/s, 1/s.
    pair_gaits: tuple[str, ...] = ("bound", "gallop")
    pair_gait_kp_pitch: float = 100.0
    pair_gait_kd_pitch: float = 15.0
    pair_gait_kd_xy: float = 30.0
    # The gaits whose horizontal velocity error is integrated into the body target's acceleration (a feed-forward
    # of the forward force the stance feet do not deliver; issue 29): the gain (1/s²) and the feed-forward's bound
    # (m/s²). The error is integrated only while the steering command is steady (within
    # speed_integral_band_mps for speed_integral_hold_s, s), so accelerating from a stand does not wind it up.
    # Off by default: in the gallop at 2.5 m/s it raised the steered family from 2.33-2.36 to 2.32-2.42 m/s (3 of 5
    # walks within 5 %), but pushed sideways by 15-25 N·s the gallop then fell in 3 of 5 walks (0 of 5 without)
    # (docs/agility-notes.md).
    speed_integral_gaits: tuple[str, ...] = ()
    speed_integral_ki: float = 4.0
    speed_integral_max_mps2: float = 3.0
    speed_integral_band_mps: float = 0.05
    speed_integral_hold_s: float = 0.2
    # ... and dropped (time constant speed_integral_drop_s, s) while the velocity across the command is off by more
    # than speed_integral_disturbed_mps (a push): the forward push it asks for takes the friction the sideways
    # recovery needs (pushed 15-25 N·s sideways at 2.5 m/s the gallop fell in 3 of 5 walks without this, 0 of 5 without
    # the integral)
    speed_integral_disturbed_mps: float = 0.2
    speed_integral_drop_s: float = 0.05
    # ... the velocity error tested against speed_integral_disturbed_mps by its norm (both axes: a push slows the
    # walk forward too, and an integral gated on the sideways error alone wound up during the recovery) rather than
    # across the command only
    speed_integral_disturbed_any_axis: bool = False
    # ... the feed-forward leaking with this time constant (s; None: it holds), a bounded, leaking integral
    speed_integral_leak_s: float | None = None
    # ... and the velocity error low-passed with this time constant (s; 0: as measured) before the push test and the
    # integration: within a gallop's stride its forward speed swings by ±0.15 m/s and its sideways speed by ±0.1, so
    # a norm test on the raw error (0.3 m/s) kept dropping it (2 of 5 walks within 5 %). With all three (0.3 s
    # filter, 0.25 m/s norm, 3 s leak, bound 2 m/s², slip-friction floor 0.5) the gallop's steered family at 2.5
    # m/s ran 2.37-2.44 (4 of 5 within 5 %, no fall), but 25 N·s sideways pushes at 3.9-4.1 s then held 4 of 6
    # (6 of 6 without): still off (docs/agility-notes.md, session 9)
    speed_integral_filter_s: float = 0.0
    # Per gait (name, share): the stance legs' joint damping (HandlerParams.stance_damping) acts about the sweep of a
    # foot standing still under a body moving at this share of the target velocity (planning.handler.
    # stance_damping_torques), not about zero: at 2.5 m/s the damping of the sweep itself brakes the gallop by ~13
    # N. Off by default: in the gallop at 2.5 m/s (25 steered walks from a stand) 0.25-0.35 raised the mean speed
    # from ~2.31 to ~2.35-2.37 m/s (within 5 %: 3 walks off, 4-11 with it), but it fell 6, 0 and 3 times (0.25,
    # 0.3, 0.35; 3 off) and speed-flight's gallop held 9 of 10 pushes (10 of 10 off) (docs/agility-notes.md, session 10)
    gait_stance_damping_ref: tuple[tuple[str, float], ...] = ()
    # static balance in the slow gaits (duty >= support.min_duty: the crawl): a liftoff waits for the centre of mass
    # inside the three feet that stay down, with the gait clock or without, the body target shifted into that
    # triangle (all off)
    # (planning.steps.support; docs/terrain-notes.md, sessions 9 and 13: crawl balance)
    support: SupportShiftParams = field(default_factory=SupportShiftParams)
    steps: StepPlannerParams = field(default_factory=StepPlannerParams)
    balance: BalanceParams = field(default_factory=BalanceParams)
    handler: HandlerParams = field(default_factory=HandlerParams)


class WalkController:
    """Steering-mode controller: step planning, handler, balance forces."""

    def __init__(
        self,
        robot: RobotModel,
        params: WalkParams | None = None,
        gait: str = "trot",
        weights: str = "default",
        reference_only: bool = False,
    ) -> None:
        self.robot = robot
        self.params = p = params or WalkParams()
        self.planner = StepPlanner(robot, p.steps, gait="stand", weights=weights)
        self.planner.walk_gait = get_gait(gait)
        self.gait = gait
        self.reference_only = reference_only
        self.plan = StepPathPlan()
        self.handler = Handler(robot, params=p.handler)
        self.balance = BalanceController(robot, p.balance)
        self.command = SteeringCommand()
        self._then_gait: str | None = None
        self._clock_held_s = 0.0  # how long the gait clock has waited for the coming liftoff's balance (s)
        self._t_last_lift = -np.inf
        self._held_support: tuple[SupportShiftParams | None, SupportShiftParams | None] = (None, None)
        self._terrain_hold = (
            False  # the terrain asks the slow gait's liftoff hold (TerrainDecision.support_hold)
        )
        self._clock_held_now = False  # the gait clock was held at this tick (SupportShiftParams.hold_clock)
        self._via_gait: str | None = None  # the gait walked for one cycle on the way to _then_gait
        self._trot_since: float | None = None
        self.goal: np.ndarray | None = None
        # The terrain pipeline (planning.terrain.decision), when walking on it: the controller asks it for
        # a decision every step-plan tick and applies it (use_terrain).
        self.terrain: TerrainPipeline | None = None
        self.fast_gait = gait  # on a terrain: the gait the pipeline returns to where its cadence allows
        self._gait_since = -np.inf
        self.f_des = np.zeros((4, 3))
        self.height = robot.standing_height_m
        self.pitch = 0.0  # body pitch target, rad (positive: nose down), e.g. along a slope or a stair
        self.target = BodyTarget(np.zeros(3), np.zeros(3), np.eye(3), np.zeros(3))
        self._last_state: RobotState | None = None
        self._p_des: np.ndarray | None = None
        self._yaw_des = 0.0
        self._t_last = 0.0
        self._swing_slow: SwingParams | None = None  # the swing parameters to restore after trot_fast
        self._handler_slow: HandlerParams | None = None  # ... and the handler's
        self._gait_swing_limits = {g: (v, a) for g, v, a in p.gait_swing_limits}
        self._damping_ref = dict(p.gait_stance_damping_ref)
        # the fast swing's horizontal limits applied now, and the gait's slip friction floor (None: the handler's)
        self._swing_limits: tuple[float, float, float | None] | None = None
        self._a_ff_along = 0.0  # m/s², along the command
        self._a_ff = np.zeros(2)  # the integrated velocity error's feed-forward (WalkParams.speed_integral_*)
        self._v_err_f = np.zeros(2)  # the velocity error low-passed (WalkParams.speed_integral_filter_s)
        self._v_cmd_ref = np.zeros(2)  # the command the steady test compares with, and since when
        self._t_cmd_ref = 0.0
        self._pair_gains = False  # the balance QP has the pair gaits' gains (WalkParams.pair_gait_*)
        self.problems = StepPathProblems(robot)
        self.driver = (
            SolverDriver(robot, None, p.solution_max_age_s, p.centroidal) if p.use_centroidal else None
        )
        self.stages = [
            Stage("step_plan", p.step_rate_hz, self._step_plan),
            Stage("balance", p.balance_rate_hz, self._balance),
            Stage("swing", p.swing_rate_hz, self._swing),
        ]
        if p.use_centroidal:
            self.stages.insert(1, Stage("centroidal", p.centroidal_rate_hz, self._centroidal))

    def use_terrain(self, terrain: TerrainPipeline) -> None:
        """Walks on the unified terrain pipeline: its perception and body-path stages run first, and every
        step-plan tick the controller applies its decision (command, gait, body height and pitch, swing ground)
        and its footholds. The swing planner and the handler take the pipeline's swing settings (the same on every
        terrain)."""
        self.terrain = terrain
        self.fast_gait = self.gait
        sp = self.handler.swing_planner
        sp.set_params(terrain.params.swing.applied_to(sp.params))
        self.handler.params = replace(
            self.handler.params, replan_height_from_plan_m=terrain.params.replan_height_from_plan_m
        )
        if terrain.goal is not None:
            self.set_goal(*terrain.goal)
        # the swing replanning at the pipeline's rate
        self.params = replace(self.params, swing_rate_hz=terrain.params.swing_rate_hz)
        for st in self.stages:
            if st.name == "swing":
                st.rate_hz = terrain.params.swing_rate_hz
        self.stages[:0] = [
            Stage(
                "perception", terrain.params.perception_rate_hz, lambda s: terrain.perceive(s.p_world_body)
            ),
            Stage("body_path", 10.0, lambda s: terrain.plan_path(s.p_world_body, s.yaw, s.t)),
        ]

    def _terrain_view(self, s: RobotState) -> TerrainView:
        from planning.terrain.decision import TerrainView

        return TerrainView(
            t_s=s.t,
            p_world_body=s.p_world_body.copy(),
            yaw=s.yaw,
            p_world_foot=s.p_world_foot.copy(),
            v_world_foot=s.v_world_foot.copy(),
            stance=self.handler.stance.copy(),
            z_contact=self._contact_z(),
            gait=self.gait,
            gait_since_s=self._gait_since,
            fast_gait=self.fast_gait,
            operator=self.command,
            goal=None if self.goal is None else self.goal.copy(),
            pitch_rad=self.pitch,
            height_m=self.height,
            foot_radius_m=self.robot.foot_radius_m,
            standing_height_m=self.robot.standing_height_m,
            p_body_hip=np.asarray(self.robot.p_body_hip, dtype=np.float64)[:, :2],
            dt_s=1.0 / self.params.step_rate_hz,
            l_upper_m=self.robot.l_upper,
            l_lower_m=self.robot.l_lower,
            abd_offset_m=np.asarray(self.robot.abd_offset, dtype=np.float64),
            shin_radius_m=self.robot.shin_radius_m,
        )

    # ---- inputs -----------------------------------------------------------------------------------------------
    def steer(self, vx: float, vy: float, yaw_rate: float) -> None:
        """Sets the velocity command (m/s forward, m/s left, rad/s); the planner's filter limits and smooths it."""
        self.command = SteeringCommand(vx, vy, yaw_rate)
        self.goal = None

    def set_goal(self, x: float, y: float) -> None:
        self.goal = np.array([x, y], dtype=float)

    # switches that go through another gait for one cycle (measured: straight from a bound to a crawl the robot
    # fell; from trot_fast to a bound at 1.3-1.4 m/s it fell, through a gallop it holds)
    _VIA: dict[tuple[str, str], str] = {("bound", "walk"): "trot", ("trot_fast", "bound"): "gallop"}

    def set_gait(self, gait: str) -> None:
        """Switches gait while walking (at the planner's next safe boundary); some switches go through another
        gait for one cycle (_VIA)."""
        current = self.planner.clock.gait.name
        self.gait = gait
        via = self._VIA.get((current, gait))
        if via is not None:
            self._then_gait, self._via_gait = gait, via
            self.planner.set_gait(via)
            return
        self._then_gait = self._via_gait = None
        self.planner.set_gait(gait)

    def _goal_command(self, s: RobotState) -> SteeringCommand:
        assert self.goal is not None
        p = self.params
        d_world = self.goal - s.p_world_body[:2]
        dist = float(np.linalg.norm(d_world))
        if dist < p.goal_tolerance_m:
            return SteeringCommand()
        yaw = s.yaw
        c, sn = np.cos(yaw), np.sin(yaw)
        d_body = np.array([c * d_world[0] + sn * d_world[1], -sn * d_world[0] + c * d_world[1]])
        speed = min(p.goal_speed_mps, p.goal_gain * dist)
        v = d_body / dist * speed
        return SteeringCommand(float(v[0]), float(v[1]), 0.0)

    # ---- stages -----------------------------------------------------------------------------------------------
    def _walk_state(self, s: RobotState) -> WalkState:
        feet = s.p_world_foot.copy()
        feet[:, 2] -= self.robot.foot_radius_m
        return WalkState(
            s.p_world_com.copy(),
            s.v_world_com.copy(),
            s.yaw,
            float(s.omega_world[2]),
            feet,
            self.handler.stance.copy(),
            s.t,
        )

    def _contact_z(self) -> float:
        """The feet's mean contact height (m): np.mean's value (the sum over the count) without its dispatch cost."""
        z = self.handler.p_contact[:, 2]
        return float(z.sum() / z.shape[0])

    def _step_plan(self, s: RobotState) -> None:
        clock = self.planner.clock
        via = self._via_gait
        if self._then_gait is not None and clock.pending is None and self.planner.walk_gait.name == via:
            self._trot_since = s.t if self._trot_since is None else self._trot_since
            if s.t - self._trot_since >= clock.gait.cycle_s:  # one full cycle, then on to the asked gait
                self.planner.set_gait(self._then_gait)
                self._then_gait, self._via_gait, self._trot_since = None, None, None
        view = None
        decision = None
        if self.terrain is not None:
            view = self._terrain_view(s)
            decision = self.terrain.decide(view)
        if decision is not None:
            if decision.gait != self.gait:
                self.set_gait(decision.gait)
                self._gait_since = s.t
            self.height = decision.body_height_m
            self.pitch = decision.body_pitch_rad
            self._terrain_hold = decision.support_hold
            self.handler.ground = decision.swing_ground
            cmd = decision.command
        elif self.goal is not None:
            cmd = self._goal_command(s)
        else:
            cmd = self.command
        maps = None if self.terrain is None else self.terrain.maps
        sel = self.planner.tick(cmd, self._walk_state(s), maps)
        self._swing_for_speed()
        self._balance_for_gait()
        if self.reference_only:
            ref = sel.candidates[0]
            sel = Selection(ref, 0.0, sel.scores, 0, sel.candidates, sel.xi_td, sel.xi_td_reference, True, 1)
        if self.terrain is not None and view is not None:
            sel = self.terrain.footholds(view, sel)
        self.plan.update(sel)

    def _balance_for_gait(self) -> None:
        """Sets the balance QP's pitch and horizontal damping gains (in place) for the gait walked: the pair gaits'
        (WalkParams.pair_gait_*) in the bound and the gallop, BalanceParams' otherwise."""
        pair = self.planner.clock.gait.name in self.params.pair_gaits
        if pair == self._pair_gains:
            return
        self._pair_gains = pair
        b, p, bp = self.balance, self.params, self.balance.params
        b.kp_rot[1] = p.pair_gait_kp_pitch if pair else bp.kp_rot[1]
        b.kd_rot[1] = p.pair_gait_kd_pitch if pair else bp.kd_rot[1]
        b.kd_pos[:2] = p.pair_gait_kd_xy if pair else bp.kd_pos[:2]

    def _swing_for_speed(self) -> None:
        """Raises the swing feet's horizontal limits and speeds up their late touchdowns and trip responses while
        the gait is one of the fast ones (WalkParams.fast_*, a gait's own horizontal limits from
        WalkParams.gait_swing_limits); restores them after."""
        name = self.planner.clock.gait.name
        fast = name in self.params.fast_swing_gaits
        p = self.params
        v_a = self._gait_swing_limits.get(name, (p.fast_swing_v_max_xy_mps, p.fast_swing_a_max_xy_mps2))
        slip_min = dict(p.gait_slip_friction_min).get(name)
        limits = (v_a[0], v_a[1], slip_min)
        if fast == (self._swing_slow is not None) and (not fast or limits == self._swing_limits):
            return
        sp = self.handler.swing_planner
        if fast:
            if self._swing_slow is None:
                self._swing_slow = sp.params
                self._handler_slow = self.handler.params
            self._swing_limits = limits
            sp.set_params(
                replace(
                    self._swing_slow,
                    v_max_xy_mps=limits[0],
                    a_max_xy_mps2=limits[1],
                    late_descent_mps=p.fast_swing_late_descent_mps,
                    trip_response_s=p.fast_trip_response_s,
                )
            )
            assert self._handler_slow is not None
            self.handler.params = replace(
                self._handler_slow,
                replan_height_from_plan_m=p.fast_replan_height_from_plan_m,
                slip_friction_min=self._handler_slow.slip_friction_min if slip_min is None else slip_min,
            )
        else:
            assert self._swing_slow is not None and self._handler_slow is not None
            sp.set_params(self._swing_slow)
            self.handler.params = self._handler_slow
            self._swing_slow = self._handler_slow = None
            self._swing_limits = None

    def _centroidal(self, s: RobotState) -> None:
        sel = self.plan.selection
        if sel is None or self.driver is None:
            return
        state = BodyState(
            s.t, s.p_world_com.copy(), s.v_world_com.copy(), s.R_world_body.copy(), s.omega_world.copy()
        )
        stance = self.handler.stance.copy()
        self.driver.solve(
            self.problems.problem_at(state, sel.path, stance, self.handler.p_contact, self.height), s.t
        )

    def _balance(self, s: RobotState) -> None:
        self.handler.update_phases(s, self.plan)
        self._hold_clock_for_support(s)
        self._update_target(s)
        stance = self.handler.stance
        if self.driver is not None and self.driver.forces(s.t, stance, self.f_des):
            np.subtract(s.p_world_foot, s.p_world_com, out=self.balance.r_com_foot)
            self.balance.r_com_foot[:, 2] -= self.robot.foot_radius_m
        else:
            # the friction assumed, lowered after foot slips (Handler.friction_scale)
            mu = self.balance.params.mu * self.handler.friction_scale
            self.f_des[:] = self.balance.contact_forces(s, self.target, stance, mu=mu)

    def _hold_clock_for_support(self, s: RobotState) -> None:
        """While a liftoff waits for static balance (SupportShiftParams.hold with hold_clock), the gait clock waits
        with it: every later planned event moves by the wait, so the held swing keeps its duration and the legs
        after it their four-foot phases; at most max_hold_s per liftoff."""
        h = self.handler
        sp = h.support_hold
        self._clock_held_now = False
        if sp is None or not sp.hold_clock:
            return
        t_lift = float(np.max(h.t_liftoff))
        if t_lift != self._t_last_lift:
            self._t_last_lift = t_lift
            self._clock_held_s = 0.0
            h.support_hold_spent = False
        dt = s.t - self._t_last  # the balance tick's step (_update_target moves _t_last after this)
        if not h.support_held or not 0.0 < dt < 0.05:
            return
        step = min(dt, sp.max_hold_s - self._clock_held_s)
        if step > 0.0:
            self.planner.clock.hold(step)
            self._clock_held_s += step
            self._clock_held_now = True
        if self._clock_held_s >= sp.max_hold_s:
            h.support_hold_spent = True

    def _update_target(self, s: RobotState) -> None:
        dt = s.t - self._t_last
        self._t_last = s.t
        cmd = self.planner.steering.command
        if self._p_des is None:
            self._p_des = s.p_world_body.copy()
            self._yaw_des = s.yaw
        # the body waits for its feet while the gait clock waits for a liftoff (SupportShiftParams.hold_body)
        sp = self.handler.support_hold
        wait = (
            self._clock_held_now
            and sp is not None
            and sp.hold_body
            and (sp.hold_body_for_com or self.handler.support_held_for_load)
        )
        yaw_rate = 0.0 if wait else cmd.yaw_rate
        self._yaw_des += yaw_rate * dt
        v = yaw_R(self._yaw_des) @ (np.zeros(3) if wait else np.array([cmd.vx, cmd.vy, 0.0]))
        R = rpy_to_R(np.array([0.0, self.pitch, self._yaw_des])) if self.pitch else yaw_R(self._yaw_des)
        self._p_des += v * dt
        # the target leads the body by a bounded amount: it tracks velocity, not an absolute path
        lead = self._p_des[:2] - s.p_world_body[:2]
        n = float(np.linalg.norm(lead))
        if n > self.params.max_position_lead_m:
            self._p_des[:2] = s.p_world_body[:2] + lead * (self.params.max_position_lead_m / n)
        dyaw = (self._yaw_des - s.yaw + np.pi) % (2 * np.pi) - np.pi
        if abs(dyaw) > 0.3:
            self._yaw_des = s.yaw + np.sign(dyaw) * 0.3
        ground = self._contact_z()
        self._p_des[2] = ground + self.height
        t = self.target
        t.p_world_body = self._p_des.copy()
        self._support_shift(s, t.p_world_body)
        t.v_world_body = v
        t.R_world_body = R
        t.omega_world = np.array([0.0, 0.0, yaw_rate])
        # turning while moving: the velocity turns with the yaw rate, so the body needs the centripetal
        # acceleration ω × v (2.25 m/s² on a 1 m radius at 1.5 m/s; without it the body slid out of the circle)
        t.a_world_body = np.array([-yaw_rate * v[1], yaw_rate * v[0], 0.0])
        if wait:
            return  # the speed integral neither integrates nor pushes while the body waits
        self._speed_integral(s, v, np.array([cmd.vx, cmd.vy]), dt)
        t.a_world_body[:2] += self._a_ff

    def _support_shift(self, s: RobotState, p_target: np.ndarray) -> None:
        """Moves the body target (in place, xy) so that the centre of mass lies in the support triangle of the
        slow gaits (WalkParams.support, planning.steps.support.support_target)."""
        sp = self.params.support
        gait = self.planner.clock.gait
        h = self.handler
        if gait.is_stand or gait.duty < sp.min_duty:
            h.support_hold = None
            return
        if sp.hold or not self._terrain_hold:
            h.support_hold = sp
        else:
            if self._held_support[0] is not sp:  # made once per parameter set, not every tick
                self._held_support = (sp, replace(sp, hold=True))
            h.support_hold = self._held_support[1]
        if not sp.shift:
            return
        stance = h.stance
        feet = np.where(stance[:, None], h.p_contact[:, :2], h.p_touchdown[:, :2])
        if not np.all(np.isfinite(feet)):
            return
        off = s.p_world_body[:2] - s.p_world_com[:2]
        com = p_target[:2] - off
        p_target[:2] = support_target(com, feet, stance, self.plan.t_liftoff_now, s.t, sp) + off

    def _speed_integral(self, s: RobotState, v: np.ndarray, v_cmd: np.ndarray, dt: float) -> None:
        """Integrates the horizontal velocity error (world frame; v the target's velocity) into self._a_ff in the
        gaits of WalkParams.speed_integral_gaits while the command (v_cmd, heading frame) is steady; resets it in
        other gaits."""
        p = self.params
        if float(np.linalg.norm(v_cmd - self._v_cmd_ref)) > p.speed_integral_band_mps:
            self._v_cmd_ref[:] = v_cmd
            self._t_cmd_ref = s.t
        if self.planner.clock.gait.name not in p.speed_integral_gaits:
            self._a_ff_along = 0.0
            self._a_ff[:] = 0.0
            self._v_err_f[:] = 0.0
            return
        if dt <= 0.0:
            return
        # along the command only: sideways (the turns' centripetal term) it added roll and slowed the turning walks
        # (a scalar that turns with the command: a world-frame vector went stale at 0.4 rad/s)
        speed = float(np.linalg.norm(v[:2]))
        if speed < p.speed_integral_band_mps:
            self._a_ff_along = 0.0
            self._a_ff[:] = 0.0
            return
        u = v[:2] / speed
        err = v[:2] - s.v_world_body[:2]
        # the error averaged over about a stride (a gallop's speed swings within one)
        if p.speed_integral_filter_s > 0.0:
            self._v_err_f += min(dt / p.speed_integral_filter_s, 1.0) * (err - self._v_err_f)
            err = self._v_err_f
        if p.speed_integral_leak_s is not None:
            self._a_ff_along *= math.exp(-dt / p.speed_integral_leak_s)
        if p.speed_integral_disturbed_any_axis:
            off = float(np.linalg.norm(err))
        else:
            off = abs(float(u[0] * err[1] - u[1] * err[0]))
        if off > p.speed_integral_disturbed_mps:
            self._a_ff_along *= math.exp(-dt / p.speed_integral_drop_s)
            self._t_cmd_ref = s.t  # and integrates again only after the hold
            self._a_ff[:] = self._a_ff_along * u
            return
        if s.t - self._t_cmd_ref < p.speed_integral_hold_s:
            self._a_ff[:] = self._a_ff_along * u
            return
        e = float(u @ err)
        self._a_ff_along = min(
            max(self._a_ff_along + p.speed_integral_ki * dt * e, 0.0), p.speed_integral_max_mps2
        )
        self._a_ff[:] = self._a_ff_along * u

    def _swing(self, s: RobotState) -> None:
        self.handler.plan_swings(s, self.target.v_world_body)

    def plan_overlays(self) -> dict[str, dict[str, Any]]:
        """Returns the studio's overlays: the chosen and the reference step paths, the other potential paths, the
        capture points at touchdowns (chosen and reference), swing trajectories and contact forces; on a terrain,
        the terrain pipeline's (planning.terrain.overlays)."""
        s = self._last_state
        if s is None:
            return {}
        out = self.handler.overlays(self.f_des, s.p_world_foot)
        if self.terrain is not None:
            out.update(self.terrain.overlays())
        sel = self.plan.selection
        if sel is None:
            return out
        ground = self._contact_z()

        def flat(xy: np.ndarray) -> list[list[float]]:
            return [
                [round(float(x), 4), round(float(y), 4), round(ground + 0.005, 4)]
                for x, y in np.reshape(xy, (-1, 2))
            ]

        out["steps_selected"] = {
            "kind": "points",
            "points": np.round(sel.path.p_world_touchdown, 4).tolist(),
            "color": [0.1, 0.9, 0.3],
        }
        ref = sel.candidates[0]
        out["steps_reference"] = {
            "kind": "points",
            "points": np.round(ref.p_world_touchdown, 4).tolist(),
            "color": [0.7, 0.7, 0.7],
        }
        others = [p for p in sel.candidates[1:12]]
        out["steps_potential"] = {
            "kind": "points",
            "points": [q for p in others for q in np.round(p.p_world_touchdown, 4).tolist()],
            "color": [0.35, 0.45, 0.6],
        }
        out["capture_points_selected"] = {
            "kind": "polyline",
            "points": flat(sel.xi_td),
            "color": [1.0, 0.85, 0.1],
        }
        out["capture_points_reference"] = {
            "kind": "polyline",
            "points": flat(sel.xi_td_reference),
            "color": [0.6, 0.6, 0.3],
        }
        return out

    def actuate(self, s: RobotState) -> np.ndarray:
        self._last_state = s
        share = self._damping_ref.get(self.planner.clock.gait.name)
        self.handler.stance_damping_v_ref = None if share is None else share * self.target.v_world_body
        return self.handler.torques(s, self.f_des, self.balance.r_com_foot)
