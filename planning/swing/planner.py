"""SwingPlanner: selects a horizontal and a vertical policy per swing leg, in touchdown order, every 3 ms.

Per leg (seed FIGS. 2, 3, 6): every horizontal policy is tried with the most aggressive vertical policy, likeliest
first, each one given the cheap *simple analysis* (limits, reach, undesirability) and — unless that shows it cannot
beat the best so far — the *detailed analysis* that puts it in a tier. A preferred policy in Success is taken at
once. Then the gentlest vertical policy that arrives on time with the margins is chosen. Each policy is evaluated
at most once, so a leg costs at most M + N evaluations.

Several legs (FIGS. 9, 10): legs are planned least time left first; each new leg sees the legs already planned
(their swing paths and lower legs) and the stance legs as obstacles, and their keep-out areas for Swing Around.
When a later leg cannot avoid an earlier one, the earlier one is replanned around it, then the later one again.

Trips (FIG. 16) switch to special policies for ``trip_response_s``; a recent normal trip keeps the foot elevated.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from planning.robot import ReachError, RobotModel
from planning.swing._analysis import (
    Analyzer,
    LegProblem,
    OtherLeg,
    Verdict,
    limits_ok,
    miss_distance,
    reaches,
    undesirability_h,
    undesirability_z,
)
from planning.swing._poly import Poly1D
from planning.swing.params import SwingParams
from planning.swing.policies import (
    AABB,
    DEFAULT_POLICY,
    HORIZONTAL_NAMES,
    HORIZONTAL_POLICIES,
    RISE_FIRST,
    HPath,
    LegCtx,
    VerticalSpec,
    after_hold,
    bbw_axis,
    blocked_keepouts,
    disentangle,
    elevate,
    knee_trip,
    late_touchdown,
    policy_order,
    rise_first_hold,
    side_step,
    stop_forward,
    vertical,
    vertical_family,
    vertical_outlook,
)
from planning.swing.types import (
    BodyMotion,
    FlatGround,
    GroundHeightFn,
    SwingRequest,
    Tier,
    TripEvent,
    TripKind,
    flat_ground,
)

_WAY_SAMPLES = np.linspace(0.0, 1.0, 9)
_ROUTE_SAMPLES = np.linspace(0.0, 1.0, 24)  # the rise-first route's samples (fractions of the way)
_ROUTE_SAMPLES.flags.writeable = False
_max = np.maximum.reduce  # ndarray.max() without the method's Python wrapper (the same reduction)
_F64 = np.dtype(np.float64)
_SHANK_CACHE_M = 0.005  # a leg's shank is recomputed once its foot moved this far in the body frame (m)
# other legs as obstacles and their keep-out areas (heading frame), in one order
_Obstacles = tuple[tuple[OtherLeg, ...] | list[OtherLeg], tuple[AABB, ...] | list[AABB]]


@dataclass(frozen=True, slots=True)
class SwingPlan:
    """A planned swing: analytic world trajectory of the foot contact point from t_start on.

    The horizontal part lives in the heading frame (yaw at planning time) and is turned into the world on
    sampling; after touchdown time the foot holds the target (or, for a late touchdown, keeps descending).
    """

    leg: int
    t_start: float
    t_touchdown: float
    p_touchdown: np.ndarray  # (3,) world, m
    tier: Tier
    horizontal_policy: str
    vertical_policy: str
    evaluations: int  # policy evaluations spent selecting this plan (≤ M + N)
    x_heading: Poly1D
    y_heading: Poly1D
    z: Poly1D
    cos_yaw: float
    sin_yaw: float
    trip: TripKind | None = None
    colliding_leg: int | None = None  # the other leg this plan still collides with (self-collision tiers)

    @property
    def policy_names(self) -> tuple[str, str]:
        """(horizontal policy, vertical policy)."""
        return self.horizontal_policy, self.vertical_policy

    def sample(self, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Returns world position (3,) m, velocity (3,) m/s and acceleration (3,) m/s² of the foot at t (s)."""
        xp, xv, xa = self.x_heading.state(t)
        yp, yv, ya = self.y_heading.state(t)
        zp, zv, za = self.z.state(t)
        c, s = self.cos_yaw, self.sin_yaw
        return (
            np.array([c * xp - s * yp, s * xp + c * yp, zp]),
            np.array([c * xv - s * yv, s * xv + c * yv, zv]),
            np.array([c * xa - s * ya, s * xa + c * ya, za]),
        )

    def state_floats(self, t: float) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
        """sample(t)'s position and velocity as floats (the same arithmetic, without the arrays)."""
        xp, xv, _ = self.x_heading.state(t)
        yp, yv, _ = self.y_heading.state(t)
        zp, zv, _ = self.z.state(t)
        c, s = self.cos_yaw, self.sin_yaw
        return (c * xp - s * yp, s * xp + c * yp, zp), (c * xv - s * yv, s * xv + c * yv, zv)

    def positions(self, ts: np.ndarray) -> np.ndarray:
        """Returns world positions (K,3) at times ts (K,)."""
        hx, hy = self.x_heading.sample_many(ts), self.y_heading.sample_many(ts)
        c, s = self.cos_yaw, self.sin_yaw
        out = np.empty((len(ts), 3))
        out[:, 0] = c * hx - s * hy
        out[:, 1] = s * hx + c * hy
        out[:, 2] = self.z.sample_many(ts)
        return out

    def derivatives(self, ts: np.ndarray, order: int) -> np.ndarray:
        """Returns world velocities (order 1) or accelerations (order 2), (K,3), at times ts (K,)."""
        hx, hy = self.x_heading.sample_many(ts, order), self.y_heading.sample_many(ts, order)
        c, s = self.cos_yaw, self.sin_yaw
        return np.column_stack((c * hx - s * hy, s * hx + c * hy, self.z.sample_many(ts, order)))

    def points(self, n: int = 24) -> np.ndarray:
        """Returns n (≥ 2) world points (n,3) from t_start to touchdown, for the studio."""
        t_end = max(self.t_touchdown, self.t_start + 1e-3)
        return self.positions(np.linspace(self.t_start, t_end, max(n, 2)))


@dataclass(slots=True)
class _Choice:
    hp: HPath
    verdict: Verdict
    evaluations: int


def _linspace(start: float, stop: float, ramp: np.ndarray) -> np.ndarray:
    """np.linspace(start, stop, len(ramp)) with ramp = np.arange(len(ramp)) precomputed: the same arithmetic (and
    so the same bits) without its overhead."""
    div = len(ramp) - 1
    step = (stop - start) / div if div > 0 else 0.0
    if step == 0.0:
        return np.linspace(start, stop, len(ramp))
    y = ramp * step
    y += start
    y[-1] = stop
    return y


def _heading(v: np.ndarray, c: float, s: float) -> tuple[float, float]:
    return float(c * v[0] + s * v[1]), float(-s * v[0] + c * v[1])


def liftoff_clear_height(
    g_route: np.ndarray,
    u: np.ndarray,
    length_m: float,
    travelled_m: float,
    z_liftoff: float,
    params: SwingParams,
) -> float | None:
    """The height (m) a foot that just lifted off must reach before it moves on (SwingParams.liftoff_clear_run_m):
    the highest ground on its route plus liftoff_clear_margin_m, when ground within the first liftoff_clear_run_m
    of the route from the lift-off place stands above the lift-off height z_liftoff by more than
    rise_first_above_m; None when none does, or when the foot is already that far from its lift-off place.

    g_route: the ground (swing ground, dilated by the foot) at the route's samples, the fractions u (from 0: the
    foot now) of its length length_m; travelled_m: how far the foot is from its lift-off place already."""
    left = params.liftoff_clear_run_m - travelled_m
    if params.liftoff_clear_run_m <= 0.0 or left <= 0.0:
        return None
    near = u * length_m <= left
    if not bool(np.any(g_route[near] > z_liftoff + params.rise_first_above_m)):
        return None
    return float(np.max(g_route)) + params.liftoff_clear_margin_m


class SwingPlanner:
    """Plans every swing leg each tick; keeps only per-leg memory (last policy, last plan, last trip)."""

    def __init__(self, robot: RobotModel, params: SwingParams | None = None) -> None:
        self.robot = robot
        self.params = params or SwingParams()
        self.analyzer = Analyzer(robot, self.params)
        self.family: tuple[VerticalSpec, ...] = vertical_family(self.params)
        self.n_horizontal = len(HORIZONTAL_POLICIES)
        self.n_vertical = len(self.family)
        self._previous: list[str | None] = [None] * 4
        self._last_plan: list[SwingPlan | None] = [None] * 4
        self._trip: list[TripEvent | None] = [None] * 4
        # per leg: the body-frame foot center the shank was last computed for, and that shank (NaN: none yet)
        self._sc_foot = np.full((4, 3), np.nan)
        self._sc_shank = np.zeros((4, 3))
        # the same rows as floats (the stance legs' set-up reads them every tick)
        self._sc_foot_f: list[tuple[float, ...]] = [(math.nan,) * 3] * 4
        self._sc_shank_f: list[tuple[float, ...]] = [(0.0,) * 3] * 4
        self._z_liftoff: list[float | None] = [None] * 4  # lift-off height of the current swing, m
        # lift-off place (x, y) of the current swing, m
        self._xy_liftoff: list[np.ndarray | None] = [None] * 4
        # top of the first plan of the current swing, m: replans may change the vertical policy (a measured
        # velocity a hair above a gentle policy's limit makes it infeasible), but never raise the apex, or a foot
        # replanned every 3 ms climbs policy by policy and lands late
        self._z_top: list[float | None] = [None] * 4
        self._trip_z: dict[int, tuple[float, float]] = {}  # leg → (trip time s, foot height at the trip m)
        self._last_t: list[float] = [-np.inf] * 4  # when each leg was last planned, s
        # rise first: the highest clearance height asked for during the current swing, m (None: none asked)
        self._z_clear: list[float | None] = [None] * 4
        # rise over a box: the current swing (not a step up) rises first over the boxes on its route (see
        # SwingParams.rise_over_boxes)
        self._over_box = [False] * 4
        # event-driven selection (SwingParams.reuse_selection_s): per leg, the inputs of the last full tier analysis
        # (time s, terrain map object, the tick's swing legs, the stance feet, the target), and the legs analysed this
        # tick
        self._memo: list[tuple[float, object, frozenset[int], dict[int, np.ndarray], list[float]] | None] = [
            None
        ] * 4
        self._analysed: set[int] = set()
        self._swinging: frozenset[int] = frozenset()  # this tick's swing legs
        self.reused = 0  # selections reused without the tier analysis so far (diagnostics)
        self._side = np.sign(robot.p_body_hip[:, 1])
        # per-leg constants resolved once
        self._ramp = np.arange(self.params.samples, dtype=float)  # for the sample times
        self._up_rf = np.array([0.0, 0.0, robot.foot_radius_m])  # contact point → foot center, m
        self._hips_body = [robot.p_body_hip[i].copy() for i in range(4)]
        self._hips_body_f = [tuple(float(v) for v in robot.p_body_hip[i]) for i in range(4)]
        self._no_hips = np.zeros((0, 3))  # LegProblem.hips on flat ground (no knee grid to probe)

    def set_params(self, params: SwingParams) -> None:
        """Switches to other parameters (a terrain mode), keeping the per-leg memory of the swings under way."""
        if params == self.params:
            return
        self.params = params
        self.analyzer = Analyzer(self.robot, params)
        self.family = vertical_family(params)
        self.n_vertical = len(self.family)
        self._ramp = np.arange(params.samples, dtype=float)

    @property
    def max_evaluations(self) -> int:
        """M + N: the most policy evaluations one leg's selection may take."""
        return self.n_horizontal + self.n_vertical

    def reset(self) -> None:
        """Forgets the per-leg memory (after a teleport or a new maneuver)."""
        self._previous = [None] * 4
        self._last_plan = [None] * 4
        self._trip = [None] * 4
        self._sc_foot[:] = np.nan
        self._sc_foot_f = [(math.nan,) * 3] * 4
        self._z_liftoff = [None] * 4
        self._xy_liftoff = [None] * 4
        self._z_top = [None] * 4
        self._last_t = [-np.inf] * 4
        self._z_clear = [None] * 4
        self._over_box = [False] * 4
        self._memo = [None] * 4

    def _forget(self, leg: int) -> None:
        if self._z_liftoff[leg] is None and self._last_plan[leg] is None and self._trip[leg] is None:
            return  # nothing remembered (a leg in stance, forgotten on an earlier tick)
        self._previous[leg] = None
        self._last_plan[leg] = None
        self._trip[leg] = None
        self._z_liftoff[leg] = None
        self._xy_liftoff[leg] = None
        self._z_top[leg] = None
        self._z_clear[leg] = None
        self._over_box[leg] = False
        self._memo[leg] = None

    # ---- the tick -----------------------------------------------------------------------------------------
    def plan(
        self,
        t_now: float,
        legs: Sequence[SwingRequest],
        ground: GroundHeightFn = flat_ground,
        stance_feet_world: Mapping[int, np.ndarray] | None = None,
        body: BodyMotion | None = None,
    ) -> dict[int, SwingPlan]:
        """Returns a plan per swing leg, planned in touchdown order around each other and the stance legs.

        Call it every replan period with every swing leg: a leg missing from a call is taken to be in stance,
        and its memory (lift-off height, last policy, trip) is cleared. stance_feet_world: contact points (3,)
        of the legs in stance, by leg index. body: the body's predicted motion (defaults to standing still at
        the nominal height over the origin).
        """
        stance = self._checked_stance(stance_feet_world or {})
        seen = set()
        for r in legs:
            if r.leg in seen:
                raise ValueError(f"plan: legs: leg {r.leg} is requested twice")
            if r.leg in stance:
                raise ValueError(f"plan: leg {r.leg} is both swinging and in stance_feet_world")
            seen.add(r.leg)
        if body is None:
            body = BodyMotion(t_now, np.array([0.0, 0.0, self.robot.standing_height_m]), np.eye(3))
        # A leg missing from this tick is in stance, and one not planned for a while starts a new swing.
        for leg in range(4):
            if leg not in seen or t_now - self._last_t[leg] > self.params.new_swing_gap_s:
                self._forget(leg)
        for r in legs:
            self._last_t[r.leg] = t_now
            if self._z_liftoff[r.leg] is None:
                self._z_liftoff[r.leg] = float(r.p_world_foot[2])
                self._xy_liftoff[r.leg] = np.array(r.p_world_foot[:2], dtype=float)
            if r.trip is not None:
                self._trip[r.leg] = r.trip
        order = sorted(legs, key=lambda r: r.t_touchdown)
        by_leg = {r.leg: r for r in order}
        planned: dict[int, SwingPlan] = {}
        yaw = body.yaw
        c, s = math.cos(yaw), math.sin(yaw)
        # the stance legs as obstacles: the same for every swing leg of this tick, set up once for all of them
        fixed = self._stance_obstacles(stance, body, t_now, c, s)
        self._analysed.clear()
        swinging = self._swinging = frozenset(seen)
        terrain = _terrain_of(ground)
        for req in order:
            plan = self._plan_leg(t_now, req, ground, stance, body, planned, fixed)
            blame = plan.colliding_leg
            if plan.tier in (Tier.SELF_COLLISION, Tier.KNEE_SELF_COLLISION) and blame in planned:
                plan = self._replan_earlier(
                    t_now, req, by_leg[blame], plan, ground, stance, body, planned, fixed
                )
            planned[req.leg] = plan
        for leg in self._analysed:
            self._memo[leg] = (t_now, terrain, swinging, stance, by_leg[leg].p_touchdown.tolist())
        for leg, p in planned.items():
            if self._z_top[leg] is None and p.vertical_policy != "LateTouchdown":
                self._z_top[leg] = float(_max(p.z.sample_many(np.linspace(t_now, p.t_touchdown, 12))))
            self._last_plan[leg] = p
            self._previous[leg] = p.horizontal_policy
        return planned

    def _replan_earlier(
        self,
        t_now: float,
        req: SwingRequest,
        earlier_req: SwingRequest,
        plan: SwingPlan,
        ground: GroundHeightFn,
        stance: dict[int, np.ndarray],
        body: BodyMotion,
        planned: dict[int, SwingPlan],
        fixed: _Obstacles,
    ) -> SwingPlan:
        """The later leg cannot avoid an earlier one: replan the earlier leg around the later leg's own
        unobstructed plan, then the later leg again; keep the change only when the later leg does better.
        Updates ``planned`` in place; returns the later leg's plan."""
        j = earlier_req.leg
        earlier = planned.pop(j)
        free = self._plan_leg(t_now, req, ground, stance, body, planned, fixed)
        redo = self._plan_leg(t_now, earlier_req, ground, stance, body, {**planned, req.leg: free}, fixed)
        if redo.tier <= earlier.tier:
            planned[j] = redo
            again = self._plan_leg(t_now, req, ground, stance, body, planned, fixed)
            if again.tier < plan.tier:
                return again
        planned[j] = earlier
        return plan

    def plan_one(
        self,
        t_now: float,
        req: SwingRequest,
        ground: GroundHeightFn = flat_ground,
        stance_feet_world: Mapping[int, np.ndarray] | None = None,
        body: BodyMotion | None = None,
    ) -> SwingPlan:
        """Returns the plan of one swing leg (the others in stance_feet_world are obstacles)."""
        return self.plan(t_now, [req], ground, stance_feet_world, body)[req.leg]

    # ---- one leg ------------------------------------------------------------------------------------------
    def _plan_leg(
        self,
        t_now: float,
        req: SwingRequest,
        ground: GroundHeightFn,
        stance: dict[int, np.ndarray],
        body: BodyMotion,
        planned: dict[int, SwingPlan],
        fixed: _Obstacles,
    ) -> SwingPlan:
        pr = self.params
        leg = req.leg
        last = self._last_plan[leg]
        horizon = req.t_touchdown - t_now
        if (
            last is not None
            and self._trip[leg] is None
            and 0.0 < horizon < pr.min_replan_horizon_s
            and last.t_touchdown == req.t_touchdown
            # np.allclose(last.p_touchdown, req.p_touchdown) for finite points (SwingRequest checks), without its overhead
            and bool(
                (np.abs(last.p_touchdown - req.p_touchdown) <= 1e-8 + 1e-5 * np.abs(req.p_touchdown)).all()
            )
        ):
            return last  # too close to touchdown for a replan from noisy measurements to help
        yaw = body.yaw
        c, s = math.cos(yaw), math.sin(yaw)
        if horizon <= 0.0:
            return self._late(t_now, req, c, s)
        trip = self._trip[leg]
        if trip is not None and t_now - trip.t_s > max(pr.trip_response_s, pr.recent_trip_s):
            trip = self._trip[leg] = None
        # the last selection may be reused: the set-up leaves out what only the tier analysis needs, and completes
        # it when the analysis runs after all
        may_reuse = (
            trip is None and pr.reuse_selection_s > 0.0 and self._may_reuse(t_now, req, ground, stance)
        )
        prob = self._problem(t_now, req, ground, fixed, body, planned, c, s, full=not may_reuse)
        if may_reuse:
            reused = self._reuse(t_now, req, prob)
            if reused is not None:
                self.reused += 1
                return reused
            self._complete(prob, req)
        self._analysed.add(leg)
        if trip is not None and t_now - trip.t_s <= pr.trip_response_s:
            return self._trip_plan(prob, req, trip, stance, planned, ground)
        choice = self._select_horizontal(prob)
        if (
            pr.rise_over_boxes
            and not self._over_box[leg]
            and choice.verdict.tier in _TERRAIN_TIERS
            and not isinstance(ground, FlatGround)
        ):
            prob, choice = self._clear_terrain(t_now, req, ground, fixed, body, planned, c, s, prob, choice)
        elevated = trip is not None and trip.kind is TripKind.NORMAL
        # a rise-first swing keeps the most aggressive vertical policy (capped just above the terrain it rises
        # over): the hold waits for it, and a gentler one, planned from a foot still rising fast, overshoots
        rising = self._z_clear[leg] is not None
        return self._finish(prob, req, choice, force_aggressive=elevated or rising)

    def _may_reuse(
        self, t_now: float, req: SwingRequest, ground: GroundHeightFn, stance: dict[int, np.ndarray]
    ) -> bool:
        """The event-driven selection's conditions that do not need this tick's problem: the last full analysis
        recent, on the same map and legs, its selection the preferred policy in Success, not rising first, the same
        touchdown time; the target and the stance feet within their tolerances, and the foot where the last plan put
        it."""
        pr = self.params
        leg = req.leg
        memo, last = self._memo[leg], self._last_plan[leg]
        if memo is None or last is None:
            return False
        t_full, ground_full, swinging, stance_full, target_full = memo
        if (
            t_now - t_full > pr.reuse_selection_s
            or ground_full is not _terrain_of(ground)
            or last.tier != Tier.SUCCESS
            or last.horizontal_policy != pr.preferred_policy
            or last.trip is not None
            or last.t_touchdown != req.t_touchdown
            or self._z_clear[leg] is not None
            or self._over_box[leg]
            or swinging != self._swinging
            or stance_full.keys() != stance.keys()
        ):
            return False
        (ax, ay, az), (bx, by, bz) = req.p_touchdown.tolist(), target_full
        tol = pr.reuse_target_tol_m
        if abs(ax - bx) > tol or abs(ay - by) > tol or abs(az - bz) > tol:
            return False
        tol = pr.reuse_stance_tol_m
        for j, p in stance.items():
            (ax, ay, az), (bx, by, bz) = p.tolist(), stance_full[j].tolist()
            if abs(ax - bx) > tol or abs(ay - by) > tol or abs(az - bz) > tol:
                return False
        # the foot where the last plan put it (position and velocity)
        (px, py, pz), (vx, vy, vz) = last.state_floats(t_now)
        fx, fy, fz = req.p_world_foot.tolist()
        tol = pr.reuse_foot_tol_m
        if abs(px - fx) > tol or abs(py - fy) > tol or abs(pz - fz) > tol:
            return False
        wx, wy, wz = req.v_world_foot.tolist()
        tol = pr.reuse_foot_vel_tol_mps
        return not (abs(vx - wx) > tol or abs(vy - wy) > tol or abs(vz - wz) > tol)

    def _reuse(self, t_now: float, req: SwingRequest, prob: LegProblem) -> SwingPlan | None:
        """The event-driven selection (SwingParams.reuse_selection_s), once _may_reuse holds: the last selection's
        policies rebuilt from this tick's problem, without the tier analysis, when the problem asks for no hold, its
        policies arrive on time and no gentler vertical policy does; None otherwise (then the full selection runs)."""
        pr = self.params
        leg = req.leg
        last = self._last_plan[leg]
        assert last is not None
        if prob.hold is not None or not prob.z_ok or self._z_clear[leg] is not None:
            return None  # (the set-up may have found terrain to rise over first)
        c = prob.ctx
        hp = HORIZONTAL_POLICIES[HORIZONTAL_NAMES.index(last.horizontal_policy)][1](c)
        if hp is None or not limits_ok(hp, c) or not reaches(hp, c, pr):
            return None
        names = [spec.name for spec in self.family]
        if last.vertical_policy not in names:
            return None
        i = names.index(last.vertical_policy)
        z0, vz0, z1 = prob.z_v_z1
        for spec in self.family[:i]:  # a gentler policy on time again: the full selection decides
            if vertical_outlook(spec, c.t0, z0, vz0, z1, c.t_end, prob.z_ceiling, prob.z_ref)[1]:
                return None
        if i == len(self.family) - 1:
            z_poly = prob.z_aggressive
        else:
            z_poly, ok = vertical(self.family[i], c.t0, z0, vz0, z1, c.t_end, prob.z_ceiling, prob.z_ref)
            if not ok:
                return None
        return SwingPlan(
            leg=leg,
            t_start=c.t0,
            t_touchdown=req.t_touchdown,
            p_touchdown=req.p_touchdown,
            tier=Tier.SUCCESS,
            horizontal_policy=hp.name,
            vertical_policy=last.vertical_policy,
            evaluations=i + 2,
            x_heading=hp.x,
            y_heading=hp.y,
            z=z_poly,
            cos_yaw=prob.cos_yaw,
            sin_yaw=prob.sin_yaw,
        )

    def _clear_terrain(
        self,
        t_now: float,
        req: SwingRequest,
        ground: GroundHeightFn,
        fixed: _Obstacles,
        body: BodyMotion,
        planned: dict[int, SwingPlan],
        c: float,
        s: float,
        prob: LegProblem,
        choice: _Choice,
    ) -> tuple[LegProblem, _Choice]:
        """The plan collides with the terrain or scrapes an edge: the leg planned again with its apex free of the
        first plan's (the foothold moved, or the map changed, since: a top kept from a swing planned over the floor
        left the foot at a box's side), and, still colliding, with a rise-first hold over the boxes on its route as
        well (SwingParams.rise_over_boxes); each taken when it ranks better (its top then the swing's new one, and the
        swing keeps rising over boxes until it lands), else the leg's memory is left as it was."""
        leg = req.leg
        for over_box in (False, True):
            if over_box and choice.verdict.tier != Tier.TERRAIN_COLLISION:
                break
            kept = (self._z_top[leg], self._z_clear[leg], self._over_box[leg])
            self._z_top[leg] = None
            self._over_box[leg] = over_box
            again_prob = self._problem(t_now, req, ground, fixed, body, planned, c, s)
            if over_box and again_prob.hold is None:
                self._z_top[leg], self._z_clear[leg], self._over_box[leg] = kept
                break
            again = self._select_horizontal(again_prob)
            if (int(again.verdict.tier), again.verdict.key) < (int(choice.verdict.tier), choice.verdict.key):
                prob, choice = again_prob, again
            else:
                self._z_top[leg], self._z_clear[leg], self._over_box[leg] = kept
        return prob, choice

    def _problem(
        self,
        t_now: float,
        req: SwingRequest,
        ground: GroundHeightFn,
        fixed: _Obstacles,
        body: BodyMotion,
        planned: dict[int, SwingPlan],
        c: float,
        s: float,
        full: bool = True,
    ) -> LegProblem:
        """The leg's problem for this tick. full: with what only the tier analysis needs (the keep-outs on the
        straight route, the aggressive policy's samples, the hips and the highest ground around them for the knee
        checks, looked up with the ground on the way in one call); else without them, for the event-driven
        selection (_complete adds them, the highest ground around the hips left to the analysis)."""
        pr = self.params
        leg = req.leg
        ts = _linspace(t_now, req.t_touchdown, self._ramp)
        # the hip's height is linear in time (the body turns about z only): the lowest over the swing is at an end
        (r20, r21, r22), hbx, hby, hbz = body.R_world_body[2].tolist(), *self._hips_body_f[leg]
        pz, vz = float(body.p_world_body[2]), float(body.v_world_body[2])
        rz = r20 * hbx + r21 * hby + r22 * hbz
        hip_z_min = min(pz + (t_now - body.t0) * vz, pz + (req.t_touchdown - body.t0) * vz) + rz
        others: list[OtherLeg] = list(fixed[0])
        keepouts: list[AABB] = list(fixed[1])
        r = pr.keepout_radius_m
        rf = self.robot.foot_radius_m
        for j, p in planned.items():
            shank = self._shank(j, p.p_touchdown, body, p.t_touchdown)
            fc = p.positions(ts)
            fc[:, 2] += rf
            others.append(OtherLeg(j, fc, shank))
            keepouts.append(self._keepout(p.p_touchdown + self._up_rf, shank, c, s, r))
        # the request's numbers as floats once (NumPy scalar arithmetic is several times slower)
        (x0, y0, z0), (vx0, vy0, vz0), (x1, y1, z1) = (
            req.p_world_foot.tolist(),
            req.v_world_foot.tolist(),
            req.p_touchdown.tolist(),
        )
        p0 = (c * x0 + s * y0, c * y0 - s * x0)
        p1 = (c * x1 + s * y1, c * y1 - s * x1)
        ctx = LegCtx(
            t0=t_now,
            t_end=req.t_touchdown,
            p0=p0,
            v0=(c * vx0 + s * vy0, c * vy0 - s * vx0),
            p1=p1,
            v_max=pr.v_max_xy_mps,
            a_max=pr.a_max_xy_mps2,
            keepouts=keepouts,
            margin=pr.swing_around_margin_m,
            time_split_frac=pr.time_split_frac,
            blocked=blocked_keepouts(p0, p1, keepouts) if full else [],
        )
        z_ceiling = hip_z_min - self.robot.min_leg_length_m - pr.hip_clearance_m
        g_knee_max = None
        hips = self._no_hips
        if isinstance(ground, FlatGround):
            g_way, g_obstacle = -math.inf, -math.inf
        else:  # the ground on the way and around the hips (for the knees) in one lookup
            # the hips at the swing's start, middle and end: where the knee grid probes
            if full:
                hips = self._hips_at(body, (t_now, float(ts[len(ts) // 2]), req.t_touchdown), leg)
                kx, ky = self.analyzer.knee_grid(leg, hips, c, s)
                (g_way, g_obstacle), g_knee_max = self._ground_on_way(req, ground, (kx, ky))
            else:
                (g_way, g_obstacle), _ = self._ground_on_way(req, ground)
        if pr.terrain_apex_m is not None and math.isfinite(g_way):
            # On mapped terrain the swing rises no higher than needed over the highest ground on its way: a foot
            # high in the air lands late.
            z_ceiling = min(z_ceiling, max(g_way, z0) + pr.terrain_apex_m)
        z_top = self._z_top[leg]
        if z_top is not None and self._trip[leg] is None:
            # A replan keeps the first plan's apex, unless terrain on the way needs more (seen late, or the target
            # moved behind it): then up to the clearance it needs.
            z_cap = max(z_top + pr.apex_tolerance_m, g_obstacle + pr.obstacle_apex_m)
            z_ceiling = min(z_ceiling, z_cap)
        agg = self.family[-1]
        z_ref = self._z_liftoff[leg]
        z_ref = z0 if z_ref is None else z_ref
        if z1 < z_ref - pr.rise_first_above_m:
            # a step down: the swing need not rise far above the surface it leaves (the nosing is at its height)
            z_ceiling = min(z_ceiling, max(z_ref + pr.step_down_top_m, z0))
        z_agg, z_ok = vertical(agg, t_now, z0, vz0, z1, req.t_touchdown, z_ceiling, z_ref)
        hold = None
        if not isinstance(ground, FlatGround):
            z_clear, approach = self._rise_first_height(
                req, ground, z_ref, self._over_box[leg], self._xy_liftoff[leg]
            )
            if pr.rise_first_within_reach and z_clear is not None and z_clear > z_ceiling - 0.003:
                # the leg cannot lift the foot rise_first_margin_m over the terrain: it waits for what it can
                # reach, if that still clears the terrain by 5 mm (else as before: no wait)
                if z_ceiling - 0.003 >= z_clear - pr.rise_first_margin_m + 0.005:
                    z_clear = z_ceiling - 0.003
            z_rose = self._z_clear[leg]
            if z_clear is not None:
                z_rose = self._z_clear[leg] = z_clear if z_rose is None else max(z_rose, z_clear)
            if z_rose is not None:
                # the swing's top stays just above the terrain it rose over: a higher top only delays the touchdown
                z_ceiling = min(z_ceiling, z_rose + pr.rise_first_top_m)
                # ... and rises at a pace the leg tracks (a foot rising fast overshoots its top)
                agg = dataclasses.replace(agg, v_up=min(agg.v_up, pr.rise_first_v_up_mps))
                z_agg, z_ok = vertical(agg, t_now, z0, vz0, z1, req.t_touchdown, z_ceiling, z_ref)
            if z_clear is not None:
                t_clear = z_agg.crossing_time(z_clear)
                if t_clear is None and pr.rise_first_within_reach:
                    # the apex capped at the height it rose to before may fall short of it by rounding
                    t_clear = z_agg.crossing_time(z_clear - 0.004)
                p_wait = None
                d = req.p_touchdown[:2] - req.p_world_foot[:2]
                d_hat = d / max(float(np.linalg.norm(d)), 1e-9)
                anchor = self._xy_liftoff[leg]
                if pr.rise_first_anchored and anchor is not None:
                    # the wait point is fixed from the lift-off place: a foot carried past it comes back
                    ahead = float((req.p_world_foot[:2] - anchor) @ d_hat) + approach
                    p_wait = _heading(anchor + d_hat * max(ahead, 0.0), c, s)
                elif approach > 0.0:
                    p_wait = _heading(req.p_world_foot[:2] + d_hat * approach, c, s)
                hold = None if t_clear is None else rise_first_hold(ctx, t_clear, p_wait)
        return LegProblem(
            leg=leg,
            ctx=ctx,
            cos_yaw=c,
            sin_yaw=s,
            ts=ts,
            p_start=req.p_world_foot,
            v_start=req.v_world_foot,
            p_target=req.p_touchdown,
            z_aggressive=z_agg,
            z_ok=z_ok,
            zs_aggressive=z_agg.sample_many(ts) if full else None,
            others=others,
            hips=hips,
            ground=ground,
            flat_height=ground.height_m if isinstance(ground, FlatGround) else None,
            body=body,
            previous_policy=self._previous[leg],
            u_z_aggressive=undesirability_z(z_agg, agg.height_m, pr),
            z_ref=z_ref,
            xy_liftoff=self._xy_liftoff[leg],
            z_ceiling=z_ceiling,
            hold=hold,
            hip_z_min=hip_z_min,
            z_v_z1=(z0, vz0, z1),
            g_knee_max=g_knee_max,
        )

    def _complete(self, prob: LegProblem, req: SwingRequest) -> None:
        """Adds to a problem set up for the event-driven selection (_problem with full=False) what the tier analysis
        needs: the same values _problem computes with full=True, the highest ground around the hips looked up by
        the analysis (Analyzer._knee_samples) in a call of its own."""
        c = prob.ctx
        c.blocked = blocked_keepouts(c.p0, c.p1, c.keepouts)
        prob.zs_aggressive = prob.z_aggressive.sample_many(prob.ts)
        if prob.flat_height is None:
            ts = prob.ts
            prob.hips = self._hips_at(prob.body, (c.t0, float(ts[len(ts) // 2]), req.t_touchdown), prob.leg)

    def _hips_at(self, body: BodyMotion, times: tuple[float, ...], leg: int) -> np.ndarray:
        """The leg's hip in the world (n,3) at a few times: body.hip_world_many in Python floats (a handful of
        points: a fifth of the time)."""
        (r00, r01, r02), (r10, r11, r12), (r20, r21, r22) = body.R_world_body.tolist()
        hx, hy, hz = self._hips_body_f[leg]
        rx, ry, rz = (
            r00 * hx + r01 * hy + r02 * hz,
            r10 * hx + r11 * hy + r12 * hz,
            r20 * hx + r21 * hy + r22 * hz,
        )
        (px, py, pz), (vx, vy, vz) = body.p_world_body.tolist(), body.v_world_body.tolist()
        w = body.yaw_rate
        rows = []
        for t in times:
            dt = t - body.t0
            if w == 0.0:
                ox, oy = rx, ry
            else:
                cw, sw = math.cos(w * dt), math.sin(w * dt)
                ox, oy = cw * rx - sw * ry, sw * rx + cw * ry
            rows.append((px + dt * vx + ox, py + dt * vy + oy, pz + dt * vz + rz))
        return np.array(rows)

    def _rise_first_height(
        self,
        req: SwingRequest,
        ground: GroundHeightFn,
        z_ref: float,
        over_box: bool = False,
        anchor: np.ndarray | None = None,
    ) -> tuple[float | None, float]:
        """The height (m) the foot must reach before it moves over the terrain ahead (see
        SwingParams.rise_first_above_m), None when nothing on the route asks for it; and how far (m) the foot may
        approach that terrain meanwhile (negative: the foot is already closer to it than rise_first_gap_m).

        On a step up (touchdown above the lift-off by more than rise_first_above_m), terrain on the straight route
        from the foot to the touchdown (under the foot's center or its front) that stands above the line from the
        lift-off height to the touchdown height (the riser) must be cleared
        before the foot moves over it: the foot rises rise_first_margin_m above the highest ground on the route
        first, closing in on it up to rise_first_gap_m. Replanned every tick from the measured foot, so a lagging
        leg waits longer. over_box: any other swing rises so over terrain on the route that stands above both the
        lift-off height and that line by more than rise_first_above_m (a box on the way; see
        SwingParams.rise_over_boxes). anchor: the lift-off place (x, y), for the lift-off clearance of a swing that
        is neither (SwingParams.liftoff_clear_run_m).
        """
        pr = self.params
        if not math.isfinite(pr.rise_first_above_m):
            return None, 0.0
        p0, p1 = req.p_world_foot, req.p_touchdown
        step_up = float(p1[2]) - z_ref > pr.rise_first_above_m
        travelled = -1.0  # how far the foot is from its lift-off place, when the lift-off clearance may apply
        if not step_up and not over_box:
            if pr.liftoff_clear_run_m <= 0.0 or anchor is None:
                return None, 0.0  # not a step up: boxes on the way are the tiers' business
            travelled = math.hypot(float(p0[0] - anchor[0]), float(p0[1] - anchor[1]))
            if travelled >= pr.liftoff_clear_run_m:
                return None, 0.0
        u = _ROUTE_SAMPLES
        n = len(u)
        xs = p0[0] + u * (p1[0] - p0[0])
        ys = p0[1] + u * (p1[1] - p0[1])
        d = p1[:2] - p0[:2]
        length = float(np.linalg.norm(d))
        ahead = d * (float(self.robot.foot_radius_m) / max(length, 1e-9))
        # under the foot's center and its front in one lookup
        g2 = np.asarray(
            ground(np.concatenate((xs, xs + ahead[0])), np.concatenate((ys, ys + ahead[1]))), dtype=float
        )
        g = np.maximum(g2[:n], g2[n:])
        if travelled >= 0.0:
            # the lift-off clearance: the foot waits where it is (no approach) until it stands over its route
            z_lift = liftoff_clear_height(g, u, length, travelled, z_ref, pr)
            if z_lift is None or float(p0[2]) >= z_lift - pr.rise_first_done_m:
                return None, 0.0
            return z_lift, 0.0
        h_line = z_ref + u * (float(p1[2]) - z_ref)
        if not step_up:
            h_line = np.maximum(h_line, z_ref)  # a box, not the surface stepped down from
        above = np.flatnonzero(g > h_line + pr.rise_first_above_m)
        if above.size == 0:
            return None, 0.0
        z_clear = float(np.max(g)) + pr.rise_first_margin_m
        if float(p0[2]) >= z_clear - pr.rise_first_done_m:
            return None, 0.0
        approach = length * float(u[max(int(above[0]) - 1, 0)]) - pr.rise_first_gap_m
        return z_clear, approach

    def _ground_on_way(
        self,
        req: SwingRequest,
        ground: GroundHeightFn,
        extra: tuple[np.ndarray, np.ndarray] | None = None,
    ) -> tuple[tuple[float, float], float | None]:
        """The highest ground (m) on the straight way from the foot to its target, and the highest that stands above
        the line between them by more than obstacle_step_m (-inf when none, or when apex_free_over_obstacles is off);
        both -inf on flat ground. And the highest ground at the extra points (x, y), looked up in the same call
        (None without them)."""
        if isinstance(ground, FlatGround):
            return (-math.inf, -math.inf), None
        u = _WAY_SAMPLES
        n = len(u)
        (x0, y0, z0), (x1, y1, z1) = req.p_world_foot.tolist(), req.p_touchdown.tolist()
        m = n if extra is None else n + len(extra[0])
        px, py = np.empty(m), np.empty(m)
        np.multiply(u, x1 - x0, out=px[:n])
        px[:n] += x0
        np.multiply(u, y1 - y0, out=py[:n])
        py[:n] += y0
        g_extra = None
        if extra is not None:
            px[n:], py[n:] = extra
        gall = np.asarray(ground(px, py), dtype=float)
        g = gall[:n]
        if extra is not None:
            g_extra = float(_max(gall[n:]))
        line = u * (z1 - z0)
        line += z0
        line += self.params.obstacle_step_m
        above = g > line
        g_obstacle = (
            float(_max(g[above]))
            if self.params.apex_free_over_obstacles and True in above.tolist()  # above.any()
            else -math.inf
        )
        return (float(_max(g)), g_obstacle), g_extra

    def _checked_stance(self, feet: Mapping[int, np.ndarray]) -> dict[int, np.ndarray]:
        """The stance feet as (3,) float arrays by leg index; a clear error naming the first bad entry."""
        if not feet:
            return {}
        fast: dict[int, np.ndarray] = {}
        for k, a in feet.items():  # the usual case, checked in floats: float (3,) arrays of finite numbers
            if type(k) is not int or not 0 <= k < 4 or type(a) is not np.ndarray or a.shape != (3,):
                break
            # the dtype by identity first (float64 arrays share one dtype object; != converts the type each time);
            # a sum is finite if each term is
            if (a.dtype is not _F64 and a.dtype != np.float64) or not math.isfinite(sum(a.tolist())):
                break
            fast[k] = a
        else:
            return fast
        keys = list(feet)
        try:
            arr = np.array([feet[k] for k in keys], dtype=float)
            ok = arr.shape == (len(keys), 3) and bool(np.isfinite(arr).all())
            ok = ok and all(0 <= int(k) < 4 for k in keys)
        except (TypeError, ValueError):
            ok = False
        if not ok:
            for k in keys:
                try:
                    a = np.asarray(feet[k], dtype=float)
                    good = 0 <= int(k) < 4 and a.shape == (3,) and bool(np.isfinite(a).all())
                except (TypeError, ValueError):
                    good = False
                if not good:
                    raise ValueError(
                        f"plan: stance_feet_world[{k!r}]: needs a leg index 0..3 and 3 finite numbers"
                    )
        return {int(k): arr[i] for i, k in enumerate(keys)}

    def _shank_body(self, leg: int, p_body_foot: np.ndarray) -> np.ndarray:
        """Knee minus foot center (3,) in the body frame, through the leg IK; cached per leg while the foot moves
        less than shank_cache_m in the body."""
        if float(np.abs(self._sc_foot[leg] - p_body_foot).max()) < _SHANK_CACHE_M:
            return self._sc_shank[leg]
        return self._shank_ik(leg, p_body_foot)

    def _shank_ik(self, leg: int, p_body_foot: np.ndarray) -> np.ndarray:
        try:
            q = self.robot.ik_leg(leg, p_body_foot)
            shank_body = self.robot.knee_body(leg, q) - p_body_foot
        except ReachError:
            # Out of reach: a vertical shank up to the hip height is a safe stand-in.
            shank_body = np.array(
                [0.0, 0.0, min(-p_body_foot[2], self.robot.l_upper + self.robot.l_lower) * 0.5]
            )
        self._sc_foot[leg] = p_body_foot
        self._sc_shank[leg] = shank_body
        self._sc_foot_f[leg] = tuple(self._sc_foot[leg].tolist())
        self._sc_shank_f[leg] = tuple(self._sc_shank[leg].tolist())
        return self._sc_shank[leg]

    def _shank(self, leg: int, p_foot_world: np.ndarray, body: BodyMotion, t: float) -> np.ndarray:
        """Knee minus foot center (3,) world, through the leg IK (cached, see _shank_body)."""
        p_b, R = body.pose_at(t)
        return R @ self._shank_body(leg, R.T @ (p_foot_world + self._up_rf - p_b))

    def _stance_obstacles(
        self, stance: dict[int, np.ndarray], body: BodyMotion, t: float, c: float, s: float
    ) -> _Obstacles:
        """The stance legs as obstacles (foot center to knee) and their keep-out areas in the heading frame, all
        legs at once."""
        if not stance:
            return (), ()
        p_b, R = body.pose_at(t)
        px, py, pz = p_b.tolist()
        (r00, r01, r02), (r10, r11, r12), (r20, r21, r22) = R.tolist()
        rf = self.robot.foot_radius_m
        r = self.params.keepout_radius_m
        # a handful of legs: plain float arithmetic beats NumPy calls on arrays this small (a tenth of the time)
        legs = list(stance)
        rows: list[list[float]] = []
        for j in legs:
            x, y, z = stance[j].tolist()
            z += rf  # the foot center
            dx, dy, dz = x - px, y - py, z - pz
            bx = r00 * dx + r10 * dy + r20 * dz  # body frame: Rᵀ (fc − p)
            by = r01 * dx + r11 * dy + r21 * dz
            bz = r02 * dx + r12 * dy + r22 * dz
            fx, fy, fz = self._sc_foot_f[j]
            if not (
                abs(fx - bx) < _SHANK_CACHE_M
                and abs(fy - by) < _SHANK_CACHE_M
                and abs(fz - bz) < _SHANK_CACHE_M
            ):
                self._shank_ik(j, np.array([bx, by, bz]))
            hx, hy, hz = self._sc_shank_f[j]
            rows.append([x, y, z, r00 * hx + r01 * hy + r02 * hz, r10 * hx + r11 * hy + r12 * hz,
                         r20 * hx + r21 * hy + r22 * hz])  # fmt: skip
        arr = np.array(rows)
        fc, shank = arr[:, :3], arr[:, 3:]
        others = []
        boxes = []
        for i, (x, y, _, sx, sy, _) in enumerate(rows):
            x1, y1 = x + sx, y + sy
            # min(a, b) and max(a, b) as the builtins pick them (b only when strictly smaller or larger), inline
            box = (x1 if x1 < x else x, x1 if x1 > x else x, y1 if y1 < y else y, y1 if y1 > y else y)
            others.append(OtherLeg(legs[i], fc[i : i + 1], shank[i], box))
            ax, ay, bx, by = c * x + s * y, c * y - s * x, c * x1 + s * y1, c * y1 - s * x1
            boxes.append(
                ((bx if bx < ax else ax) - r, (bx if bx > ax else ax) + r,
                 (by if by < ay else ay) - r, (by if by > ay else ay) + r)
            )  # fmt: skip
        return others, boxes

    @staticmethod
    def _keepout(fc: np.ndarray, shank: np.ndarray, c: float, s: float, r: float) -> AABB:
        """The keep-out area (heading-frame box) of a lower leg from its foot center fc along shank."""
        a = _heading(fc, c, s)
        b = _heading(fc + shank, c, s)
        return (min(a[0], b[0]) - r, max(a[0], b[0]) + r, min(a[1], b[1]) - r, max(a[1], b[1]) + r)

    # ---- horizontal selection -----------------------------------------------------------------------------
    def _select_horizontal(self, prob: LegProblem) -> _Choice:
        pr = self.params
        c = prob.ctx
        best: tuple[int, tuple[float, ...]] | None = None
        best_hp: HPath | None = None
        best_v: Verdict | None = None
        default: tuple[HPath, Verdict] | None = None
        evaluations = 0
        hold = prob.hold
        c_pol = c if hold is None else hold.ctx
        previous = None if prob.previous_policy is None else prob.previous_policy.removesuffix(RISE_FIRST)
        for i in policy_order(bool(c_pol.blocked), previous):
            name, fn = HORIZONTAL_POLICIES[i]
            hp = fn(c_pol)
            if hp is None:
                continue
            if hold is not None:
                hp = after_hold(hold, hp)
            evaluations += 1
            # Simple analysis: the best tier and key this policy could reach.
            u = undesirability_h(hp, pr) + prob.u_z_aggressive
            limits = limits_ok(hp, c)
            miss = miss_distance(hp, c)
            reach = hp.t_arrive <= c.t_end + 1e-6 and miss <= pr.xy_reach_tol_m  # reaches(hp, c, pr)
            if not limits:
                opt: tuple[int, tuple[float, ...]] = (Tier.VIOLATES_CONSTRAINTS, (0.0,))
            elif not reach:
                hyst = pr.miss_hysteresis_m if name == prob.previous_policy else 0.0
                opt = (Tier.XY_CANT_REACH, (miss - hyst,))
            else:
                opt = (Tier.SUCCESS if prob.z_ok else Tier.XY_SUCCESS_Z_IMPOSSIBLE, (u,))
            if name != DEFAULT_POLICY and opt[0] == Tier.VIOLATES_CONSTRAINTS:
                continue
            if best is not None and name != DEFAULT_POLICY and not _could_beat(opt, best):
                continue
            v = self.analyzer.analyze(prob, hp, u, (limits, miss, reach))
            if name == DEFAULT_POLICY:
                default = (hp, v)
            if v.tier == Tier.VIOLATES_CONSTRAINTS:
                continue
            cand = (int(v.tier), v.key)
            if best is None or cand < best:
                best, best_hp, best_v = cand, hp, v
            if name == pr.preferred_policy and v.tier == Tier.SUCCESS:
                break
        if best_hp is None or best_v is None:
            if default is None:
                hp = HORIZONTAL_POLICIES[HORIZONTAL_NAMES.index(DEFAULT_POLICY)][1](c_pol)
                assert hp is not None
                if hold is not None:
                    hp = after_hold(hold, hp)
                evaluations += 1
                default = (hp, self.analyzer.analyze(prob, hp, undesirability_h(hp, pr)))
            best_hp, best_v = default
            best_v.tier = Tier.DEFAULT
        return _Choice(best_hp, best_v, evaluations)

    # ---- vertical selection and the plan ------------------------------------------------------------------
    def _finish(
        self,
        prob: LegProblem,
        req: SwingRequest,
        choice: _Choice,
        force_aggressive: bool = False,
        trip: TripKind | None = None,
    ) -> SwingPlan:
        c = prob.ctx
        evaluations = choice.evaluations
        z_poly, z_name = prob.z_aggressive, self.family[-1].name
        if choice.verdict.tier == Tier.SUCCESS and not force_aggressive:
            z0, vz0, z1 = prob.z_v_z1
            # a policy that arrives late, or whose peak stays below what the terrain on the way needs, fails:
            # rejected without building its trajectory (the same selection, a few float operations instead)
            need = self.analyzer.clearance_need(choice.verdict) - 1e-9
            for i, spec in enumerate(self.family):
                evaluations += 1
                if i == len(self.family) - 1:
                    break
                if i > 0 or (prob.z_gentlest is None and need > -math.inf):
                    peak, on_time = vertical_outlook(
                        spec, c.t0, z0, vz0, z1, c.t_end, prob.z_ceiling, prob.z_ref
                    )
                    if not on_time or peak < need:
                        continue
                if i == 0:
                    zp, zs = self.analyzer.gentlest(prob)
                    ok = prob.z_gentlest_ok
                else:
                    zp, ok = vertical(spec, c.t0, z0, vz0, z1, c.t_end, prob.z_ceiling, prob.z_ref)
                    zs = zp.sample_many(prob.ts)
                if ok and self.analyzer.vertical_ok(prob, choice.verdict, zs):
                    z_poly, z_name = zp, spec.name
                    break
        else:
            evaluations += 1
        return SwingPlan(
            leg=req.leg,
            t_start=c.t0,
            t_touchdown=req.t_touchdown,
            p_touchdown=req.p_touchdown,
            tier=choice.verdict.tier,
            horizontal_policy=choice.hp.name,
            vertical_policy=z_name,
            evaluations=evaluations,
            x_heading=choice.hp.x,
            y_heading=choice.hp.y,
            z=z_poly,
            cos_yaw=prob.cos_yaw,
            sin_yaw=prob.sin_yaw,
            trip=trip,
            colliding_leg=choice.verdict.blame,
        )

    def _late(self, t_now: float, req: SwingRequest, c: float, s: float) -> SwingPlan:
        """Late touchdown: hold the target in xy and descend at a fixed speed until contact."""
        pr = self.params
        p0, v0, p1 = (
            _heading(req.p_world_foot, c, s),
            _heading(req.v_world_foot, c, s),
            _heading(req.p_touchdown, c, s),
        )
        x, _ = bbw_axis(t_now, p0[0], v0[0], p1[0], pr.v_max_xy_mps, pr.a_max_xy_mps2)
        y, _ = bbw_axis(t_now, p0[1], v0[1], p1[1], pr.v_max_xy_mps, pr.a_max_xy_mps2)
        # high above the touchdown (a step down, a swing that rose over a riser), descend faster
        above = max(float(req.p_world_foot[2] - req.p_touchdown[2]) - pr.late_descent_above_m, 0.0)
        descent = min(pr.late_descent_mps + pr.late_descent_gain_per_s * above, pr.v_max_down_mps)
        z = late_touchdown(
            t_now,
            float(req.p_world_foot[2]),
            float(req.v_world_foot[2]),
            max(descent, pr.late_descent_mps),
            pr.a_max_z_mps2,
        )
        miss = math.hypot(p0[0] - p1[0], p0[1] - p1[1])
        return SwingPlan(
            leg=req.leg,
            t_start=t_now,
            t_touchdown=req.t_touchdown,
            p_touchdown=req.p_touchdown,
            tier=Tier.SUCCESS if miss <= pr.xy_reach_tol_m else Tier.XY_CANT_REACH,
            horizontal_policy="BangBangWait",
            vertical_policy="LateTouchdown",
            evaluations=2,
            x_heading=x,
            y_heading=y,
            z=z,
            cos_yaw=c,
            sin_yaw=s,
        )

    # ---- trips --------------------------------------------------------------------------------------------
    def _trip_plan(
        self,
        prob: LegProblem,
        req: SwingRequest,
        trip: TripEvent,
        stance: dict[int, np.ndarray],
        planned: dict[int, SwingPlan],
        ground: GroundHeightFn = flat_ground,
    ) -> SwingPlan:
        """Seed FIG. 16: normal trip → stop forward motion and elevate; knee and self-collisions → special XY.

        A normal trip elevates the foot trip_lift_m above where it tripped, and at least over the highest mapped
        ground on its way to the touchdown (the riser or box it hit) by the foot radius and clearance_margin_m."""
        pr = self.params
        c = prob.ctx
        leg = req.leg
        if trip.kind is TripKind.NORMAL:
            hp = stop_forward(c)
            v = self.analyzer.analyze(prob, hp, undesirability_h(hp, pr))
            z0, vz0 = float(req.p_world_foot[2]), float(req.v_world_foot[2])
            z_ceiling = prob.hip_z_min - self.robot.min_leg_length_m - pr.hip_clearance_m
            # above where it tripped (not above where it is now: replans every tick would ratchet it up)
            z_trip = self._trip_z.get(leg)
            if z_trip is None or z_trip[0] != trip.t_s:
                z_trip = self._trip_z[leg] = (trip.t_s, z0)
            (g_way, _), _ = self._ground_on_way(req, ground)
            z_clear = g_way + float(self.robot.foot_radius_m) + pr.clearance_margin_m
            z_top = min(max(z_trip[1] + pr.trip_lift_m, z_clear), max(z_ceiling, z0))
            z = elevate(c.t0, z0, vz0, z_top, pr.v_max_up_mps, pr.a_max_z_mps2)
            return SwingPlan(
                leg=leg,
                t_start=c.t0,
                t_touchdown=req.t_touchdown,
                p_touchdown=req.p_touchdown,
                tier=v.tier,
                horizontal_policy=hp.name,
                vertical_policy="Elevate",
                evaluations=2,
                x_heading=hp.x,
                y_heading=hp.y,
                z=z,
                cos_yaw=prob.cos_yaw,
                sin_yaw=prob.sin_yaw,
                trip=trip.kind,
            )
        if trip.kind is TripKind.KNEE:
            hp = knee_trip(c, pr.knee_trip_speed_frac)
        else:
            other = trip.other_leg
            p_other = None
            if other is not None and other in stance:
                p_other = stance[other]
            elif other is not None and other in planned:
                p_other = planned[other].p_touchdown
            side = float(self._side[leg])
            if p_other is None:
                y_other = c.p0[1] - side * pr.keepout_radius_m
            else:
                y_other = _heading(p_other, prob.cos_yaw, prob.sin_yaw)[1]
            if trip.kind is TripKind.SELF_CROSSED:
                hp = disentangle(c, y_other + side * (pr.keepout_radius_m + pr.disentangle_margin_m))
            else:
                away = 1.0 if c.p0[1] >= y_other else -1.0
                hp = side_step(c, c.p0[1] + away * pr.disentangle_margin_m)
        v = self.analyzer.analyze(prob, hp, undesirability_h(hp, pr))
        if v.tier == Tier.VIOLATES_CONSTRAINTS:
            v.tier = Tier.DEFAULT
        return self._finish(prob, req, _Choice(hp, v, 1), trip=trip.kind)


def _terrain_of(ground: GroundHeightFn) -> object:
    """The object behind a ground height function: a map's bound method (a new object on every access) by its map,
    which stays one object until the map is updated."""
    return getattr(ground, "__self__", ground)


# the tiers of a plan that meets the terrain: planned again (SwingParams.rise_over_boxes)
_TERRAIN_TIERS = (Tier.TERRAIN_COLLISION, Tier.CLIFF_SCRAPING)


def _could_beat(opt: tuple[int, tuple[float, ...]], best: tuple[int, tuple[float, ...]]) -> bool:
    """Simple analysis pruning: can a candidate whose best case is ``opt`` still beat ``best``?"""
    if opt[0] != best[0]:
        return opt[0] < best[0]
    if opt[0] in (Tier.SUCCESS, Tier.XY_SUCCESS_Z_IMPOSSIBLE, Tier.XY_CANT_REACH):
        return opt[1] < best[1]  # these keys are exact after the simple analysis
    return True
