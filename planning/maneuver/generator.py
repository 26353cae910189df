"""Problem generator (dynamic-planning-controller seed): a stateless maneuver + the measured state → the stateful,
solver-facing centroidal problem, regenerated every tick with a horizon that slides as the maneuver advances.

The maneuver's swings become per-leg stance phases (with their adjust windows); its body reference is sampled at the
knots of a time grid that is fine near now, coarse further out and has a boundary at every event; the measured
contacts win over the plan (a late or an early touchdown is taken into the problem). Hints (passive maneuvers beside
the active one, planning.maneuver.hints) arrive already folded into the body reference.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from planning.centroidal import _so3
from planning.centroidal.problem import (
    BodyModel,
    BodyState,
    BodyTargets,
    CentroidalProblem,
    ContactPhase,
    CostWeights,
    Objective,
    phase_event_times,
    reconcile_contacts,
)
from planning.centroidal.timegrid import make_time_grid
from planning.geometry import rpy_to_R
from planning.maneuver.body import BodyReference
from planning.maneuver.expand import Schedule
from planning.maneuver.frame import PlanFrame
from planning.maneuver.hints import HintedBody
from planning.maneuver.spec import Lean, Maneuver, MaximizeHeight, Weights
from planning.robot import RobotModel

_DEFAULT_WEIGHTS = Weights.model_validate({})


@dataclass(frozen=True)
class GeneratorParams:
    """Horizon and grid of the generated problems, and how maneuver weights map onto the solver's costs."""

    horizon_s: float = 1.0  # s, how far ahead each problem looks
    base_dt_s: float | None = 0.05  # s, the finest step (None: derived from the shortest gap between events)
    pattern: tuple[tuple[int, int], ...] = ((4, 1), (4, 2), (4, 3))  # (count, multiple of base_dt), then last
    max_knots: int = 24
    running_weight: float = (
        20.0  # per m² (and rad²) at every knot; keyframes add their own weight × pose_scale
    )
    keyframe_scale: float = 100.0  # a keyframe weight of 1.0 is worth this many running weights
    keyframe_radius_s: float = 0.06  # knots this close to a keyframe carry its weight
    fz_min_n: float = 8.0
    fz_max_n: float = 600.0
    # per s² of touchdown/liftoff shift at the maneuver's default weight: high enough that the solver moves an
    # event only when the plan needs it (a shift of 30 ms costs about as much as 1 cm held for a second)
    touchdown_time_weight: float = 1000.0
    # Push recovery on four planted feet: when the measured capture point (CoM + v·√(h/g)) comes within
    # recovery_margin_m of the feet's support polygon edge (or leaves it), the problems look only
    # recovery_horizon_s ahead and the minimum normal force drops to recovery_fz_min_n (the feet on the far side
    # may unload while the body rolls back), until recovery_hold_s after the capture point is back inside. With the
    # full horizon the linearized plan of a body tipping past its feet diverges (no usable plan for ~0.3 s after a
    # 10 N·s sideways push on a 12.7 kg Go1; docs/robot-notes.md).
    recovery_margin_m: float = 0.01
    recovery_horizon_s: float = 0.5
    recovery_fz_min_n: float = 1.0
    recovery_hold_s: float = 0.3
    recovery_deviation_m: float = (
        0.05  # ... and only when it is this far from the plan's own capture point (a
    )
    # landing that the maneuver plans moving, a pronk-forward's, is no push)


class ProblemGenerator:
    """Builds the centroidal problem of one maneuver at any time from the measured state."""

    def __init__(
        self,
        maneuver: Maneuver,
        schedule: Schedule,
        body: BodyReference | HintedBody,
        robot: RobotModel,
        offset_world: np.ndarray | PlanFrame | None = None,
        params: GeneratorParams | None = None,
    ) -> None:
        self.maneuver = maneuver
        self.schedule = schedule
        self.body = body
        self.robot = robot
        self.params = p = params or GeneratorParams()
        # where the maneuver frame sits in the world (the start pose; a bare (3,) array: a translation)
        if isinstance(offset_world, PlanFrame):
            self.frame = offset_world
        else:
            o = np.zeros(3) if offset_world is None else np.asarray(offset_world, dtype=float)
            self.frame = PlanFrame(float(o[0]), float(o[1]), float(o[2]))
        self.offset = self.frame.t
        self.model = BodyModel.from_robot(robot)
        self.phases = self._phases()
        self.events = np.array(sorted({e.t for e in schedule.events()}))
        self.key_times = np.array([k.t for k in maneuver.body])
        self.key_weights = np.array([k.weight for k in maneuver.body])
        w = maneuver.weights or _DEFAULT_WEIGHTS
        d = CostWeights()
        self.weights = CostWeights(
            **{
                **d.__dict__,
                "force": d.force * w.force / _DEFAULT_WEIGHTS.force,
                "touchdown_time": p.touchdown_time_weight
                * w.touchdown_time
                / _DEFAULT_WEIGHTS.touchdown_time,
                "touchdown_position": d.touchdown_position
                * w.touchdown_position
                / _DEFAULT_WEIGHTS.touchdown_position,
                "hip_over_foot": d.hip_over_foot * w.hip_over_foot / _DEFAULT_WEIGHTS.hip_over_foot,
            }
        )
        self.pose_scale = w.pose / _DEFAULT_WEIGHTS.pose
        self.objectives = tuple(self._objectives())
        self.base_dt = p.base_dt_s
        self.recovering_until = -math.inf  # push recovery (see GeneratorParams) holds until this time
        self.recovery_ticks = 0  # problems built in push recovery

    # ---- static parts (built once) -----------------------------------------------------------------------------
    def _phases(self) -> tuple[ContactPhase, ...]:
        out: list[ContactPhase] = []
        sch = self.schedule
        for leg in range(4):
            t_down = -1.0
            p_down = self.frame.point(sch.p_start_foot[leg])
            normal = np.array([0.0, 0.0, 1.0])
            td_window = (0.0, 0.0)
            radius, region = 0.0, None
            for sw in sch.swings[leg]:
                lo = (sw.liftoff_adjust_s, sw.liftoff_adjust_s)
                out.append(
                    ContactPhase(
                        leg,
                        t_down,
                        sw.t_liftoff,
                        p_down,
                        td_window,
                        lo,
                        radius,
                        region,
                        normal,
                        key=f"{leg}@{t_down:.4f}",
                    )
                )
                t_down = sw.t_touchdown
                p_down = self.frame.point(sw.p_touchdown)
                normal = self.frame.vector(np.asarray(sw.normal, dtype=float))
                td_window = (sw.adjust.time_s, sw.adjust.time_s)
                radius = float(sw.adjust.radius_m or 0.0)
                region = None if sw.adjust.region_xy is None else self.frame.xy(sw.adjust.region_xy)
            out.append(
                ContactPhase(
                    leg,
                    t_down,
                    math.inf,
                    p_down,
                    td_window,
                    (0.0, 0.0),
                    radius,
                    region,
                    normal,
                    key=f"{leg}@{t_down:.4f}",
                )
            )
        return tuple(out)

    def _objectives(self) -> list[Objective]:
        out = []
        for o in self.maneuver.objectives or ():
            if isinstance(o, MaximizeHeight):
                out.append(Objective("maximize_height", o.t[0], o.t[1], o.weight))
            elif isinstance(o, Lean):
                d = o.direction
                dw = self.frame.direction_xy(np.array([float(d[0]), float(d[1])]))
                out.append(Objective("lean", o.t[0], o.t[1], o.weight, (float(dw[0]), float(dw[1]))))
        return out

    # ---- per tick --------------------------------------------------------------------------------------------
    def trunk_target(self, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Returns the trunk's target (p (3,), v (3,), R (3,3), ω (3,)) at t (hints included)."""
        p, v, rpy, omega = self.body.sample(t)
        f = self.frame
        return f.point(p), f.vector(v), f.rotation(rpy_to_R(rpy)), f.vector(omega)

    def problem_at(
        self,
        state: BodyState,
        contact_measured: np.ndarray | None = None,
        p_world_foot_measured: np.ndarray | None = None,
    ) -> CentroidalProblem:
        """Returns the problem for the tick at state.t (CoM state); measured contacts (4,) and points win."""
        pr = self.params
        t = state.t
        phases = self.phases
        if contact_measured is not None and p_world_foot_measured is not None:
            phases = reconcile_contacts(phases, t, contact_measured, p_world_foot_measured)
        recovering = contact_measured is not None and self._pushed_off_support(
            state, contact_measured, phases
        )
        if recovering:
            self.recovery_ticks += 1
        end = t + (pr.recovery_horizon_s if recovering else pr.horizon_s)
        phases = tuple(
            p
            for p in phases
            if p.t_liftoff + p.liftoff_window_s[1] > t and p.t_touchdown - p.touchdown_window_s[0] < end
        )
        grid = make_time_grid(t, phase_event_times(phases), end, self.base_dt, pr.pattern, pr.max_knots)
        return CentroidalProblem(
            t_knots=grid,
            initial=state,
            phases=phases,
            targets=self.targets(grid),
            model=self.model,
            mu=self.maneuver.friction,
            fz_min_N=pr.recovery_fz_min_n if recovering else pr.fz_min_n,
            fz_max_N=pr.fz_max_n,
            weights=self.weights,
            objectives=self.objectives,
        )

    def _pushed_off_support(
        self, state: BodyState, contact_measured: np.ndarray, phases: tuple[ContactPhase, ...]
    ) -> bool:
        """Whether the problem at state.t is one of a push recovery: four feet planted (measured and planned) and
        the capture point within recovery_margin_m of their polygon's edge or outside it, recovery_deviation_m away
        from the plan's (or held after that)."""
        t = state.t
        planted = [p for p in phases if p.t_touchdown <= t < p.t_liftoff]
        if not bool(np.all(contact_measured)) or len(planted) != 4:
            self.recovering_until = -math.inf
            return False
        feet = np.array([p.p_world_foot[:2] for p in planted])
        h = float(state.p_world[2] - np.mean([p.p_world_foot[2] for p in planted]))
        tc = math.sqrt(max(h, 1e-3) / 9.81)
        xi = state.p_world[:2] + state.v_world[:2] * tc
        if _inside_distance(feet, xi) < self.params.recovery_margin_m:
            p_ref, v_ref, R_ref, _ = self.trunk_target(t)
            xi_ref = (p_ref + R_ref @ self.model.p_body_com)[:2] + v_ref[:2] * tc
            if np.hypot(*(xi - xi_ref)) < self.params.recovery_deviation_m:
                return t < self.recovering_until
            self.recovering_until = t + self.params.recovery_hold_s
        return t < self.recovering_until

    def targets(self, grid: np.ndarray) -> BodyTargets:
        """Returns the per-knot CoM targets: the body reference sampled at the knots, weighted near keyframes."""
        K = grid.size
        p = np.empty((K, 3))
        v = np.empty((K, 3))
        R = np.empty((K, 3, 3))
        om = np.empty((K, 3))
        com = self.model.p_body_com
        for j, tj in enumerate(grid):
            pj, vj, Rj, wj = self.trunk_target(float(tj))
            p[j] = pj + Rj @ com
            v[j] = vj + _so3.cross(wj, Rj @ com)
            R[j] = Rj
            om[j] = wj
        w = np.full(K, self.params.running_weight * self.pose_scale)
        for tk, wk in zip(self.key_times, self.key_weights, strict=True):
            near = np.abs(grid - tk) <= self.params.keyframe_radius_s
            w[near] += wk * self.params.keyframe_scale * self.pose_scale
        if K and grid[-1] >= self.maneuver.duration - 1e-9:
            w[-1] += self.params.keyframe_scale * self.pose_scale  # the final pose
        W = np.repeat(w[:, None], 3, axis=1)
        return BodyTargets(p, R, W, W.copy(), v, om)


def _inside_distance(points: np.ndarray, q: np.ndarray) -> float:
    """Returns how far q (2,) lies inside the convex hull of a few points (K,2) (negative: outside), m."""
    c = points.mean(axis=0)
    ring = points[np.argsort(np.arctan2(points[:, 1] - c[1], points[:, 0] - c[0]))]
    d = math.inf
    for a, b in zip(ring, np.roll(ring, -1, axis=0), strict=True):
        e = b - a
        n = float(np.hypot(e[0], e[1]))
        if n > 1e-9:
            # counter-clockwise ring: a point on the left of an edge is inside
            d = min(d, float(e[0] * (q[1] - a[1]) - e[1] * (q[0] - a[0])) / n)
    return d
