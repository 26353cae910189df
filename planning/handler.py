"""The handler (dynamic-planning-controller seed): carries out a contact plan with the measured state winning.

Per leg a small phase machine decides stance or swing from the plan *and* the contacts the simulator measures: a
foot planned down that has not landed is a late touchdown (it keeps descending and carries no force), a swing foot
that lands early is in stance at once. Stance legs get the planned contact forces through the stance handler (torque
and friction limits enforced again at the joints); swing legs are position-controlled along the swing planner's
trajectories (joint PD plus feed-forward through the leg Jacobian).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import IntEnum
from typing import Any, Protocol

import numpy as np

from planning.robot import LEGS, RobotModel
from planning.robot.model import reference_leg_joint_inertia
from planning.sim.world import RobotState
from planning.stance import StanceHandler
from planning.steps.support import SupportShiftParams, liftoff_ready
from planning.swing import (
    TIER_RGB,
    BodyMotion,
    GroundHeightFn,
    SwingPlan,
    SwingPlanner,
    SwingRequest,
    TripEvent,
    classify_trip,
    swing_joint_command,
)


class Phase(IntEnum):
    STANCE = 0
    SWING = 1
    LATE = 2  # past the planned touchdown, not yet in contact: descending until contact


# the members' values as plain ints: the per-tick code compares numpy integers with them thousands of times a second,
# and numpy probes an enum member's class for array protocols (EnumType.__getattr__ calls) on every comparison
_STANCE, _SWING, _LATE = int(Phase.STANCE), int(Phase.SWING), int(Phase.LATE)


class PlannedSwing(Protocol):
    """One planned swing of a contact plan (planning.maneuver.Swing provides it)."""

    @property
    def leg(self) -> int: ...
    @property
    def t_liftoff(self) -> float: ...
    @property
    def t_touchdown(self) -> float: ...
    @property
    def p_touchdown(self) -> np.ndarray: ...


class ContactPlan(Protocol):
    """What the handler needs of a plan: which swing a leg is in at time t (None: stance)."""

    def swing_at(self, leg: int, t: float) -> PlannedSwing | None: ...


def too_few_supports(stance: np.ndarray, contact: np.ndarray, lifting: np.ndarray, min_legs: int) -> bool:
    """Whether lifting the legs in ``lifting`` (4,) would leave fewer than ``min_legs`` feet that are both in stance
    (the plan's phase, (4,)) and measured in contact ((4,)): the feet that would carry the body."""
    carry = (
        np.asarray(stance, dtype=bool) & np.asarray(contact, dtype=bool) & ~np.asarray(lifting, dtype=bool)
    )
    return int(carry.sum()) < min_legs


def stepping_down(z_from: np.ndarray, z_to: np.ndarray, moving: np.ndarray, drop_m: float) -> bool:
    """Whether the legs in ``moving`` (4,) step down: one of them lands at least drop_m below its last foothold
    (z_from, (4,), m) and none lands drop_m or more above it (z_to, (4,), m: each moving leg's touchdown). A step
    down a riser or off a box, not a climb nor level ground."""
    m = np.asarray(moving, dtype=bool)
    dz = (np.asarray(z_to, dtype=np.float64) - np.asarray(z_from, dtype=np.float64))[m]
    dz = dz[np.isfinite(dz)]
    return bool(dz.size) and bool((dz <= -drop_m).any()) and not bool((dz >= drop_m).any())


@dataclass(frozen=True)
class HandlerParams:
    """Joint gains of swing legs and the contact rules."""

    kp_swing: tuple[float, float, float] = (120.0, 120.0, 120.0)  # N·m/rad
    kd_swing: tuple[float, float, float] = (3.0, 3.0, 3.0)  # N·m·s/rad
    stance_damping: float = 0.5  # N·m·s/rad on stance legs
    early_touchdown_fraction: float = 0.5  # a contact after this fraction of the swing counts as a touchdown
    max_liftoff_delay_s: float = 0.12  # a liftoff waits at most this long for a late foot to land
    landing_wait_s: float = 0.04  # a foot due down within this counts as late for other legs' liftoffs
    min_stance_s: float = 0.08  # a foot that just landed stays down at least this long
    min_stance_legs: int = 2  # liftoffs wait (max_liftoff_delay_s at most) rather than leave fewer feet down
    # None: off. On a descent, a liftoff that would leave fewer than min_stance_legs feet down *and measured in
    # contact* (a foot in stance that bounced or lost its ground does not count; too_few_supports) waits up to this
    # long (s, from when it fell due) instead of max_liftoff_delay_s; past its planned touchdown the step is skipped
    # (the foot stays down for the gait's next cycle). Off: 0.25 s measured the stairs family 27 of 50 clean as
    # main (21 falls to 16, five of them crossing with a no-step touchdown instead; docs/terrain-notes.md, session
    # 13: the descent's late-touchdown cascade)
    support_wait_s: float | None = None
    # m: ... only while the legs in the air or lifting step down (one lands at least this far below its last
    # foothold, none this far above; stepping_down): on a climb or level ground a longer wait only squeezes the
    # waiting swing (its touchdown time stays), and a climbing swing squeezed meets the riser
    support_wait_drop_m: float = 0.05
    self_collision_m: float = (
        0.05  # a swing foot center this close to another leg's shin is a self-collision trip
    )
    touchdown_lead_s: float = 0.02  # swing trajectories aim to land this much before the planned time
    touchdown_depth_m: float = 0.0  # ... and this far below the planned contact point (the swing planner counts depth as terrain collision)
    max_touchdown_shift_s: float = (
        0.1  # a replanned touchdown may move by at most this much in time mid-swing
    )
    # > 0: a swinging foot within this of its plan's height is replanned from the plan's height and vertical
    # velocity, not the measured ones, so the leg's joint feedback keeps acting on one trajectory; farther off
    # (blocked, pushed) it is replanned from where it is. 0: every swing is replanned from the measured foot, and
    # the joint feedback sees only the drift since the last replan (3 ms): over a riser a foot rising at 2 m/s went
    # on rising 12 cm past its planned top and landed late. The stairs mode turns it on (StairsMode).
    replan_height_from_plan_m: float = 0.0
    mu: float = 0.6
    # Foot slip: a stance foot (down for slip_settle_s, so not the touchdown's impact; measured in contact within
    # the last slip_contact_s: a sliding foot's contact flickers; planned to carry at least slip_min_load_n: a
    # nearly unloaded foot, e.g. before its liftoff, is dragged along) whose measured horizontal
    # speed stays above slip_speed_mps for slip_min_s is a slip (a foot rolling on its sphere moves its center at
    # up to ~0.1 m/s at 1 m/s and ~0.23 m/s at 2 m/s, measured on a 0.8 floor). Each slip lowers the friction the
    # forces assume (the balance QP's and the stance handler's mu) by slip_friction_factor, down to
    # slip_friction_min of the nominal; every slip_recover_s without a slip it rises back by slip_recover_step of
    # the nominal (in steps: a friction changing every tick would refactor the QPs every tick).
    slip_speed_mps: float = 0.4
    slip_contact_s: float = 0.03
    slip_start_s: float = 0.1  # none in a run's first 0.1 s (the feet settle from the spawn pose; Go1's slid)
    slip_min_load_n: float = 20.0
    slip_min_s: float = 0.01
    slip_settle_s: float = 0.02
    slip_friction_factor: float = 0.5
    slip_friction_min: float = 0.25
    slip_recover_s: float = 1.0
    slip_recover_step: float = 0.1


def stance_damping_torques(
    qd: np.ndarray, J_world_foot: np.ndarray, damping: float, v_ref: np.ndarray | None = None
) -> np.ndarray:
    """The stance legs' joint damping (rows of legs, (n,3) N·m): -damping·qd, or, given the body velocity v_ref
    (world, m/s; its horizontal part), -damping·(qd - qd_ref) with qd_ref the joint rates that sweep a foot standing
    still back under a body moving at v_ref (J qd_ref = -v_ref): the damping then brakes the legs' motion relative
    to that sweep, not the sweep itself. qd (n,3) rad/s, J_world_foot (n,3,3): d p_world_foot / d q per leg."""
    if v_ref is None:
        return -damping * qd
    v = np.array([-float(v_ref[0]), -float(v_ref[1]), 0.0])
    out = np.empty_like(qd)
    for i in range(qd.shape[0]):
        try:
            qd_ref = np.linalg.solve(J_world_foot[i], v)
        except np.linalg.LinAlgError:  # a singular leg (stretched): damp about zero
            qd_ref = np.zeros(3)
        out[i] = -damping * (qd[i] - qd_ref)
    return out


class Handler:
    """Leg phases, swing planning and the torques of one robot."""

    def __init__(
        self,
        robot: RobotModel,
        swing_planner: SwingPlanner | None = None,
        params: HandlerParams | None = None,
    ) -> None:
        self.robot = robot
        self.params = params or HandlerParams()
        p = self.params
        self.swing_planner = swing_planner or SwingPlanner(robot)
        self.stance_handler = StanceHandler()
        self.phase = np.zeros(4, dtype=np.int64)  # Phase per leg
        self.stance = np.ones(4, dtype=bool)
        self.t_liftoff = np.zeros(4)
        self.t_touchdown = np.zeros(4)
        self.t_landed = np.full(4, -np.inf)
        # when each stance leg's liftoff fell due (nan: not due), and whether a due liftoff waits this tick
        self._due_since = np.full(4, np.nan)
        self.waiting = False
        self.p_touchdown = np.zeros((4, 3))
        self.p_contact = np.zeros((4, 3))  # where each stance foot stands (contact point)
        self.plans: dict[int, SwingPlan] = {}
        # swing gains per leg and joint: the parameters' (tuned on the reference robot) scaled up by how much a joint's
        # inertia (leg and armature, from MuJoCo) exceeds the reference robot's, so the swing keeps its bandwidth and
        # damping ratio on heavier legs (kp, kd ∝ I); lighter legs keep the parameters' gains
        heavier = np.maximum(1.0, robot.leg_joint_inertia / reference_leg_joint_inertia())
        self.kp = np.array(p.kp_swing) * heavier
        self.kd = np.array(p.kd_swing) * heavier
        self.tau = np.zeros((4, 3))
        self.touchdown_overrides: dict[int, np.ndarray] = {}  # solver-adjusted touchdown places by leg
        self.waypoints: list[np.ndarray | None] = [None] * 4
        self.trips: list[TripEvent | None] = [
            None
        ] * 4  # the last trip of each leg (the planner's response input)
        self.trip_log: list[
            tuple[int, TripEvent]
        ] = []  # (leg, trip) in time order  # (K,4) [t, x, y, z] of each leg's current swing
        self.ground: GroundHeightFn | None = None  # the terrain the swings clear (None: flat)
        # foot slips (see HandlerParams.slip_*): each (leg, t the slip began, how long it lasted so far, s)
        self.slip_log: list[list[Any]] = []
        self.friction_scale = 1.0  # the share of the nominal friction the forces assume now
        self.friction_scale_min = 1.0  # ... its lowest so far
        self._fast_since = np.full(4, np.nan)  # since when a stance foot has been above slip_speed_mps
        self._slip_entry: list[list[Any] | None] = [None] * 4  # the slip in progress, per leg
        self._t_last_slip = -np.inf
        self._t_contact = np.full(4, -np.inf)  # when each foot was last measured in contact
        self._fz_planned = np.zeros(4)  # the normal force each foot was last asked for (torques), N
        self._t_start = 0.0  # the first phase update's time
        self._initialized = False
        # the slow gaits' liftoff hold (planning.steps.support), set by the walk controller in the gaits that use
        # it: a due liftoff waits while the other three feet would not hold the centre of mass (None: off)
        self.support_hold: SupportShiftParams | None = None
        self.support_held = False  # a liftoff waited for static balance at the last phase update
        self.support_held_for_load = False  # ... and one of the feet staying down was not loaded then
        # the walk controller's hold of the gait clock is used up for this liftoff (no more waits)
        self.support_hold_spent = False
        # the body velocity (world, m/s) about whose sweep the stance legs are damped (stance_damping_torques; None:
        # about zero joint rates); the walk controller sets it in the gaits of WalkParams.gait_stance_damping_ref
        self.stance_damping_v_ref: np.ndarray | None = None

    # ---- phases (500 Hz) -------------------------------------------------------------------------------------
    def update_phases(self, s: RobotState, plan: ContactPlan) -> None:
        """Advances each leg's phase from the plan at s.t and the measured contacts."""
        t = s.t
        r = self.robot.foot_radius_m
        if not self._initialized:
            self._t_start = t
            self.p_contact[:] = s.p_world_foot
            self.p_contact[:, 2] -= r
            self._initialized = True
        # measured state wins: while another foot is late (or still in the air when the legs due to lift now would
        # leave fewer than min_stance_legs down), lifting would leave the body on fewer feet than planned; wait for
        # that foot (briefly)
        swings = [plan.swing_at(leg, t) for leg in range(4)]
        due = []
        self.waiting = False
        self.support_held = False
        self.support_held_for_load = False
        for leg in range(4):
            sw = swings[leg]
            if self.phase[leg] != _STANCE or sw is None or t >= sw.t_touchdown:
                self._due_since[leg] = np.nan
                continue
            if np.isnan(self._due_since[leg]):
                self._due_since[leg] = max(t, sw.t_liftoff)
            if t - self.t_landed[leg] >= self.params.min_stance_s:
                due.append((leg, sw))
            else:
                self.waiting = True  # landed late: it stays down min_stance_s first
        if due:
            # a swing foot due down within landing_wait_s counts as late already: in a walk one foot's liftoff falls
            # on another's touchdown, and a foot still high over an obstacle lands after its time
            landing = (self.phase == _SWING) & (self.t_touchdown - t <= self.params.landing_wait_s)
            late = bool(((self.phase == _LATE) | landing).any())
            few = int((self.phase == _STANCE).sum()) - len(due) < self.params.min_stance_legs
            wait_s = self.params.max_liftoff_delay_s
            if self.params.support_wait_s is not None:
                lifting = np.zeros(4, dtype=bool)
                lifting[[leg for leg, _ in due]] = True
                moving = lifting | (self.phase != _STANCE)
                z_to = self.p_touchdown[:, 2].copy()
                for leg, sw in due:
                    z_to[leg] = sw.p_touchdown[2]
                if too_few_supports(
                    self.phase == _STANCE, s.contact, lifting, self.params.min_stance_legs
                ) and stepping_down(self.p_contact[:, 2], z_to, moving, self.params.support_wait_drop_m):
                    few = True
                    wait_s = max(wait_s, self.params.support_wait_s)
            for leg, sw in due:
                # the wait counts from when the liftoff fell due (the plan may have moved its liftoff time since)
                if not (late or few) or t - self._due_since[leg] > wait_s:
                    if self._support_holds(leg, s):
                        self.waiting = True
                        continue
                    self._lift(leg, sw, s)
                else:
                    self.waiting = True
        for leg in range(4):
            ph = self.phase[leg]
            if ph == _STANCE:
                continue
            if ph == _SWING:
                if self._tripped(leg, s):
                    continue  # a trip: the swing planner responds (elevate, stop forward motion, go around)
                sw = swings[leg]
                if sw is not None and leg not in self.touchdown_overrides:
                    # the plan may move a touchdown while the foot is in the air (step replanning), but not into
                    # a later cycle: a foot that should be down by now is a late touchdown, not a new step
                    if abs(sw.t_touchdown - self.t_touchdown[leg]) <= self.params.max_touchdown_shift_s:
                        self.t_touchdown[leg] = sw.t_touchdown
                        self.p_touchdown[leg] = sw.p_touchdown
                frac = (t - self.t_liftoff[leg]) / max(self.t_touchdown[leg] - self.t_liftoff[leg], 1e-3)
                wp = self.waypoints[leg]
                waypoints_left = wp is not None and bool((wp[:, 0] > t).any())
                if s.contact[leg] and frac >= self.params.early_touchdown_fraction and not waypoints_left:
                    self._land(leg, s)
                elif t >= self.t_touchdown[leg]:
                    if s.contact[leg]:
                        self._land(leg, s)
                    else:
                        self.phase[leg] = _LATE
            elif s.contact[leg]:  # LATE
                self._land(leg, s)
        np.equal(self.phase, _STANCE, out=self.stance)
        self._detect_slips(s)

    @property
    def mu(self) -> float:
        """The friction coefficient the stance forces assume now (the nominal, lowered after slips)."""
        return self.params.mu * self.friction_scale

    def _detect_slips(self, s: RobotState) -> None:
        """Flags stance feet sliding on the ground (HandlerParams.slip_*), logs each slip, and lowers the assumed
        friction on each new one (raises it back in steps while none slips)."""
        p = self.params
        t = s.t
        v = s.v_world_foot
        self._t_contact[s.contact] = t
        if t - self._t_start < p.slip_start_s:
            return
        fast = (
            self.stance
            & (self._fz_planned >= p.slip_min_load_n)
            & (t - self._t_contact <= p.slip_contact_s)
            & (t - self.t_landed >= p.slip_settle_s)
            & (v[:, 0] * v[:, 0] + v[:, 1] * v[:, 1] > p.slip_speed_mps * p.slip_speed_mps)
        )
        for leg in range(4):
            entry = self._slip_entry[leg]
            if not fast[leg]:
                self._fast_since[leg] = np.nan
                self._slip_entry[leg] = None
                continue
            if np.isnan(self._fast_since[leg]):
                self._fast_since[leg] = t
            elif entry is not None:
                entry[2] = t - entry[1]
            elif t - self._fast_since[leg] >= p.slip_min_s:
                entry = [leg, float(self._fast_since[leg]), t - float(self._fast_since[leg])]
                self._slip_entry[leg] = entry
                self.slip_log.append(entry)
                self.friction_scale = max(p.slip_friction_min, self.friction_scale * p.slip_friction_factor)
                self.friction_scale_min = min(self.friction_scale_min, self.friction_scale)
                self._t_last_slip = t
        if any(e is not None for e in self._slip_entry):
            self._t_last_slip = t  # the recovery waits for the slips to end
        elif self.friction_scale < 1.0 and t - self._t_last_slip >= p.slip_recover_s:
            self.friction_scale = min(1.0, self.friction_scale + p.slip_recover_step)
            self._t_last_slip = t

    def _tripped(self, leg: int, s: RobotState) -> bool:
        """Detects a trip of a swing leg from the contacts the simulator measured (seed FIG. 16) and records it."""
        frac = (s.t - self.t_liftoff[leg]) / max(self.t_touchdown[leg] - self.t_liftoff[leg], 1e-3)
        foot_hit = (
            bool(s.contact[leg])
            and frac < self.params.early_touchdown_fraction
            and s.t - self.t_liftoff[leg] > 0.03
        )
        knee_hit = bool(s.knee_contact[leg])
        other = self._self_collision(leg, s)
        if not (foot_hit or knee_hit or other is not None):
            return False
        last = self.trips[leg]
        if last is not None and s.t - last.t_s < 0.1:
            return False  # the same trip, still being answered
        feet_body = (s.p_world_foot - s.p_world_body) @ s.R_world_body
        trip = classify_trip(
            self.robot, leg, s.t, feet_body, foot_hit=foot_hit, knee_hit=knee_hit, other_leg=other
        )
        if trip is None:
            return False
        self.trips[leg] = trip
        self.trip_log.append((leg, trip))
        return True

    def _self_collision(self, leg: int, s: RobotState) -> int | None:
        """Returns the other leg whose lower leg the swing foot is touching (the robot's own geoms do not collide
        in the simulator, so this is measured geometrically), or None."""
        p = s.p_world_foot[leg]
        feet = s.p_world_foot.tolist()  # the skip test on Python floats (the same arithmetic, less overhead)
        px, py = feet[leg][0], feet[leg][1]
        for j in range(4):
            # a shin reaches at most ~0.3 m from its foot horizontally: skip legs whose foot is farther than that
            if j == leg or abs(px - feet[j][0]) + abs(py - feet[j][1]) > 0.45:
                continue
            knee = s.p_world_body + s.R_world_body @ self.robot.knee_body(j, s.q[j])
            foot = s.p_world_foot[j]
            d = foot - knee
            u = float(min(max(np.dot(p - knee, d) / max(float(np.dot(d, d)), 1e-9), 0.0), 1.0))  # np.clip
            e = p - (knee + u * d)
            if math.sqrt(e.dot(e)) < self.params.self_collision_m:  # np.linalg.norm's own arithmetic
                return j
        return None

    def _support_holds(self, leg: int, s: RobotState) -> bool:
        """Whether the liftoff of ``leg``, due now, waits for static balance (support_hold; at most its
        max_hold_s from when the liftoff fell due)."""
        sh = self.support_hold
        if sh is None or not sh.hold or s.t - self._due_since[leg] > sh.max_hold_s or self.support_hold_spent:
            return False
        stance = self.phase == _STANCE
        held = not liftoff_ready(
            s.p_world_com[:2],
            self.p_contact[:, :2],
            stance,
            s.loaded,
            leg,
            sh.hold_margin_fraction,
            sh.hold_com,
        )
        if held:
            self.support_held = True
            keep = stance.copy()
            keep[leg] = False
            if not bool(np.all(s.loaded[keep])):
                self.support_held_for_load = True
        return held

    def _lift(self, leg: int, sw: PlannedSwing, s: RobotState) -> None:
        self.phase[leg] = Phase.SWING
        self.t_liftoff[leg] = s.t
        self.t_touchdown[leg] = sw.t_touchdown
        self.p_touchdown[leg] = self.touchdown_overrides.get(leg, sw.p_touchdown)
        self.waypoints[leg] = getattr(sw, "waypoints", None)
        self.plans.pop(leg, None)

    def _land(self, leg: int, s: RobotState) -> None:
        self.phase[leg] = Phase.STANCE
        self.t_landed[leg] = s.t
        self.p_contact[leg] = s.p_world_foot[leg]
        self.p_contact[leg, 2] -= self.robot.foot_radius_m
        self.plans.pop(leg, None)
        self.touchdown_overrides.pop(leg, None)
        self.trips[leg] = None

    def set_touchdown(self, leg: int, p_world: np.ndarray, t: float | None = None) -> None:
        """Moves a swing leg's touchdown target (and time), e.g. to where the centroidal solver put it."""
        self.touchdown_overrides[leg] = np.asarray(p_world, dtype=float)
        if self.phase[leg] != Phase.STANCE:
            self.p_touchdown[leg] = p_world
            if t is not None:
                self.t_touchdown[leg] = t

    # ---- swing planning (333 Hz) ------------------------------------------------------------------------------
    def plan_swings(self, s: RobotState, v_body_des: np.ndarray | None = None) -> None:
        """Replans every swing leg from its measured position and velocity (the height and vertical velocity from
        its last plan while the foot is within HandlerParams.replan_height_from_plan_m of it)."""
        legs = [i for i in range(4) if self.phase[i] != _STANCE]
        if not legs:
            self.plans.clear()
            return
        reqs = []
        r = self.robot.foot_radius_m
        for i in legs:
            p = s.p_world_foot[i].copy()
            p[2] -= r
            # Aim a little early and a little low: the leg lags its reference, and a plan that arrives exactly on
            # time has no room for replanning from measured states. A touchdown time in the past selects the
            # planner's late-touchdown policy (descend until contact).
            t_td = float(self.t_touchdown[i])
            target = self.p_touchdown[i].copy()
            wp = self.waypoints[i]
            ahead = np.zeros(0, dtype=np.int64) if wp is None else np.flatnonzero(wp[:, 0] > s.t + 0.005)
            if wp is not None and ahead.size and self.phase[i] == _SWING:
                # on the way: the next waypoint
                t_td, target = float(wp[ahead[0], 0]), wp[ahead[0], 1:4].copy()
            elif self.phase[i] == _SWING and t_td - self.params.touchdown_lead_s > s.t + 0.01:
                t_td -= self.params.touchdown_lead_s
            target[2] -= self.params.touchdown_depth_m
            last = self.trips[i]
            trip = last if last is not None and s.t - last.t_s < 0.02 else None
            v_foot = s.v_world_foot[i]
            prev = self.plans.get(i)
            tol = self.params.replan_height_from_plan_m
            if tol > 0.0 and prev is not None and trip is None and self.phase[i] == _SWING:
                p_plan, v_plan, _ = prev.sample(s.t)
                if abs(float(p_plan[2]) - float(p[2])) < tol:
                    p[2] = p_plan[2]
                    v_foot = v_foot.copy()
                    v_foot[2] = v_plan[2]
            reqs.append(SwingRequest(i, p, v_foot, target, t_td, trip))
        stance = {i: self.p_contact[i] for i in range(4) if self.phase[i] == _STANCE}
        v = s.v_world_body if v_body_des is None else v_body_des
        body = BodyMotion(
            s.t, s.p_world_body.copy(), s.R_world_body.copy(), v.copy(), float(s.omega_world[2])
        )
        kwargs: dict[str, Any] = {} if self.ground is None else {"ground": self.ground}
        self.plans.update(self.swing_planner.plan(s.t, reqs, stance_feet_world=stance, body=body, **kwargs))

    # ---- what the studio shows -----------------------------------------------------------------------------------
    def overlays(self, f_des: np.ndarray, s_foot: np.ndarray) -> dict[str, dict[str, Any]]:
        """Returns the swing trajectories (colored by tier) and the contact force arrows as studio overlays."""
        out: dict[str, dict[str, Any]] = {}
        for leg, plan in list(self.plans.items()):
            rgb = TIER_RGB[plan.tier]
            out[f"swing_{LEGS[leg]}"] = {
                "kind": "polyline",
                "points": np.round(plan.points(16), 4).tolist(),
                "color": [c / 255.0 for c in rgb],
                "label": f"{plan.tier.name.lower()} ({plan.horizontal_policy}, {plan.vertical_policy})",
            }
        seg = []
        for leg in range(4):
            if self.stance[leg]:
                base = s_foot[leg] - (0.0, 0.0, self.robot.foot_radius_m)
                seg += [np.round(base, 4).tolist(), np.round(base + f_des[leg] * 0.0015, 4).tolist()]
        out["contact_forces"] = {"kind": "segments", "points": seg, "color": [1.0, 0.3, 0.2]}
        return out

    # ---- torques (every physics step) ---------------------------------------------------------------------------
    def torques(self, s: RobotState, f_des: np.ndarray, p_com_foot: np.ndarray | None = None) -> np.ndarray:
        """Returns joint torques (4,3): stance legs realize f_des, swing legs track their trajectories."""
        p = self.params
        self._fz_planned[:] = f_des[:, 2]
        tau = self.stance_handler.solve(
            f_des,
            s.J_world_foot,
            self.stance,
            self.robot.tau_max,
            tau_bias_leg=s.tau_bias,
            mu=self.mu,
            p_com_foot_world=p_com_foot,
        )
        self.tau[:] = tau
        if self.stance_damping_v_ref is None:
            self.tau[self.stance] -= p.stance_damping * s.qd[self.stance]
        else:
            self.tau[self.stance] += stance_damping_torques(
                s.qd[self.stance], s.J_world_foot[self.stance], p.stance_damping, self.stance_damping_v_ref
            )
        for leg in range(4):
            if self.stance[leg]:
                continue
            plan = self.plans.get(leg)
            if plan is None:
                # not planned yet this tick: hold the joints where they are, compensating gravity
                self.tau[leg] = s.tau_bias[leg] - self.kd[leg] * s.qd[leg]
                continue
            q_des, qd_des, tau_ff = swing_joint_command(
                self.robot,
                leg,
                s.q[leg],
                s.qd[leg],
                plan,
                s.t,
                s.R_world_body,
                s.p_world_body,
                s.v_world_body,
                s.omega_world,
                self.swing_planner.params,
            )
            self.tau[leg] = (
                self.kp[leg] * (q_des - s.q[leg])
                + self.kd[leg] * (qd_des - s.qd[leg])
                + tau_ff
                + s.tau_bias[leg]
            )
        tau_max = self.robot.tau_max
        np.minimum(np.maximum(self.tau, -tau_max, out=self.tau), tau_max, out=self.tau)  # np.clip
        return self.tau
