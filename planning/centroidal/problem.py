"""The solver-facing centroidal problem: a time grid, contact phases, the measured state, targets and weights.

Frames and units: ``world`` is the maneuver frame (x forward, y left, z up; meters, seconds, newtons, radians).
Legs are indexed 0..3 in the order FL, FR, RL, RR. Forces are the forces the ground applies to the feet.

A ``ContactPhase`` is one stance of one leg: nominal touchdown and liftoff times, the nominal contact point, and
what the maneuver lets the solver change (touchdown time and liftoff time within windows, touchdown place within a
radius or a polygon). The problem is stateful (it holds the measured state) and is built anew every tick; the
maneuver it comes from is not. ``reconcile_contacts`` makes the measured contacts win over the plan (a late or an
early touchdown) before the time grid is made.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Literal

import numpy as np

from planning.centroidal import _so3

if TYPE_CHECKING:
    from planning.robot import RobotModel

N_LEGS = 4
LEG_NAMES: tuple[str, str, str, str] = ("FL", "FR", "RL", "RR")
GRAVITY = np.array([0.0, 0.0, -9.81])


class ProblemError(ValueError):
    """A centroidal problem that cannot be solved as given; the message names the field and the reason."""


_Z_UP = np.array([0.0, 0.0, 1.0])  # the default contact normal, shared by every phase (read-only)
_Z_UP.setflags(write=False)


def _arr(x: object, shape: tuple[int, ...], name: str) -> np.ndarray:
    a = np.array(x, dtype=float)
    if a.shape != shape:
        raise ProblemError(f"{name}: expected shape {shape}, got {a.shape}")
    a.setflags(write=False)
    return a


# --------------------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class BodyModel:
    """The single rigid body and the leg limits the solver uses.

    mass_kg: total mass. inertia_body: (3,3) kg·m², about the CoM, body frame. p_body_hip: (4,3) m, hip
    (abduction joint) positions in the body frame. leg_length_min_m / leg_length_max_m: limits on the distance
    from the hip to the foot center (the circle of FIG. 2E). foot_radius_m: the foot center sits this far from
    the contact point along the contact normal. foot_offset_body_xy: (4,2) m, the nominal horizontal offset of
    each foot from its hip in the body frame (the "hip over foot" cost pulls toward it). p_body_com: (3,) m,
    the composite CoM in the trunk frame at nominal stance. The solver's body is the CoM: p_body_hip is measured
    from it, and a state's p_world is the CoM's (p_com = p_trunk + R p_body_com). hip_x_range_m: the hip constraint, a pair of lines in the body's
    X–Z plane: the foot center's body-x offset from its hip, after tilting the body X–Z plane by hip_line_tilt_rad
    about body y, stays within this range (m); keeps the upper leg from over-rotating into the body.
    """

    mass_kg: float
    inertia_body: np.ndarray
    p_body_hip: np.ndarray
    leg_length_min_m: float
    leg_length_max_m: float
    foot_radius_m: float = 0.0
    hip_x_range_m: tuple[float, float] = (-0.45, 0.45)
    hip_line_tilt_rad: float = 0.0
    foot_offset_body_xy: np.ndarray = field(default_factory=lambda: np.zeros((4, 2)))
    p_body_com: np.ndarray = field(default_factory=lambda: np.zeros(3))

    def __post_init__(self) -> None:
        object.__setattr__(self, "inertia_body", _arr(self.inertia_body, (3, 3), "model.inertia_body"))
        object.__setattr__(self, "p_body_hip", _arr(self.p_body_hip, (4, 3), "model.p_body_hip"))
        object.__setattr__(
            self, "foot_offset_body_xy", _arr(self.foot_offset_body_xy, (4, 2), "model.foot_offset_body_xy")
        )
        object.__setattr__(self, "p_body_com", _arr(self.p_body_com, (3,), "model.p_body_com"))

    @classmethod
    def from_robot(
        cls, robot: RobotModel, reach_margin: float = 0.95, min_fraction: float = 0.4
    ) -> BodyModel:
        """Returns the body model of a RobotModel: its mass, composite inertia, hips and leg reach.

        The robot's leg lengths are sagittal (hip-flexion joint to foot); the abduction offset is added back to
        get hip-to-foot distances. reach_margin scales the maximum so the knee stays off its singular stretch;
        the minimum is min_fraction of that maximum (at least the robot's own), which keeps the knee from folding
        the foot up under the hip.
        """
        a = float(np.max(np.abs(robot.abd_offset))) if hasattr(robot, "abd_offset") else 0.0
        lmax = math.hypot(float(robot.max_leg_length_m), a) * reach_margin
        lmin = max(math.hypot(float(robot.min_leg_length_m), a), min_fraction * lmax)
        com = _com_offset_body(robot)
        return cls(
            mass_kg=float(robot.mass_kg),
            inertia_body=np.asarray(robot.inertia_body, dtype=float),
            p_body_hip=np.asarray(robot.p_body_hip, dtype=float) - com,
            p_body_com=com,
            leg_length_min_m=lmin,
            leg_length_max_m=lmax,
            foot_radius_m=float(robot.foot_radius_m),
            foot_offset_body_xy=np.asarray(robot.nominal_foot_body, dtype=float)[:, :2]
            - np.asarray(robot.p_body_hip, dtype=float)[:, :2],
        )


def _com_offset_body(robot: RobotModel) -> np.ndarray:
    """Returns the composite CoM (3,) m in the trunk frame at the robot's nominal stance (zeros if unknown)."""
    try:
        import mujoco

        m = robot.model
        d = mujoco.MjData(m)
        d.qpos[:] = robot.home_qpos()
        mujoco.mj_kinematics(m, d)
        mujoco.mj_comPos(m, d)
        R = d.xmat[robot.body_id].reshape(3, 3)
        return np.asarray(R.T @ (d.subtree_com[robot.body_id] - d.xpos[robot.body_id]), dtype=float)
    except (AttributeError, TypeError, ValueError):
        return np.zeros(3)


@dataclass(frozen=True)
class BodyState:
    """The measured (or planned) body state at time t (s): CoM position and velocity, orientation, ω (world).

    p_world is the CoM (see BodyModel.p_body_com for the trunk origin's offset)."""

    t: float
    p_world: np.ndarray
    v_world: np.ndarray
    R_world_body: np.ndarray
    omega_world: np.ndarray

    def __post_init__(self) -> None:
        object.__setattr__(self, "p_world", _arr(self.p_world, (3,), "initial.p_world"))
        object.__setattr__(self, "v_world", _arr(self.v_world, (3,), "initial.v_world"))
        object.__setattr__(self, "R_world_body", _arr(self.R_world_body, (3, 3), "initial.R_world_body"))
        object.__setattr__(self, "omega_world", _arr(self.omega_world, (3,), "initial.omega_world"))


@dataclass(frozen=True)
class ContactPhase:
    """One stance of one leg. Times in seconds; a phase already down has t_touchdown <= t_now.

    t_liftoff may be math.inf (stays down past the horizon). p_world_foot: nominal contact point (3,).
    touchdown_window_s / liftoff_window_s: (earlier, later) shifts the solver may make, seconds, each >= 0.
    adjust_radius_m: the solver may move the touchdown within this distance (0: fixed). region_xy: (M,2) convex
    polygon (world x, y, counter-clockwise) the touchdown must stay in, or None. normal: contact normal (3,).
    key: identity across ticks (warm start); defaults to leg and nominal touchdown time.
    """

    leg: int
    t_touchdown: float
    t_liftoff: float
    p_world_foot: np.ndarray
    touchdown_window_s: tuple[float, float] = (0.0, 0.0)
    liftoff_window_s: tuple[float, float] = (0.0, 0.0)
    adjust_radius_m: float = 0.0
    region_xy: np.ndarray | None = None
    normal: np.ndarray = field(default_factory=lambda: _Z_UP)
    key: str = ""

    def __post_init__(self) -> None:
        object.__setattr__(self, "p_world_foot", _arr(self.p_world_foot, (3,), "phase.p_world_foot"))
        if self.normal is not _Z_UP:  # the default (shared, read-only) is a unit vector already
            n = np.array(self.normal, dtype=float).reshape(-1)
            if n.shape != (3,) or not np.all(np.isfinite(n)) or np.linalg.norm(n) < 1e-9:
                raise ProblemError(f"phase {LEG_NAMES[self.leg % 4]}: normal must be a nonzero 3-vector")
            n = n / np.linalg.norm(n)
            n.setflags(write=False)
            object.__setattr__(self, "normal", n)
        if self.region_xy is not None:
            reg = np.array(self.region_xy, dtype=float)
            if reg.ndim != 2 or reg.shape[1] != 2:
                raise ProblemError(f"phase {LEG_NAMES[self.leg % 4]}: region_xy must be (M,2)")
            reg.setflags(write=False)
            object.__setattr__(self, "region_xy", reg)
        if not self.key:
            object.__setattr__(self, "key", f"{LEG_NAMES[self.leg % 4]}@{self.t_touchdown:.4f}")

    @property
    def adjustable_place(self) -> bool:
        return self.adjust_radius_m > 0.0 or self.region_xy is not None


@dataclass(frozen=True)
class BodyTargets:
    """Per-knot body targets and weights (K = number of knots).

    p_world (K,3) m, R_world_body (K,3,3); w_position (K,3) per m², w_orientation (K,3) per rad² (world
    axes); v_world (K,3) m/s and omega_world (K,3) rad/s are tracked with the weights' velocity terms.
    Keyframes are knots with large weights; the last is the final pose.
    """

    p_world: np.ndarray
    R_world_body: np.ndarray
    w_position: np.ndarray
    w_orientation: np.ndarray
    v_world: np.ndarray
    omega_world: np.ndarray

    @classmethod
    def hold(
        cls,
        n_knots: int,
        p_world: np.ndarray,
        R_world_body: np.ndarray,
        w_position: float | Sequence[float] = 100.0,
        w_orientation: float | Sequence[float] = 100.0,
    ) -> BodyTargets:
        """Returns targets that hold one pose at every knot with the same weights."""
        K = n_knots
        return cls(
            p_world=np.tile(np.asarray(p_world, dtype=float), (K, 1)),
            R_world_body=np.tile(np.asarray(R_world_body, dtype=float), (K, 1, 1)),
            w_position=np.tile(np.broadcast_to(np.asarray(w_position, dtype=float), (3,)), (K, 1)),
            w_orientation=np.tile(np.broadcast_to(np.asarray(w_orientation, dtype=float), (3,)), (K, 1)),
            v_world=np.zeros((K, 3)),
            omega_world=np.zeros((K, 3)),
        )

    @classmethod
    def from_keyframes(
        cls,
        t_knots: np.ndarray,
        start: BodyState,
        keyframes: Sequence[tuple[float, np.ndarray, np.ndarray, float]],
        running_weight: float = 20.0,
        keyframe_radius_s: float = 0.05,
    ) -> BodyTargets:
        """Returns targets interpolated between keyframes (t, p_world (3,), R_world_body (3,3), weight).

        Positions interpolate linearly and orientations along the geodesic from the state at ``start`` through
        the keyframes; after the last keyframe its pose holds. Velocity targets follow the interpolated path.
        Every knot gets ``running_weight``; knots within keyframe_radius_s of a keyframe (or the nearest knot) get
        the keyframe's weight on top.
        """
        t = np.asarray(t_knots, dtype=float)
        K = t.size
        kf = sorted(keyframes, key=lambda k: k[0])
        times = np.array([start.t] + [k[0] for k in kf])
        ps = np.array([start.p_world] + [np.asarray(k[1], dtype=float) for k in kf])
        Rs = np.array([start.R_world_body] + [np.asarray(k[2], dtype=float) for k in kf])
        p = np.empty((K, 3))
        R = np.empty((K, 3, 3))
        for j in range(K):
            i = int(np.searchsorted(times, t[j], side="right")) - 1
            if i >= len(times) - 1:
                p[j], R[j] = ps[-1], Rs[-1]
            elif i < 0:
                p[j], R[j] = ps[0], Rs[0]
            else:
                a = (t[j] - times[i]) / max(times[i + 1] - times[i], 1e-9)
                p[j] = (1 - a) * ps[i] + a * ps[i + 1]
                R[j] = _so3.interpolate(Rs[i], Rs[i + 1], np.asarray(a))
        w = np.full(K, running_weight)
        for tk, _, _, wk in kf:
            near = np.abs(t - tk) <= keyframe_radius_s
            if not near.any() and t[0] <= tk <= t[-1]:
                near[int(np.argmin(np.abs(t - tk)))] = True
            w[near] += wk
        W = np.repeat(w[:, None], 3, axis=1)
        v = np.zeros((K, 3))
        om = np.zeros((K, 3))
        if K > 1:
            h = np.maximum(np.diff(t), 1e-9)[:, None]
            v[:-1] = np.diff(p, axis=0) / h
            om[:-1] = _so3.log(R[1:] @ np.swapaxes(R[:-1], -1, -2)) / h
            v[-1], om[-1] = v[-2], om[-2]
        return cls(p, R, W, W.copy(), v, om)


@dataclass(frozen=True)
class Objective:
    """A custom objective over [t_start, t_end] (s): maximize_height (CoM z) or lean (CoM along direction_xy).

    weight: per meter per second (a linear reward integrated over the window).
    """

    kind: Literal["maximize_height", "lean"]
    t_start: float
    t_end: float
    weight: float
    direction_xy: tuple[float, float] = (1.0, 0.0)


@dataclass(frozen=True)
class CostWeights:
    """Cost weights; running terms are integrated over time (× seconds).

    force: per N²·s on every contact force. velocity: per (m/s)²·s on v - v_target. angular_velocity: per
    (rad/s)²·s on ω - ω_target. touchdown_time: per s² of timing shift (touchdown and liftoff). touchdown_position:
    per m² of touchdown shift. hip_over_foot: per m²·s on the horizontal hip-to-foot offset of stance legs beyond
    the nominal stance offset. contact_regularization: tiny quadratic on the relaxed contact variables (keeps the
    QP strictly convex).
    """

    force: float = 2e-5
    velocity: float = 2.0
    angular_velocity: float = 1.0
    touchdown_time: float = 50.0
    touchdown_position: float = 100.0
    hip_over_foot: float = 1.0
    contact_regularization: float = 1e-3


@dataclass(frozen=True)
class CentroidalProblem:
    """Everything one solve needs. t_knots (K,) s, strictly increasing, t_knots[0] = initial.t.

    phases: stance phases of all legs intersecting the horizon. mu: friction coefficient. fz_min_N / fz_max_N:
    normal force bounds on stance legs (fz_min > 0 keeps a little load on every stance foot). objectives: custom
    costs. gravity: (3,) m/s².
    """

    t_knots: np.ndarray
    initial: BodyState
    phases: tuple[ContactPhase, ...]
    targets: BodyTargets
    model: BodyModel
    mu: float = 0.6
    fz_min_N: float = 10.0
    fz_max_N: float = 600.0
    weights: CostWeights = field(default_factory=CostWeights)
    objectives: tuple[Objective, ...] = ()
    gravity: np.ndarray = field(default_factory=lambda: GRAVITY.copy())

    def __post_init__(self) -> None:
        t = np.array(self.t_knots, dtype=float).reshape(-1)
        t.setflags(write=False)
        object.__setattr__(self, "t_knots", t)
        object.__setattr__(self, "phases", tuple(self.phases))
        object.__setattr__(self, "objectives", tuple(self.objectives))
        object.__setattr__(self, "gravity", _arr(self.gravity, (3,), "gravity"))

    @property
    def n_knots(self) -> int:
        return int(self.t_knots.size)

    @property
    def contact(self) -> np.ndarray:
        """Returns the nominal contact flags (N,4) bool of the N intervals (True: the leg is in stance)."""
        tm = 0.5 * (self.t_knots[:-1] + self.t_knots[1:])
        out = np.zeros((tm.size, N_LEGS), dtype=bool)
        for ph in self.phases:
            out[:, ph.leg] |= (tm >= ph.t_touchdown) & (tm < ph.t_liftoff)
        return out

    def validate(self) -> list[str]:
        """Returns every problem found as "field: reason" (empty when the problem is well formed)."""
        out: list[str] = []
        t = self.t_knots
        if t.size < 2:
            out.append("t_knots: needs at least two knots")
        elif not np.all(np.isfinite(t)):
            out.append("t_knots: must be finite")
        elif np.any(np.diff(t) <= 0.0):
            out.append("t_knots: must be strictly increasing")
        elif abs(t[0] - self.initial.t) > 1e-6:
            out.append(f"t_knots: starts at {t[0]:.4f} s but the initial state is at {self.initial.t:.4f} s")
        s = self.initial
        for name in ("p_world", "v_world", "R_world_body", "omega_world"):
            if not np.all(np.isfinite(getattr(s, name))):
                out.append(f"initial.{name}: must be finite")
        R = s.R_world_body
        if np.all(np.isfinite(R)) and (np.linalg.norm(R.T @ R - np.eye(3)) > 1e-3 or np.linalg.det(R) < 0.0):
            out.append("initial.R_world_body: not a rotation matrix")
        m = self.model
        if _checked_models.get(id(m)) is not m:
            out.extend(_validate_model(m))
        out.extend(self._validate_rest())
        return out

    def _validate_rest(self) -> list[str]:
        out: list[str] = []
        if not (self.mu > 0.0 and math.isfinite(self.mu)):
            out.append(f"mu: must be positive, got {self.mu}")
        if not (0.0 <= self.fz_min_N <= self.fz_max_N and math.isfinite(self.fz_max_N)):
            out.append(f"fz_min_N/fz_max_N: need 0 <= fz_min <= fz_max, got {self.fz_min_N}, {self.fz_max_N}")
        out.extend(self._validate_targets())
        out.extend(self._validate_phases())
        for i, ob in enumerate(self.objectives):
            if ob.kind not in ("maximize_height", "lean"):
                out.append(f"objectives[{i}].kind: unknown objective {ob.kind!r} (maximize_height, lean)")
            if not (ob.t_start <= ob.t_end) or not math.isfinite(ob.weight):
                out.append(f"objectives[{i}]: need t_start <= t_end and a finite weight")
            if ob.kind == "lean" and math.hypot(*ob.direction_xy) < 1e-9:
                out.append(f"objectives[{i}].direction_xy: must be nonzero")
        w = self.weights
        for name in w.__dataclass_fields__:
            v = getattr(w, name)
            if not (math.isfinite(v) and v >= 0.0):
                out.append(f"weights.{name}: must be finite and >= 0, got {v}")
        return out

    def _validate_targets(self) -> list[str]:
        out: list[str] = []
        K = self.t_knots.size
        tg = self.targets
        shapes = {
            "p_world": (K, 3),
            "R_world_body": (K, 3, 3),
            "w_position": (K, 3),
            "w_orientation": (K, 3),
            "v_world": (K, 3),
            "omega_world": (K, 3),
        }
        for name, shape in shapes.items():
            a = np.asarray(getattr(tg, name))
            if a.shape != shape:
                out.append(f"targets.{name}: expected shape {shape}, got {a.shape}")
            elif not np.all(np.isfinite(a)):
                out.append(f"targets.{name}: must be finite")
            elif name.startswith("w_") and np.any(a < 0.0):
                out.append(f"targets.{name}: weights must be >= 0")
        return out

    def _validate_phases(self) -> list[str]:
        # Fast path: every phase's numbers checked at once; the detailed pass only runs when something is off.
        ph = self.phases
        if not ph:
            return []
        try:
            a = np.array(
                [(p.leg, p.t_touchdown, p.t_liftoff, *p.touchdown_window_s, *p.liftoff_window_s, p.adjust_radius_m,
                  *p.p_world_foot) for p in ph],
                dtype=float,
            )  # fmt: skip
        except (TypeError, ValueError):
            return self._validate_phases_detailed()
        if a.ndim == 2 and a.shape[1] == 11 and not any(p.region_xy is not None for p in ph):
            legs = a[:, 0]
            ok = (
                np.all((legs >= 0.0) & (legs <= 3.0) & (legs == np.floor(legs)))  # 0..3 (np.isin is slow)
                and np.all(np.isfinite(a[:, 1]))
                and not np.any(np.isnan(a[:, 2]))
                and np.all(a[:, 1] < a[:, 2])
                and np.all(np.isfinite(a[:, 3:]))
                and np.all(a[:, 3:8] >= 0.0)
            )
            if ok:
                order = np.lexsort((a[:, 1], legs))
                b = a[order]
                same = b[1:, 0] == b[:-1, 0]
                if not np.any(same & (b[:-1, 2] > b[1:, 1] + 1e-9)):
                    return []
        return self._validate_phases_detailed()

    def _validate_phases_detailed(self) -> list[str]:
        out: list[str] = []
        by_leg: dict[int, list[tuple[int, ContactPhase]]] = {}
        for j, ph in enumerate(self.phases):
            where = f"phases[{j}]"
            if ph.leg not in range(N_LEGS):
                out.append(f"{where}.leg: must be 0..3 (FL, FR, RL, RR), got {ph.leg}")
                continue
            name = f"{where} ({LEG_NAMES[ph.leg]})"
            if not (math.isfinite(ph.t_touchdown) and not math.isnan(ph.t_liftoff)):
                out.append(f"{name}: touchdown time must be finite")
            elif not ph.t_touchdown < ph.t_liftoff:
                out.append(
                    f"{name}: liftoff at {ph.t_liftoff:.3f} s is not after touchdown at {ph.t_touchdown:.3f} s"
                )
            if not np.all(np.isfinite(ph.p_world_foot)):
                out.append(f"{name}.p_world_foot: must be finite")
            for wname in ("touchdown_window_s", "liftoff_window_s"):
                win = getattr(ph, wname)
                if len(win) != 2 or not all(math.isfinite(x) and x >= 0.0 for x in win):
                    out.append(f"{name}.{wname}: needs two finite shifts >= 0 (earlier, later), got {win}")
            if not (ph.adjust_radius_m >= 0.0 and math.isfinite(ph.adjust_radius_m)):
                out.append(f"{name}.adjust_radius_m: must be >= 0")
            if ph.region_xy is not None:
                msg = _polygon_problem(ph.region_xy)
                if msg:
                    out.append(f"{name}.region_xy: {msg}")
                elif not _inside_polygon(ph.region_xy, ph.p_world_foot[:2], ph.adjust_radius_m):
                    out.append(
                        f"{name}.region_xy: no point of it is within the adjust radius of the nominal touchdown"
                    )
            by_leg.setdefault(ph.leg, []).append((j, ph))
        for leg, lst in by_leg.items():
            lst.sort(key=lambda x: x[1].t_touchdown)
            # Only the nominal stances must not overlap; windows that do are shared out by the schedule.
            for (ja, a), (jb, b) in zip(lst, lst[1:], strict=False):
                if a.t_liftoff > b.t_touchdown + 1e-9:
                    out.append(
                        f"phases[{jb}] ({LEG_NAMES[leg]}): touchdown at {b.t_touchdown:.3f} s overlaps the stance "
                        f"of phases[{ja}] (liftoff at {a.t_liftoff:.3f} s)"
                    )
        return out


_checked_models: dict[int, BodyModel] = {}  # models found valid (frozen: checked once, by identity)


def _validate_model(m: BodyModel) -> list[str]:
    out: list[str] = []
    if not (m.mass_kg > 0.0 and math.isfinite(m.mass_kg)):
        out.append(f"model.mass_kg: must be positive, got {m.mass_kg}")
    if not np.all(np.isfinite(m.inertia_body)) or np.any(
        np.linalg.eigvalsh(0.5 * (m.inertia_body + m.inertia_body.T)) <= 0
    ):
        out.append("model.inertia_body: must be symmetric positive definite")
    if not (0.0 <= m.leg_length_min_m < m.leg_length_max_m):
        out.append(
            f"model.leg_length_min_m/max_m: need 0 <= min < max, got {m.leg_length_min_m}, {m.leg_length_max_m}"
        )
    if not (m.hip_x_range_m[0] < m.hip_x_range_m[1]):
        out.append(f"model.hip_x_range_m: need lo < hi, got {m.hip_x_range_m}")
    if not (np.all(np.isfinite(m.p_body_hip)) and np.all(np.isfinite(m.foot_offset_body_xy))):
        out.append("model.p_body_hip / foot_offset_body_xy: must be finite")
    if not out and len(_checked_models) < 64:
        _checked_models[id(m)] = m
    return out


def _polygon_problem(poly: np.ndarray) -> str:
    if poly.shape[0] < 3:
        return "needs at least 3 vertices"
    if not np.all(np.isfinite(poly)):
        return "must be finite"
    e = np.roll(poly, -1, axis=0) - poly
    cross = e[:, 0] * np.roll(e, -1, axis=0)[:, 1] - e[:, 1] * np.roll(e, -1, axis=0)[:, 0]
    if np.any(cross < -1e-12):
        return "must be convex and counter-clockwise"
    if np.sum(cross) <= 1e-12:
        return "has no area"
    return ""


def polygon_halfplanes(poly: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Returns (a (M,2), b (M,)) with the polygon = {x : a x <= b}, for a convex CCW polygon (M,2)."""
    e = np.roll(poly, -1, axis=0) - poly
    a = np.stack([e[:, 1], -e[:, 0]], axis=1)
    a /= np.linalg.norm(a, axis=1, keepdims=True)
    b = np.sum(a * poly, axis=1)
    return a, b


def _inside_polygon(poly: np.ndarray, xy: np.ndarray, radius: float) -> bool:
    """True when the disc of the given radius about xy meets the polygon (radius 0: xy inside)."""
    a, b = polygon_halfplanes(poly)
    if np.all(a @ xy <= b + 1e-9):
        return True
    # Distance from xy to the polygon: the nearest point on an edge.
    best = math.inf
    for i in range(poly.shape[0]):
        p0, p1 = poly[i], poly[(i + 1) % poly.shape[0]]
        d = p1 - p0
        s = float(np.clip(np.dot(xy - p0, d) / max(float(np.dot(d, d)), 1e-18), 0.0, 1.0))
        best = min(best, float(np.linalg.norm(p0 + s * d - xy)))
    return best <= radius + 1e-9


# --------------------------------------------------------------------------------------------------------------
def phase_event_times(phases: Sequence[ContactPhase]) -> np.ndarray:
    """Returns the times the grid must have knots at: nominal touchdowns and liftoffs and their window edges."""
    ts: list[float] = []
    for ph in phases:
        e1, l1 = ph.touchdown_window_s
        e2, l2 = ph.liftoff_window_s
        ts += [ph.t_touchdown - e1, ph.t_touchdown, ph.t_touchdown + l1]
        if math.isfinite(ph.t_liftoff):
            ts += [ph.t_liftoff - e2, ph.t_liftoff, ph.t_liftoff + l2]
    return np.unique(np.asarray(ts, dtype=float))


def reconcile_contacts(
    phases: Sequence[ContactPhase],
    t_now: float,
    contact_measured: np.ndarray,
    p_world_foot_measured: np.ndarray,
    touchdown_delay_s: float = 0.02,
) -> tuple[ContactPhase, ...]:
    """Returns the phases made consistent with the measured contacts: the measured state wins over the plan.

    contact_measured: (4,) bool, which feet are down now. p_world_foot_measured: (4,3) their contact points.
    - A foot that is down where the plan has it down: the phase keeps going from where the foot actually is,
      and its place can no longer move.
    - A foot that is down where the plan has it in the air: an early touchdown if the next phase's touchdown is
      nearer than the last liftoff (that phase starts now, at the measured place), else a late liftoff (the plan
      keeps it in the air: the swing controller is about to lift it, and the solver must not lean on it).
    - A foot that is in the air where the plan has it down: a late touchdown if the phase began more recently
      than it ends (its touchdown moves to t_now + touchdown_delay_s, keeping what is left of its late window),
      else an early liftoff (the phase ends now).
    """
    contact_measured = np.asarray(contact_measured, dtype=bool).reshape(4)
    pm = np.asarray(p_world_foot_measured, dtype=float).reshape(4, 3)
    out: list[ContactPhase] = []
    by_leg: dict[int, list[ContactPhase]] = {i: [] for i in range(N_LEGS)}
    for ph in phases:
        by_leg[ph.leg].append(ph)
    for leg in range(N_LEGS):
        lst = sorted(by_leg[leg], key=lambda p: p.t_touchdown)
        cur = next((j for j, p in enumerate(lst) if p.t_touchdown <= t_now < p.t_liftoff), None)
        if contact_measured[leg]:
            if cur is not None:
                p = lst[cur]
                lst[cur] = replace(p, p_world_foot=pm[leg], adjust_radius_m=0.0, region_xy=None)
            else:
                nxt = next((j for j, p in enumerate(lst) if p.t_touchdown > t_now), None)
                prev = max((p.t_liftoff for p in lst if p.t_liftoff <= t_now), default=-math.inf)
                if nxt is not None and lst[nxt].t_touchdown - t_now < t_now - prev:
                    p = lst[nxt]
                    lst[nxt] = replace(
                        p,
                        t_touchdown=t_now,
                        touchdown_window_s=(0.0, 0.0),
                        p_world_foot=pm[leg],
                        adjust_radius_m=0.0,
                        region_xy=None,
                        key=p.key,
                    )
        elif cur is not None:
            p = lst[cur]
            if t_now - p.t_touchdown < p.t_liftoff - t_now:
                late_left = max(0.0, p.t_touchdown + p.touchdown_window_s[1] - t_now - touchdown_delay_s)
                t_td = t_now + touchdown_delay_s
                if t_td >= p.t_liftoff:
                    lst.pop(cur)
                else:
                    lst[cur] = replace(p, t_touchdown=t_td, touchdown_window_s=(0.0, late_left), key=p.key)
            else:
                lst[cur] = replace(p, t_liftoff=t_now, liftoff_window_s=(0.0, 0.0), key=p.key)
        out.extend(lst)
    return tuple(out)
