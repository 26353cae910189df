"""The centroidal solver: one linearized QP a tick (real-time iteration), iterative cuts, integrated-solution check.

Each tick the nonlinear problem (single rigid body, contact force × moment arm products, rotations) is linearized
about the previous tick's solution resampled onto the new grid, which is also the QP's warm start. The QP was set
up once for ``CentroidalParams.max_knots`` with a fixed sparsity pattern (``_layout.Layout``); a tick only writes
values and bounds. Within a tick, nonlinear constraints the QP only approximates — the leg-length circle (FIG. 2E)
and the friction cone beyond its pyramid — are checked on the solution, their tangent planes written into reserved
rows, and the QP re-solved without re-linearizing. The solution's forces are then run through the nonlinear
discrete dynamics; the distance between that integrated trajectory and the QP's is ``linearization_error``.

Orientation: R_k = exp(θ_k) R̄_k with R̄_k the linearization point's orientation (at knot 0 the measured one), θ a
world-frame rotation vector; the QP's θ is small by construction and the next tick re-centres on the new solution.
Forces are scaled by m g / 4 inside the QP (so a standing leg carries about 1), positions stay in meters.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
import osqp

from planning.centroidal import _so3
from planning.centroidal._layout import Layout
from planning.centroidal._schedule import ContactSchedule, build_schedule
from planning.centroidal.dynamics import Linearization, linearize
from planning.centroidal.integrate import compare, integrate_plan
from planning.centroidal.problem import N_LEGS, BodyModel, CentroidalProblem

INF = 1e30
# The bound of a row that is switched off this tick (its A row is zeroed too). Finite, so that OSQP keeps counting
# the row as an inequality: OSQP's step size ρ is per row kind (free, inequality, equality), and a row changing
# kind refactors the KKT matrix on top of the refactorization the new A values already cost.
OFF = 1e20
_E_XY = np.array([[1.0, 0.0], [0.0, 1.0], [0.0, 0.0]])
_EYE3 = np.eye(3)
# OSQP status values (osqp.constant): 1 solved, 2 solved inaccurate, 3/4 primal infeasible, 5/6 dual infeasible,
# 7 max iterations, 8 time limit.
_STATUS_NAMES = {
    3: "infeasible",
    4: "infeasible",
    5: "unbounded",
    6: "unbounded",
    7: "max_iter",
    8: "max_iter",
}


@dataclass(frozen=True)
class CentroidalParams:
    """Solver settings.

    max_knots: the QP's size (knot times, so max_knots − 1 intervals); bigger problems fail, smaller are padded.
    size_fractions: smaller QPs set up beside it (fractions of max_knots); a tick uses the smallest that fits,
    so a short problem does not pay for padding (a padded knot costs about what a real one does in OSQP).
    max_adjustable_per_leg: foothold variables per leg (later adjustable touchdowns keep their nominal place).
    max_polygon_edges: rows reserved per foothold region. max_cut_rounds: re-solves per tick after adding
    tangent-plane cuts. leg_length_tol_m / cone_tol: violations below these (m; fraction of μ f_n) need no cut;
    nor does a friction excess under cone_tol_N newtons (lightly loaded feet).
    cut_margin_m: leg-length rows start active when the linearization point is this close to a limit.
    linearization_error_threshold_m: the integrated solution must stay this close (position m + orientation rad ×
    error_length_m) for ``ok``. time_budget_ms: a tick over it is not ``ok`` and adds no more cuts.
    timing_adjustment: let touchdown/liftoff times move within their windows. window_slack_m: inside a window a
    foot's leg-length and hip rows hold only once it is down (c = 1); with c = 0 they give way by this much (m)
    beyond what the linearization point already needs (a big-M relaxation, M (1 − c)).
    eps_abs / eps_rel / max_iter / rho / polish: OSQP settings. ADMM alone at 1e-4 can leave contact forces tens
    of newtons off the optimum (the forces' cost is tiny beside the tracking terms, so ADMM is slow along the
    force-distribution directions); polishing (a KKT solve on the guessed active set) makes them exact, and the
    rows are written so that active sets are not degenerate (a foot in the air has no active row at all).
    When polishing still fails, ADMM goes on from where it stopped to eps_fallback. scaling: OSQP's equilibration
    passes, redone on every matrix update (each pass is a sweep over P and A): 4 take the same ADMM iterations
    as OSQP's default 10 here, for about a third less update time. alpha: ADMM over-relaxation; warm-started
    from the previous tick, 1.4 needs about 15 iterations where OSQP's default 1.6 needs 20 (same solutions).
    max_tick_iterations / max_tick_solves: the work one tick may do, counted (so bounded alike on any machine and
    load): ADMM iterations over all its QP solves (cut rounds, whole schedules, the tight fallback) and the number
    of those solves; None: unbounded. A tick that runs out returns its last answer with the cuts it still needs
    ("cuts_unsatisfied", not ``ok``) or, with no answer at all, "max_iter"; the driver keeps the last good one.
    A cold start (no previous solution: the first tick, or after a solver error or reset) is not bounded.
    """

    max_knots: int = 24
    size_fractions: tuple[float, ...] = (0.65, 0.8, 0.9, 0.95)
    max_adjustable_per_leg: int = 2
    max_polygon_edges: int = 8
    max_cut_rounds: int = 3
    leg_length_tol_m: float = 0.003
    cone_tol: float = 0.01
    cone_tol_N: float = 1.0
    cut_margin_m: float = 0.01
    linearization_error_threshold_m: float = 0.02
    error_length_m: float = 0.35
    time_budget_ms: float = 10.0
    timing_adjustment: bool = True
    window_slack_m: float = 1.0
    eps_abs: float = 3e-5
    eps_rel: float = 3e-5
    eps_fallback: float = 1e-7
    max_iter: int = 4000
    rho: float = 0.1
    polish: bool = True
    scaling: int = 4
    alpha: float = 1.4
    max_tick_iterations: int | None = None
    max_tick_solves: int | None = None


@dataclass(frozen=True)
class AdjustedTouchdown:
    """A touchdown as planned: nominal and solved time (s) and contact point (world, m)."""

    leg: int
    key: str
    t_nominal: float
    t: float
    p_world_nominal: np.ndarray
    p_world: np.ndarray
    planted: bool


@dataclass(frozen=True)
class AdjustedLiftoff:
    """A liftoff as planned: nominal and solved time (s)."""

    leg: int
    key: str
    t_nominal: float
    t: float


@dataclass(frozen=True)
class CentroidalSolution:
    """One tick's answer. Knot arrays have K rows, interval arrays N = K − 1.

    status: "solved", or why not ("invalid_problem", "infeasible", "unbounded", "max_iter", "inaccurate",
    "cuts_unsatisfied", "linearization_error", "over_budget", "solver_error"). ok: the solution may drive the
    robot (solved, every cut satisfied, linearization error under threshold, within the time budget); when not,
    the arrays are still filled whenever the QP produced an answer (empty for failures before that).
    f_world: (N,4,3) N, constant over each interval. contact: (N,4) the relaxed contact variable c in [0,1].
    in_contact: (N,4) bool, the contact the plan uses (c >= 0.5 or a normal force above fz_min / 2).
    p_world_foot: (N,4,3) contact points (zeros for feet in the air). linearization_error: max over knots of
    |Δp| + error_length·|Δθ| (m) between the QP trajectory and the nonlinear rollout of its forces.
    cost: the QP's objective including its constant part (comparable between problems).
    """

    status: str
    ok: bool
    message: str
    t_knots: np.ndarray
    p_world: np.ndarray
    v_world: np.ndarray
    R_world_body: np.ndarray
    omega_world: np.ndarray
    f_world: np.ndarray
    contact: np.ndarray
    in_contact: np.ndarray
    p_world_foot: np.ndarray
    touchdowns: tuple[AdjustedTouchdown, ...]
    liftoffs: tuple[AdjustedLiftoff, ...]
    linearization_error: float
    orientation_error_rad: float
    cost: float
    qp_ms: float
    tick_ms: float
    qp_iterations: int
    cut_iterations: int
    n_cuts: int
    max_leg_length_violation_m: float
    max_cone_violation: float
    integrated: dict[str, np.ndarray] = field(default_factory=dict)

    @property
    def rpy(self) -> np.ndarray:
        """Returns roll, pitch, yaw (K,3) rad of the planned orientations."""
        return _so3.R_to_rpy(self.R_world_body)

    def force_at(self, t: float) -> np.ndarray:
        """Returns the planned contact forces (4,3) N at time t (s): the interval containing t, clamped."""
        if self.f_world.shape[0] == 0:
            return np.zeros((N_LEGS, 3))
        # np.clip on integers, in Python (a scalar np.clip costs more than the lookup; runs at 250 Hz)
        k = min(max(int(np.searchsorted(self.t_knots, t, side="right")) - 1, 0), self.f_world.shape[0] - 1)
        return self.f_world[k]


def _failure(status: str, message: str, t0: float, qp_ms: float = 0.0) -> CentroidalSolution:
    z = np.zeros((0, 3))
    return CentroidalSolution(
        status=status,
        ok=False,
        message=message,
        t_knots=np.zeros(0),
        p_world=z,
        v_world=z,
        R_world_body=np.zeros((0, 3, 3)),
        omega_world=z,
        f_world=np.zeros((0, N_LEGS, 3)),
        contact=np.zeros((0, N_LEGS)),
        in_contact=np.zeros((0, N_LEGS), dtype=bool),
        p_world_foot=np.zeros((0, N_LEGS, 3)),
        touchdowns=(),
        liftoffs=(),
        linearization_error=math.inf,
        orientation_error_rad=math.inf,
        cost=math.inf,
        qp_ms=qp_ms,
        tick_ms=(time.perf_counter() - t0) * 1e3,
        qp_iterations=0,
        cut_iterations=0,
        n_cuts=0,
        max_leg_length_violation_m=math.inf,
        max_cone_violation=math.inf,
    )


@dataclass(frozen=True)
class QPSnapshot:
    """The last QP exactly as solved (values in the layout's COO order), for reference solves and debugging."""

    P_x: np.ndarray
    A_x: np.ndarray
    q: np.ndarray
    l: np.ndarray
    u: np.ndarray
    K: int
    N: int
    force_scale: float
    layout: Layout
    x: np.ndarray | None


_C_WHOLE = 0.01  # a window's contact variable within this of 0 or 1 counts as whole
_MIN_SOLVE_ITERATIONS = 10  # a tick with fewer ADMM iterations left than this starts no further solve


@dataclass
class _Run:
    """One QP answer after its cut rounds: OSQP's result, the unpacked solution, the cut work, QP time (ms)."""

    res: Any
    sol: dict[str, np.ndarray]
    rounds: int
    n_cuts: int
    len_viol: float
    cone_viol: float
    t_qp: float
    snapshot: QPSnapshot | None


@dataclass
class _Previous:
    """The last solution, kept as the next tick's linearization point and warm start."""

    t: np.ndarray
    p: np.ndarray
    v: np.ndarray
    R: np.ndarray
    w: np.ndarray
    f: np.ndarray
    c: np.ndarray
    d_by_key: dict[str, np.ndarray]


@dataclass
class _Tick:
    """Per-tick arrays, padded to the layout's size (K_max knots, N_max intervals)."""

    pr: CentroidalProblem
    sch: ContactSchedule
    K: int
    N: int
    Fs: float
    dt: np.ndarray  # (Nmax,)
    p: np.ndarray  # (Kmax,3) linearization point ...
    v: np.ndarray
    R: np.ndarray  # (Kmax,3,3)
    w: np.ndarray
    f: np.ndarray  # (Nmax,4,3) N
    c: np.ndarray  # (Nmax,4)
    d: np.ndarray  # (4,S,2)
    slot: np.ndarray  # (Nmax,4) slot of the foot, -1 none
    var: np.ndarray  # (Nmax,4) foothold variable of the foot, -1 fixed or none
    feet: np.ndarray  # (4,P,3) contact points of the slots at the linearization point
    knot_slot: np.ndarray  # (Kmax-1,4) slot constraining knots 1..K-1
    air: np.ndarray  # (Nmax,4) bool, no foot can push (c_hi = 0): the force is out of every row, and 0
    t1: np.ndarray = field(default_factory=lambda: np.zeros(0))  # (Nmax,4,3) contact frames
    t2: np.ndarray = field(default_factory=lambda: np.zeros(0))
    n: np.ndarray = field(default_factory=lambda: np.zeros(0))
    hbar: np.ndarray = field(default_factory=lambda: np.zeros(0))  # (Kmax-1,4,3) R̄ p_body_hip
    foot_c: np.ndarray = field(default_factory=lambda: np.zeros(0))  # (Kmax-1,4,3) nominal foot centers
    cost_const: float = 0.0


def _interval_average(t_old: np.ndarray, x_old: np.ndarray, t_new: np.ndarray) -> np.ndarray:
    """Returns piecewise-constant values x_old (one per old interval) averaged over each new interval (clamped)."""
    shape = x_old.shape[1:]
    flat = x_old.reshape(x_old.shape[0], -1)
    cum = np.zeros((t_old.size, flat.shape[1]))
    np.cumsum(flat * (t_old[1:] - t_old[:-1])[:, None], axis=0, out=cum[1:])
    tc = np.clip(t_new, t_old[0], t_old[-1])
    j = np.clip(np.searchsorted(t_old, tc, side="right") - 1, 0, t_old.size - 2)
    integ = cum[j] + (tc - t_old[j])[:, None] * flat[j]  # ∫ x from t_old[0] to tc
    span = tc[1:] - tc[:-1]
    avg = (integ[1:] - integ[:-1]) / np.maximum(span, 1e-12)[:, None]
    # New intervals past the old horizon hold the last value.
    past = span < 1e-12
    if past.any():
        mids = 0.5 * (t_new[:-1] + t_new[1:])
        jk = np.clip(np.searchsorted(t_old, mids, side="right") - 1, 0, flat.shape[0] - 1)
        avg[past] = flat[jk[past]]
    dt_new = t_new[1:] - t_new[:-1]
    part = (span > 1e-12) & (span < dt_new - 1e-12)
    if part.any():  # partly past the old horizon: the rest at the last value
        dtn = dt_new[part]
        avg[part] = (avg[part] * span[part, None] + flat[-1] * (dtn - span[part])[:, None]) / dtn[:, None]
    return avg.reshape((t_new.size - 1, *shape))


def _pad_linearization(lz: Linearization, n_max: int) -> Linearization:
    """Returns the linearization extended to n_max intervals by zero-length ones (dt = 0: the state carries over,
    θ⁺ = θ and ω⁺ = ω; every other block is zero, or multiplied by dt where it is written)."""
    n = lz.Jth.shape[0]
    out = {}
    for name in lz.__dataclass_fields__:
        a = getattr(lz, name)
        b = np.zeros((n_max, *a.shape[1:]))
        b[:n] = a
        out[name] = b
    out["Jth"][n:] = _EYE3
    return Linearization(**out)


class _Instance:
    """One QP of a fixed size: layout, OSQP workspace (set up once), value buffers and cut state."""

    def __init__(self, n_knots: int, p: CentroidalParams) -> None:
        self.L = L = Layout(n_knots, p.max_adjustable_per_leg, p.max_polygon_edges)
        self.Ax = np.zeros(L.A_nnz)
        self.Px = np.zeros(L.P_nnz)
        self.q = np.zeros(L.n)
        self.l = np.full(L.m, -INF)
        self.u = np.full(L.m, INF)
        self.fr = np.zeros((L.N, N_LEGS, 8, 3))
        self.kin = (np.zeros((L.K - 1, N_LEGS, 2, 3)), np.zeros((L.K - 1, N_LEGS, 2, 3)))
        self.kd = np.zeros((L.K - 1, N_LEGS, 2, L.S, 2))
        self.cone_dir = np.zeros((L.N, N_LEGS, 2, 2))  # two remembered faces per interval and leg
        self.pyr_dir = np.zeros((L.N, N_LEGS, 2))
        self.cone_on = np.zeros((L.N, N_LEGS, 2), dtype=bool)
        self.len_dir = np.zeros((L.K - 1, N_LEGS, 3))
        self.len_on = np.zeros((L.K - 1, N_LEGS), dtype=bool)
        self.air = np.ones((L.N, N_LEGS), dtype=bool)
        # Kinematic rows of knots whose foot may be up (timing windows): relaxed by M (1 − c) of one interval.
        self.relax = np.zeros((L.K - 1, N_LEGS), dtype=bool)
        self.use_next = np.zeros((L.K - 1, N_LEGS), dtype=bool)  # c of the interval starting at the knot
        self.big_m = np.zeros((L.K - 1, N_LEGS, 2))  # per row: M, m
        self.side = np.ones((L.K - 1, N_LEGS, 2))  # +1: the row's upper bound is kept, −1: the lower
        # Blocks whose values never change are written once here; a tick writes the rest.
        for name, val in (("init", 1.0), ("pp1", 1.0), ("pp0", -1.0), ("vv1", 1.0), ("vv0", -1.0), ("tt1", 1.0),
                          ("ww1", 1.0), ("cb", 1.0), ("mo1", 1.0), ("mo0", -1.0), ("db", 1.0)):  # fmt: skip
            sl, shape = L.A_blocks[name]
            self.Ax[sl] = val
        # Each block's values as a view of its shape: a tick writes them by broadcasting, with no copies.
        self.A_view = {name: self.Ax[sl].reshape(shape) for name, (sl, shape) in L.A_blocks.items()}
        self.P_view = {name: self.Px[sl].reshape(shape) for name, (sl, shape) in L.P_blocks.items()}
        self.qp = osqp.OSQP()
        self.qp.setup(
            L.P,
            np.zeros(L.n),
            L.A,
            self.l,
            self.u,
            verbose=False,
            eps_abs=p.eps_abs,
            eps_rel=p.eps_rel,
            max_iter=p.max_iter,
            polishing=p.polish,
            warm_starting=True,
            rho=p.rho,
            check_termination=5,
            scaling=p.scaling,
            alpha=p.alpha,
        )


class CentroidalSolver:
    """Builds the QP once; ``solve(problem)`` runs one real-time iteration and returns a CentroidalSolution.

    robot: optional RobotModel; when given, ``default_model`` holds its BodyModel for building problems.
    """

    def __init__(self, params: CentroidalParams | None = None, robot: object | None = None) -> None:
        self.params = params or CentroidalParams()
        p = self.params
        if p.max_knots < 3:
            raise ValueError(f"CentroidalParams.max_knots must be >= 3, got {p.max_knots}")
        self.default_model = BodyModel.from_robot(robot) if robot is not None else None  # type: ignore[arg-type]
        sizes = sorted({max(3, math.ceil(p.max_knots * f - 1e-9)) for f in p.size_fractions} | {p.max_knots})
        self._instances = [_Instance(k, p) for k in sizes]
        self._bind(self._instances[-1])
        self._prev: _Previous | None = None
        # the work the current tick has left (max_tick_iterations, max_tick_solves), and its solves' max_iter
        self._iters_left: float = math.inf
        self._solves_left: float = math.inf
        self._max_iter_now = p.max_iter
        self._tick_iterations = 0
        self._loose: Any = None  # the last solve's answer at eps_abs when its polish failed (see _run_qp)
        self.last_snapshot: QPSnapshot | None = None
        self.last_info: list[Any] = []

    def _bind(self, inst: _Instance) -> None:
        """Points the tick's working arrays at one QP instance (the smallest that fits the problem)."""
        self._inst = inst
        self.L = inst.L
        self._qp = inst.qp
        self._Ax, self._Px, self._q, self._l, self._u = inst.Ax, inst.Px, inst.q, inst.l, inst.u
        self._fr, self._kin, self._kd = inst.fr, inst.kin, inst.kd
        self._cone_dir, self._pyr_dir, self._cone_on = inst.cone_dir, inst.pyr_dir, inst.cone_on
        self._len_dir, self._len_on, self._air = inst.len_dir, inst.len_on, inst.air
        self._relax, self._use_next = inst.relax, inst.use_next
        self._big_m, self._side = inst.big_m, inst.side

    # ----------------------------------------------------------------------------------------------------------
    def reset(self) -> None:
        """Forgets the previous solution: the next tick linearizes about a cold-start guess."""
        self._prev = None

    def solve(self, problem: CentroidalProblem) -> CentroidalSolution:
        """Returns the solution of one linearized QP (plus cuts) for the problem; never raises on bad problems."""
        t0 = time.perf_counter()
        try:
            msgs = problem.validate()
        except Exception as e:  # noqa: BLE001 - a malformed problem must come back as a failure, not a traceback
            return _failure("invalid_problem", f"problem: {e}", t0)
        if msgs:
            return _failure("invalid_problem", "; ".join(msgs), t0)
        if problem.n_knots > self.params.max_knots:
            return _failure(
                "invalid_problem",
                f"t_knots: {problem.n_knots} knots, the solver was built for at most {self.params.max_knots}",
                t0,
            )
        p = self.params
        sch = build_schedule(problem, p.max_adjustable_per_leg, p.max_polygon_edges, p.timing_adjustment)
        self._bind(next(i for i in self._instances if i.L.K >= problem.n_knots))
        if isinstance(sch, str):
            return _failure("invalid_problem", sch, t0)
        try:
            return self._solve(problem, sch, t0)
        except (FloatingPointError, np.linalg.LinAlgError, ValueError) as e:
            self._prev = None
            return _failure("solver_error", f"{type(e).__name__}: {e}", t0)

    # ----------------------------------------------------------------------------------------------------------
    def _tick_arrays(self, pr: CentroidalProblem, sch: ContactSchedule) -> _Tick:
        """Returns the linearization point (previous solution resampled, or a cold-start guess) and tick data."""
        L = self.L
        K = pr.n_knots
        N = K - 1
        t = pr.t_knots
        m = pr.model.mass_kg
        g = float(np.linalg.norm(pr.gravity))
        P = self._prev
        if P is None:
            p = pr.targets.p_world.copy()
            v = pr.targets.v_world.copy()
            R = pr.targets.R_world_body.copy()
            w = pr.targets.omega_world.copy()
            f = np.zeros((N, N_LEGS, 3))
            c = sch.c_lo.copy()
            d_prev: dict[str, np.ndarray] = {}
        else:
            # The previous plan read the way its model runs: constant acceleration within a step (p quadratic,
            # v and ω linear), geodesic orientation, and forces averaged over each new interval.
            j = np.clip(np.searchsorted(P.t, t, side="right") - 1, 0, P.t.size - 2)
            h = np.maximum(P.t[j + 1] - P.t[j], 1e-12)
            tau = np.clip(t - P.t[j], 0.0, h)
            a = tau / h
            ac = a[:, None]
            acc = (P.v[j + 1] - P.v[j]) / h[:, None]
            p = P.p[j] + tau[:, None] * P.v[j] + 0.5 * (tau * tau)[:, None] * acc
            v = (1 - ac) * P.v[j] + ac * P.v[j + 1]
            w = (1 - ac) * P.w[j] + ac * P.w[j + 1]
            R = _so3.interpolate(P.R[j], P.R[j + 1], a)
            fc = _interval_average(P.t, np.concatenate([P.f.reshape(-1, 12), P.c], axis=1), t)
            f = fc[:, :12].reshape(N, N_LEGS, 3)
            c = fc[:, 12:]
            d_prev = P.d_by_key
        s0 = pr.initial
        p[0], v[0], R[0], w[0] = s0.p_world, s0.v_world, s0.R_world_body, s0.omega_world
        # No force where there is no foot; a leg newly in stance starts with its share of the weight.
        f[sch.c_hi == 0.0] = 0.0
        c = np.clip(c, sch.c_lo, sch.c_hi)
        n_st = np.maximum((sch.c_lo > 0.5).sum(axis=1, keepdims=True), 1)
        fresh = (sch.c_lo > 0.5) & (np.abs(f[..., 2]) < 1e-9)
        f[..., 2] = np.where(fresh, m * g / n_st, f[..., 2])
        d = np.zeros((N_LEGS, L.S, 2))
        for i in range(N_LEGS):
            for sl in sch.slots[i]:
                if sl.var >= 0 and sl.phase.key in d_prev:
                    dx, dy = d_prev[sl.phase.key].tolist()
                    d[i, sl.var] = (min(max(dx, -sl.box), sl.box), min(max(dy, -sl.box), sl.box))
        # Pad to the layout's size: repeated last knot, zero-length intervals with no feet.
        Kmax, Nmax = L.K, L.N
        pad = Kmax - K

        def padk(x: np.ndarray) -> np.ndarray:
            return np.concatenate([x, np.repeat(x[-1:], pad, axis=0)]) if pad else x

        dt = np.zeros(Nmax)
        dt[:N] = t[1:] - t[:-1]
        fb = np.zeros((Nmax, N_LEGS, 3))
        fb[:N] = f
        cb = np.zeros((Nmax, N_LEGS))
        cb[:N] = c
        slot = np.full((Nmax, N_LEGS), -1, dtype=np.int64)
        slot[:N] = sch.slot
        legs = np.arange(N_LEGS)[None, :]
        var = np.where(slot >= 0, sch.var[legs, np.maximum(slot, 0)], -1)
        feet = sch.nom.copy()
        vi, vs = np.nonzero(sch.var >= 0)
        feet[vi, vs] += d[vi, sch.var[vi, vs]] @ _E_XY.T
        knot_slot = np.full((Kmax - 1, N_LEGS), -1, dtype=np.int64)
        knot_slot[: K - 1] = sch.knot_slot[1:]
        air = np.ones((Nmax, N_LEGS), dtype=bool)
        air[:N] = sch.c_hi == 0.0
        return _Tick(pr, sch, K, N, self._force_scale(pr), dt, padk(p), padk(v), padk(R), padk(w), fb, cb, d,
                     slot, var, feet, knot_slot, air)  # fmt: skip

    @staticmethod
    def _force_scale(pr: CentroidalProblem) -> float:
        return pr.model.mass_kg * max(float(np.linalg.norm(pr.gravity)), 1.0) / 4.0

    # ----------------------------------------------------------------------------------------------------------
    def _put(self, name: str, val: np.ndarray | float) -> None:
        self._inst.A_view[name][...] = val

    def _fill_dynamics(self, tk: _Tick) -> None:
        """Writes the linearized discrete map (rows ``dyn``) and the initial state (rows ``init``)."""
        L, put = self.L, self._put
        pr, dt, Fs = tk.pr, tk.dt, tk.Fs
        m, g = pr.model.mass_kg, pr.gravity
        legs = np.arange(N_LEGS)[None, :]
        has = tk.slot >= 0
        p_feet = np.where(has[..., None], tk.feet[legs, np.maximum(tk.slot, 0)], 0.0)
        d_int = np.zeros((L.N, N_LEGS, 2))
        hv = tk.var >= 0
        d_int[hv] = tk.d[np.nonzero(hv)[1], tk.var[hv]]
        n, k = tk.N, tk.K
        lz = linearize(tk.p[:k], tk.v[:k], tk.R[:k], tk.w[:k], tk.f[:n], p_feet[:n], d_int[:n], dt[:n],
                       pr.model.inertia_body, g)  # fmt: skip
        if n < L.N:
            lz = _pad_linearization(lz, L.N)
        # A foot in the air has no force: its columns are zero (so nothing but its cost, minimal at 0, sees it).
        down = ~tk.air
        down_f = down[:, None, :, None]
        put("pv0", -dt[:, None])
        put("pf", (-0.5 * dt * dt * Fs / m)[:, None, None] * down[..., None])
        put("vf", (-dt * Fs / m)[:, None, None] * down[..., None])
        put("tt0", -lz.Jth)
        put("tw0", -0.5 * lz.Jw)
        put("tw1", -0.5 * lz.Jw)
        put("tv0", -lz.Rv)
        put("tf", -np.transpose(lz.Rf, (0, 2, 1, 3)) * (Fs * down_f))
        dtc = dt[:, None, None]
        put("ww0", -(_EYE3 + dtc * lz.G_w))
        put("wt0", -dtc * lz.G_th)
        put("wp0", -dtc * (lz.I_inv @ lz.T_p))
        put("wv0", -dtc * (lz.I_inv @ lz.T_v))
        wf = np.einsum("nij,nljk->nilk", lz.I_inv, lz.T_f) * (-dtc[:, :, None] * Fs * down_f)  # (N,3,4,3)
        put("wf", wf)
        wd = np.zeros((L.N, 3, N_LEGS, L.S, 2))
        kk, ii = np.nonzero(hv)
        if kk.size:
            wd_leg = -dt[kk, None, None] * np.einsum("nij,njk->nik", lz.I_inv[kk], lz.T_d[kk, ii])  # (M,3,2)
            wd[kk, :, ii, tk.var[kk, ii], :] = wd_leg
        put("wd", wd)
        s0 = pr.initial
        x0 = np.concatenate([s0.p_world, s0.v_world, np.zeros(3), s0.omega_world])
        self._l[L.r_init] = x0
        self._u[L.r_init] = x0
        rhs = np.empty((L.N, 12))
        rhs[:, 0:3] = 0.5 * (dt * dt)[:, None] * g
        rhs[:, 3:6] = dt[:, None] * g
        rhs[:, 6:9] = lz.rot_rhs
        rhs[:, 9:12] = lz.ang_rhs
        self._l[L.r_dyn] = rhs
        self._u[L.r_dyn] = rhs

    def _fill_friction(self, tk: _Tick) -> None:
        """Writes the pyramid, the normal-force rows with the contact variable, the cone cut, c bounds, c order."""
        L = self.L
        sch, pr = tk.sch, tk.pr
        legs = np.arange(N_LEGS)[None, :]
        has = tk.slot >= 0
        n = np.where(has[..., None], sch.nrm[legs, np.maximum(tk.slot, 0)], np.array([0.0, 0.0, 1.0]))
        t1 = _so3.cross(n, np.array([0.0, 1.0, 0.0]))
        bad = _so3.norm(t1) < 1e-6
        t1[bad] = _so3.cross(n[bad], np.array([1.0, 0.0, 0.0]))
        t1 /= _so3.norm(t1)[..., None]
        t2 = _so3.cross(n, t1)
        tk.t1, tk.t2, tk.n = t1, t2, n
        # The pyramid is turned about the normal so that one face faces the linearization point's tangential
        # force: there it is exact, and the cuts only have to handle the force turning within the tick.
        ft = np.stack([np.sum(tk.f * t1, -1), np.sum(tk.f * t2, -1)], -1)
        nt = _so3.norm(ft)[..., None]
        self._pyr_dir[:] = np.where(nt > 1e-3 * tk.Fs, ft / np.maximum(nt, 1e-300), np.array([1.0, 0.0]))
        self._cone_on[:] = False
        air = self._air = tk.air
        self._write_cone_rows(tk)
        frc = np.empty((L.N, N_LEGS, 2))
        frc[..., 0] = -pr.fz_max_N / tk.Fs
        frc[..., 1] = -pr.fz_min_N / tk.Fs
        frc[air] = 0.0
        self._put("frc", frc)
        l, u = self._l, self._u
        rf = L.r_fric
        c_lo = np.zeros((L.N, N_LEGS))
        c_hi = np.zeros((L.N, N_LEGS))
        c_lo[: tk.N], c_hi[: tk.N] = sch.c_lo, sch.c_hi
        # A foot that may touch: pyramid faces, c fz_min <= f_n <= c fz_max, the cone cut. A foot in the air: the
        # rows are off (zero, bounds ±OFF) and its force out of the dynamics, so the force's own cost holds it at 0
        # with no active row (a row set that stays independent for polishing, and rows that keep their kind).
        air_r = air[..., None]
        l[rf[:, :, 0:5]] = np.where(air_r, -OFF, -INF)
        u[rf[:, :, 0:5]] = np.where(air_r, OFF, 0.0)
        l[rf[:, :, 5]] = np.where(air, -OFF, 0.0)
        u[rf[:, :, 5]] = np.where(air, OFF, INF)
        self._write_cut_bounds()
        l[L.r_cb] = c_lo
        u[L.r_cb] = c_hi
        mono = np.zeros((L.N - 1, N_LEGS), dtype=np.int64)
        mono[: max(tk.N - 1, 0)] = sch.mono
        l[L.r_mono] = np.where(mono > 0, 0.0, -INF)
        u[L.r_mono] = np.where(mono < 0, 0.0, INF)

    def _write_cone_rows(self, tk: _Tick) -> None:
        """Writes the pyramid (4 faces turned to ``_pyr_dir``), the normal-force rows and the cone cut."""
        a, c = self._pyr_dir, self._cone_dir
        u1 = a[..., :1] * tk.t1 + a[..., 1:] * tk.t2  # the face directions, world
        u2 = -a[..., 1:] * tk.t1 + a[..., :1] * tk.t2
        mn = tk.pr.mu * tk.n
        fr = self._fr
        fr[:, :, 0] = u1 - mn
        fr[:, :, 1] = -u1 - mn
        fr[:, :, 2] = u2 - mn
        fr[:, :, 3] = -u2 - mn
        fr[:, :, 4] = tk.n
        fr[:, :, 5] = tk.n
        fr[:, :, 6] = c[:, :, 0, :1] * tk.t1 + c[:, :, 0, 1:] * tk.t2 - mn
        fr[:, :, 7] = c[:, :, 1, :1] * tk.t1 + c[:, :, 1, 1:] * tk.t2 - mn
        fr[self._air] = 0.0
        fr[:, :, 6:8] *= self._cone_on[..., None]
        self._put("fr", fr)
        self._write_cut_bounds()

    def _write_cut_bounds(self) -> None:
        r = self.L.r_fric[:, :, 6:8]
        on = self._cone_on & ~self._air[..., None]
        self._l[r] = np.where(on, -INF, -OFF)
        self._u[r] = np.where(on, 0.0, OFF)

    def _fill_kinematics(self, tk: _Tick) -> None:
        """Writes the hip line rows and the leg-length cut rows of knots 1..K-1."""
        L, prm = self.L, self.params
        model = tk.pr.model
        sch = tk.sch
        legs = np.arange(N_LEGS)[None, :]
        ks = tk.knot_slot
        khas = ks >= 0
        ksi = np.maximum(ks, 0)
        Rk = tk.R[1:]
        tk.hbar = np.einsum("kij,lj->kli", Rk, model.p_body_hip)
        foot_c = tk.feet[legs, ksi] + model.foot_radius_m * sch.nrm[legs, ksi]
        nom_c = sch.nom[legs, ksi] + model.foot_radius_m * sch.nrm[legs, ksi]
        tk.foot_c = nom_c
        vec = tk.p[1:, None, :] + tk.hbar - foot_c
        dist = _so3.norm(vec)
        lo, hi = model.leg_length_min_m, model.leg_length_max_m
        self._len_on[:] = khas & ((dist > hi - prm.cut_margin_m) | (dist < lo + prm.cut_margin_m))
        self._len_dir[:] = vec / np.maximum(dist, 1e-9)[..., None]
        self._relaxed_knots(tk)
        # Hip line: a_b · (Rᵀ (foot − p) − p_body_hip) in range, with Rᵀ x ≈ R̄ᵀ (x + [x̄]× θ).
        a_b = np.array([math.cos(model.hip_line_tilt_rad), 0.0, -math.sin(model.hip_line_tilt_rad)])
        a_w = Rk @ a_b
        xbar = foot_c - tk.p[1:, None, :]
        kp, kt = self._kin
        kp[:, :, 1] = -a_w[:, None, :]
        kt[:, :, 1] = _so3.cross(a_w[:, None, :], xbar)  # a_wᵀ [x̄]× = (a_w × x̄)ᵀ
        kd = self._kd
        kd[:, :, 1] = 0.0
        kv = np.where(khas, sch.var[legs, ksi], -1)
        self._kin_var = kv
        kk, ii = np.nonzero(kv >= 0)
        kd[kk, ii, 1, kv[kk, ii], :] = a_w[kk] @ _E_XY
        kp[~khas, 1] = 0.0  # no foot at the knot: the row is off
        kt[~khas, 1] = 0.0
        hip_bh = (a_b @ model.p_body_hip.T)[None, :]
        base = hip_bh - np.einsum("kj,klj->kl", a_w, nom_c)
        # Relaxed rows (foot maybe not down) keep the side the linearization point is nearer to, and give way by
        # M = slack + what the linearization point already needs.
        relax, side, big_m = self._relax, self._side, self._big_m
        h_lo, h_hi = model.hip_x_range_m
        off = np.einsum("kj,klj->kl", a_w, xbar) - hip_bh
        side[..., 0] = np.where(dist >= 0.5 * (lo + hi), 1.0, -1.0)
        side[..., 1] = np.where(off >= 0.5 * (h_lo + h_hi), 1.0, -1.0)
        need0 = np.where(side[..., 0] > 0, dist - hi, lo - dist)
        need1 = np.where(side[..., 1] > 0, off - h_hi, h_lo - off)
        big_m[..., 0] = prm.window_slack_m + np.maximum(need0, 0.0)
        big_m[..., 1] = prm.window_slack_m + np.maximum(need1, 0.0)
        r_h = L.r_kin[:, :, 1]
        m1 = np.where(relax, big_m[..., 1], 0.0)
        self._l[r_h] = np.where(khas, np.where(relax & (side[..., 1] > 0), -INF, h_lo + base - m1), -OFF)
        self._u[r_h] = np.where(khas, np.where(relax & (side[..., 1] < 0), INF, h_hi + base + m1), OFF)
        self._khas = khas
        self._write_length_cuts(tk)

    def _relaxed_knots(self, tk: _Tick) -> None:
        """Marks the knots whose foot may not be down (no adjacent interval of its slot is surely in stance) and
        picks the contact variable their rows hang on: the interval that is down whenever the other one is
        (the later one in a touchdown window, the earlier one in a liftoff window)."""
        sch, n = tk.sch, tk.N
        ks = tk.knot_slot
        sl = tk.slot
        c_lo = np.zeros(sl.shape)
        c_lo[:n] = sch.c_lo
        mono = np.zeros(sl.shape, dtype=np.int64)
        mono[: max(n - 1, 0)] = sch.mono
        has = ks >= 0
        prev = has & (sl == ks)  # the interval ending at the knot belongs to the knot's foot
        nxt = np.zeros_like(prev)
        nxt[:-1] = has[:-1] & (sl[1:] == ks[:-1])
        sure = prev & (c_lo > 0.5)
        sure[:-1] |= nxt[:-1] & (c_lo[1:] > 0.5)
        self._relax[:] = has & ~sure
        self._use_next[:] = self._relax & nxt & (~prev | (mono >= 0))

    def _write_relaxation(self) -> None:
        """Writes the M coefficients of the relaxed kinematic rows on their contact variables."""
        on = np.stack([self._len_on & self._khas, self._khas], axis=-1)
        coef = np.where(self._relax[..., None] & on, self._side * self._big_m, 0.0)
        nxt = self._use_next[..., None]
        self._put("kc0", np.where(nxt, 0.0, coef))
        self._put("kc1", np.where(nxt, coef, 0.0)[:-1])

    def _write_length_cuts(self, tk: _Tick) -> None:
        """Writes leg-length rows: u · (hip(p, θ) − foot(d)) in [min, max] along each row's direction u."""
        L = self.L
        model = tk.pr.model
        kp, kt = self._kin
        kd = self._kd
        on = self._len_on & self._khas
        u_dir = self._len_dir
        u_on = u_dir * on[..., None]  # rows without a cut are off: zero
        kp[:, :, 0] = u_on
        kt[:, :, 0] = _so3.cross(tk.hbar, u_on)  # −uᵀ [h̄]× = (h̄ × u)ᵀ
        kd[:, :, 0] = 0.0
        kv = self._kin_var
        kk, ii = np.nonzero(kv >= 0)
        kd[kk, ii, 0, kv[kk, ii], :] = -(u_on[kk, ii] @ _E_XY)
        self._put("kp", kp)
        self._put("kt", kt)
        self._put("kd", kd)
        const = np.einsum("klj,klj->kl", u_dir, tk.hbar - tk.foot_c)
        r = L.r_kin[:, :, 0]
        relax, side = self._relax, self._side[..., 0]
        m0 = np.where(relax, self._big_m[..., 0], 0.0)
        self._l[r] = np.where(
            on, np.where(relax & (side > 0), -INF, model.leg_length_min_m - const - m0), -OFF
        )
        self._u[r] = np.where(on, np.where(relax & (side < 0), INF, model.leg_length_max_m - const + m0), OFF)
        self._write_relaxation()

    def _fill_footholds(self, tk: _Tick) -> None:
        """Writes the box and polygon rows of each foothold variable (unused ones are held at zero)."""
        L = self.L
        r_f = L.r_foot
        l, u = self._l, self._u
        l[r_f] = -INF
        u[r_f] = INF
        l[r_f[:, :, :2]] = 0.0
        u[r_f[:, :, :2]] = 0.0
        dp = np.zeros((N_LEGS, L.S, L.E, 2))
        for i in range(N_LEGS):
            for sl in tk.sch.slots[i]:
                if sl.var < 0:
                    continue
                l[r_f[i, sl.var, :2]] = -sl.box
                u[r_f[i, sl.var, :2]] = sl.box
                ne = sl.poly_a.shape[0]
                dp[i, sl.var, :ne] = sl.poly_a
                u[r_f[i, sl.var, 2 : 2 + ne]] = sl.poly_b
        self._put("dp", dp)

    def _fill_cost(self, tk: _Tick) -> None:
        """Writes P and q: pose and velocity tracking, hip over foot, objectives, forces, timing, foothold shifts."""
        L = self.L
        pr, sch, K, N, dt, Fs = tk.pr, tk.sch, tk.K, tk.N, tk.dt, tk.Fs
        Kmax = L.K
        w = pr.weights
        tg = pr.targets
        q = self._q
        H = np.zeros((Kmax, 6, 6))  # the [p; θ] block of each knot
        h = np.zeros(Kmax)  # time each knot stands for, s
        h[: K - 1] += 0.5 * dt[:N]
        h[1:K] += 0.5 * dt[:N]
        # Pose targets (knot 0 is fixed: no cost).
        wp = np.zeros((Kmax, 3))
        wr = np.zeros((Kmax, 3))
        wp[1:K] = tg.w_position[1:]
        wr[1:K] = tg.w_orientation[1:]
        pt = np.zeros((Kmax, 3))
        pt[:K] = tg.p_world
        et = np.zeros((Kmax, 3))
        et[:K] = _so3.log(tg.R_world_body @ np.swapaxes(tk.R[:K], -1, -2))
        i3 = np.arange(3)
        H[:, i3, i3] += 2.0 * wp
        H[:, 3 + i3, 3 + i3] += 2.0 * wr
        q_p = -2.0 * wp * pt
        q_t = -2.0 * wr * et
        # Velocity tracking (running).
        wv = np.zeros((Kmax, 1))
        wv[1:K, 0] = w.velocity * h[1:K]
        ww = np.zeros((Kmax, 1))
        ww[1:K, 0] = w.angular_velocity * h[1:K]
        vt = np.zeros((Kmax, 3))
        vt[:K] = tg.v_world
        wt = np.zeros((Kmax, 3))
        wt[:K] = tg.omega_world
        q[L.i_v] = -2.0 * wv * vt
        q[L.i_w] = -2.0 * ww * wt
        # Hip over foot on sure-stance knots: hip_xy ≈ p_xy + (R̄ p_bh)_xy − ([R̄ p_bh]× θ)_xy over the foot's
        # contact point (nominal + d when the touchdown may move), less the nominal hip-to-foot offset.
        model = pr.model
        hip_const = 0.0
        Hpd = np.zeros((Kmax, 6, N_LEGS, L.S, 2))
        Hdd = np.zeros((N_LEGS, L.S, 2))
        q_d = np.zeros((N_LEGS, L.S, 2))
        if w.hip_over_foot > 0.0:
            # Dense over (knot, leg), weighted by 0 where the leg is not surely down: no scatter needed.
            legs = np.arange(N_LEGS)[None, :]
            wk = np.zeros((Kmax, N_LEGS))
            wk[1:K] = np.where(sch.stance_knot[1:], w.hip_over_foot * h[1:K, None], 0.0)
            ks = np.zeros((Kmax, N_LEGS), dtype=np.int64)
            ks[1:K] = np.maximum(sch.knot_slot[1:], 0)
            hb = np.einsum("kij,lj->kli", tk.R, model.p_body_hip)
            off = np.einsum("kij,lj->kli", tk.R[:, :2, :2], model.foot_offset_body_xy)
            foot = sch.nom[legs, ks]  # a touchdown that may move adds its shift d below
            J = np.zeros((Kmax, N_LEGS, 2, 6))
            J[..., 0, 0] = 1.0
            J[..., 1, 1] = 1.0
            J[..., :, 3:] = -_so3.hat(hb)[..., :2, :]
            r0 = hb[..., :2] - foot[..., :2] + off
            H += 2.0 * np.einsum("kl,klai,klaj->kij", wk, J, J)
            g_ = 2.0 * np.einsum("kl,klai,kla->ki", wk, J, r0)
            q_p += g_[:, :3]
            q_t += g_[:, 3:]
            hip_const = float(np.sum(wk * np.sum(r0 * r0, axis=-1)))
            # r = J z + r0 − d (d in xy): cross terms −2w Jᵀ, d·d terms 2w, linear −2w r0.
            kv = sch.var[legs, ks]
            onehot = ((kv[..., None] == np.arange(L.S)) & (wk > 0.0)[..., None]).astype(float)  # (K,4,S)
            won = wk[..., None] * onehot
            Hpd -= 2.0 * np.einsum("kls,klai->kilsa", won, J)
            Hdd += 2.0 * won.sum(axis=0)[..., None]
            q_d -= 2.0 * np.einsum("kls,kla->lsa", won, r0)
        # Custom objectives: linear rewards on the CoM over their windows.
        tkn = np.full(Kmax, np.inf)
        tkn[:K] = pr.t_knots
        for ob in pr.objectives:
            inw = (tkn >= ob.t_start) & (tkn <= ob.t_end)
            inw[0] = False
            if ob.kind == "maximize_height":
                q_p[inw, 2] -= ob.weight * h[inw]
            else:
                dvec = np.asarray(ob.direction_xy, dtype=float)
                q_p[inw, :2] -= ob.weight * h[inw, None] * (dvec / np.linalg.norm(dvec))
        q[L.i_p] = q_p
        q[L.i_th] = q_t
        q[L.i_f] = 0.0
        q[L.i_c] = 0.0
        q[L.i_c[:N]] = sch.q_c
        q[L.i_d] = q_d
        # The constant part of the cost, so ``cost`` compares across problems (e.g. timing adjustment on/off).
        tk.cost_const = (
            float(np.sum(wp * pt * pt) + np.sum(wr * et * et) + np.sum(wv * vt * vt) + np.sum(ww * wt * wt))
            + hip_const
            - float(np.sum(np.minimum(sch.q_c, 0.0)))
        )
        ia, ib = L.pt_pairs
        P_view = self._inst.P_view

        def putp(name: str, val: np.ndarray | float) -> None:
            P_view[name][...] = val

        putp("pt", H[:, ia, ib])
        putp("vv", 2.0 * wv + 1e-6)
        putp("ww", 2.0 * ww + 1e-6)
        putp("ff", (2.0 * w.force * Fs * Fs * dt + 1e-6)[:, None, None])
        putp("cc", 2.0 * w.contact_regularization + 1e-6)
        putp("dd", 2.0 * w.touchdown_position + Hdd + 1e-6)
        putp("pd", Hpd)

    # ----------------------------------------------------------------------------------------------------------
    def _solve(self, pr: CentroidalProblem, sch: ContactSchedule, t0: float) -> CentroidalSolution:
        L = self.L
        tk = self._tick_arrays(pr, sch)
        self._fill_dynamics(tk)
        self._fill_friction(tk)
        self._fill_kinematics(tk)
        self._fill_footholds(tk)
        self._fill_cost(tk)
        x_ws = np.zeros(L.n)
        x_ws[L.i_p] = tk.p
        x_ws[L.i_v] = tk.v
        x_ws[L.i_w] = tk.w
        x_ws[L.i_f] = tk.f / tk.Fs
        x_ws[L.i_c] = tk.c
        x_ws[L.i_d] = tk.d

        tq = time.perf_counter()
        # a cold start (no previous solution to warm-start from: the stage's first tick, or after a reset) is not
        # bounded; every later tick is
        bounded = self._prev is not None
        mi, ms = self.params.max_tick_iterations, self.params.max_tick_solves
        self._iters_left = mi if bounded and mi is not None else math.inf
        self._solves_left = ms if bounded and ms is not None else math.inf
        self._tick_iterations = 0
        self._qp.update(q=self._q, l=self._l, u=self._u, Px=self._Px[L.P_order], Ax=self._Ax[L.A_order])
        self._qp.warm_start(x=x_ws)
        res = self._run_qp()
        self.last_info = [res.info]
        t_qp = (time.perf_counter() - tq) * 1e3
        run = None
        if int(res.info.status_val) in (1, 2) and self._relax[: tk.K - 1].any():
            # An answer leaning on the relaxation's give goes straight to whole schedules (cuts come there).
            first = _Run(res, self._unpack(res.x, tk), 0, 0, 0.0, 0.0, t_qp, None)
            run = self._snap_timing(tk, first, t0)
        if run is None:
            run = self._cut_rounds(tk, res, t0, t_qp)
            if int(run.res.info.status_val) in (1, 2) and self._relax[: tk.K - 1].any():
                run = self._snap_timing(tk, run, t0) or run
        res, t_qp = run.res, run.t_qp
        self.last_snapshot = run.snapshot
        qp_iter = self._tick_iterations  # every ADMM iteration of the tick (the tight fallback's too)
        status_val = int(res.info.status_val)
        if status_val not in (1, 2):
            # No answer: the last good solution stays the linearization point for the next tick.
            name = _STATUS_NAMES.get(status_val, "solver_error")
            return _failure(name, f"OSQP: {res.info.status}", t0, t_qp)
        return self._finish(tk, res, run.sol, t0, t_qp, qp_iter, run.rounds, run.n_cuts, run.len_viol,
                            run.cone_viol)  # fmt: skip

    def _leans_on_slack(self, sol: dict[str, np.ndarray], tk: _Tick) -> float:
        """Returns how far (m) a foot the solution loads (c above _C_WHOLE) inside a timing window is out of its
        leg-length or hip-line limits, 0 when none is: the answer leans on the big-M give of the relaxation."""
        K, model = tk.K, tk.pr.model
        relax = self._relax[: K - 1]
        if not relax.any():
            return 0.0
        c = sol["c"]
        c_sel = c[: K - 1].copy()
        c_sel[: K - 2] = np.where(self._use_next[: K - 2], c[1 : K - 1], c_sel[: K - 2])
        kk, ii = np.nonzero(relax & (c_sel > _C_WHOLE))
        if kk.size == 0:
            return 0.0
        ks = np.maximum(tk.knot_slot[kk, ii], 0)
        foot_c = sol["feet"][ii, ks] + model.foot_radius_m * tk.sch.nrm[ii, ks]
        R = sol["R"][kk + 1]
        rel = np.einsum("nji,nj->ni", R, foot_c - sol["p"][kk + 1]) - model.p_body_hip[ii]  # body frame
        dist = _so3.norm(rel)
        a_b = np.array([math.cos(model.hip_line_tilt_rad), 0.0, -math.sin(model.hip_line_tilt_rad)])
        off = rel @ a_b
        lo, hi = model.hip_x_range_m
        over = np.maximum(
            np.maximum(dist - model.leg_length_max_m, model.leg_length_min_m - dist),
            np.maximum(off - hi, lo - off),
        )
        return float(max(over.max(), 0.0))

    def _cut_rounds(self, tk: _Tick, res: Any, t0: float, t_qp: float) -> _Run:
        """Adds tangent-plane cuts for the nonlinear constraints the solution violates and re-solves, a few rounds
        at most; returns the last answer with what it took."""
        prm, L = self.params, self.L
        rounds = n_cuts = 0
        len_viol = cone_viol = 0.0
        sol: dict[str, np.ndarray] = {}
        while int(res.info.status_val) in (1, 2):
            sol = self._unpack(res.x, tk)
            len_viol, cone_viol, new_len, new_cone = self._violations(sol, tk)
            if not (new_len.any() or new_cone.any()):
                break
            if (
                rounds >= prm.max_cut_rounds
                or (time.perf_counter() - t0) * 1e3 > prm.time_budget_ms
                or not self._work_left()
            ):
                loose = self._loose
                if loose is not None and loose is not res:
                    # The accurate answer needs cuts the tick has no work left for; the same solve's answer at
                    # eps_abs (before the tight tolerance) may need none: then it stands, the best the tick had.
                    lsol = self._unpack(loose.x, tk)
                    lv = self._violations(lsol, tk, record=False)
                    if not (lv[2].any() or lv[3].any()):
                        res, sol, len_viol, cone_viol = loose, lsol, lv[0], lv[1]
                break
            rounds += 1
            n_cuts += int(new_len.sum() + new_cone.sum())
            self._write_length_cuts(tk)
            self._write_cone_rows(tk)
            tq = time.perf_counter()
            self._qp.update(l=self._l, u=self._u, Ax=self._Ax[L.A_order])
            self._qp.warm_start(x=res.x)
            before = res
            res = self._run_qp()
            t_qp += (time.perf_counter() - tq) * 1e3
            self.last_info.append(res.info)
            if int(res.info.status_val) not in (1, 2) and not self._work_left():
                # the tick's work ran out inside the re-solve: the answer before it stands, its cuts unsatisfied
                res = before
                break
        snap = QPSnapshot(self._Px.copy(), self._Ax.copy(), self._q.copy(), self._l.copy(), self._u.copy(), tk.K,
                          tk.N, tk.Fs, self.L, None if res.x is None else np.array(res.x))  # fmt: skip
        return _Run(res, sol, rounds, n_cuts, len_viol, cone_viol, t_qp, snap)

    def _snap_timing(self, tk: _Tick, run: _Run, t0: float) -> _Run | None:
        """Makes a relaxed schedule whole where it has to be. A window's contact variable between 0 and 1 is a
        foot pushing lightly, physically fine while the foot is within reach; but its kinematic rows give way by
        M (1 − c), and when the answer uses that (a loaded foot out of reach), the QP is solved again with the
        windows' contact fixed: down wherever the relaxed answer loads the foot at all, down only where it loads
        it fully, and the nominal timing (a schedule the relaxation contains, so timing adjustment never does worse than
        none); the cheaper answer is kept. Only bounds change: no refactorization. Returns None when the answer
        does not lean on the give. Past the time budget no further schedule is tried once one has solved."""
        sch, pr, L, N = tk.sch, tk.pr, self.L, tk.N
        win = sch.c_hi > sch.c_lo
        c = run.sol["c"]
        lean = self._leans_on_slack(run.sol, tk)
        if lean <= self.params.leg_length_tol_m:
            return None
        cands: list[np.ndarray] = []
        for cf in (
            np.where(win, (c > _C_WHOLE).astype(float), sch.c_lo),  # down wherever it pushes at all
            np.where(win, (c >= 1.0 - _C_WHOLE).astype(float), sch.c_lo),  # down only where fully
            np.where(win, pr.contact.astype(float), sch.c_lo),  # nominal timing
        ):
            if not any(np.array_equal(cf, x) for x in cands):
                cands.append(cf)
        best = None
        x0 = np.array(run.res.x)
        r_cb = L.r_cb[:N]
        floor = float(run.res.info.obj_val)  # the relaxation's optimum: no whole schedule does better
        # A schedule that does not solve mostly runs to max_iter (infeasibility is slow to detect): cap it.
        self._max_iter_now = max(self.params.max_iter // 4, 50)
        for cf in cands:
            if not self._work_left():
                break
            if best is not None and (
                float(best.res.info.obj_val) <= floor + 1e-4 * max(1.0, abs(floor))
                or (time.perf_counter() - t0) * 1e3 > self.params.time_budget_ms
            ):
                break
            self._l[r_cb] = cf
            self._u[r_cb] = cf
            x_ws = x0.copy()
            x_ws[L.i_c[:N]] = cf
            tq = time.perf_counter()
            self._qp.update(l=self._l, u=self._u)
            self._qp.warm_start(x=x_ws)
            res = self._run_qp()
            self.last_info.append(res.info)
            got = self._cut_rounds(tk, res, t0, run.t_qp + (time.perf_counter() - tq) * 1e3)
            run = replace(run, t_qp=got.t_qp)
            if int(got.res.info.status_val) not in (1, 2):
                continue
            if best is None or float(got.res.info.obj_val) < float(best.res.info.obj_val):
                best = got
        self._max_iter_now = self.params.max_iter
        if best is None:  # no whole schedule solves: the relaxed answer, out of reach, is not ``ok``
            self._l[r_cb] = sch.c_lo
            self._u[r_cb] = sch.c_hi
            snap = QPSnapshot(self._Px.copy(), self._Ax.copy(), self._q.copy(), self._l.copy(), self._u.copy(),
                              tk.K, tk.N, tk.Fs, self.L, x0)  # fmt: skip
            return replace(run, len_viol=max(run.len_viol, lean), snapshot=snap)
        return replace(best, t_qp=run.t_qp)

    def _work_left(self) -> bool:
        """Whether the tick may run another QP solve (max_tick_iterations, max_tick_solves)."""
        return self._solves_left >= 1 and self._iters_left >= _MIN_SOLVE_ITERATIONS

    def _iteration_cap(self, max_iter: int) -> int:
        return int(min(max_iter, max(self._iters_left, 1)))

    def _run_qp(self) -> Any:
        """Solves the QP as it stands (at most _max_iter_now ADMM iterations, and what the tick has left); when
        polishing fails (a degenerate active set), goes on to the tight tolerance from where ADMM stopped, so the
        forces are accurate either way. The answer at eps_abs is kept in _loose (None when polishing did not fail):
        a tick out of work may keep it (``_cut_rounds``), and a tight run out of iterations returns it."""
        p = self.params
        cap = self._iteration_cap(self._max_iter_now)
        self._qp.update_settings(max_iter=cap)
        res = self._qp.solve(raise_error=False)
        self._solves_left -= 1
        self._iters_left -= int(res.info.iter)
        self._tick_iterations += int(res.info.iter)
        self._loose = None
        if (
            p.polish
            and int(res.info.status_val) == 1
            and int(res.info.status_polish) != 1
            and p.eps_fallback < p.eps_abs
        ):
            self._loose = res
            self._qp.update_settings(
                eps_abs=p.eps_fallback,
                eps_rel=p.eps_fallback,
                polishing=False,
                max_iter=self._iteration_cap(cap),
            )
            tight = self._qp.solve(raise_error=False)
            self._iters_left -= int(tight.info.iter)
            self._tick_iterations += int(tight.info.iter)
            self._qp.update_settings(eps_abs=p.eps_abs, eps_rel=p.eps_rel, polishing=True)
            if int(tight.info.status_val) == 1:
                res = tight
        return res

    # ----------------------------------------------------------------------------------------------------------
    def _unpack(self, x: np.ndarray, tk: _Tick) -> dict[str, np.ndarray]:
        L, K, N, sch = self.L, tk.K, tk.N, tk.sch
        th = x[L.i_th[:K]]
        d = x[L.i_d]
        feet = sch.nom.copy()
        vi, vs = np.nonzero(sch.var >= 0)
        feet[vi, vs] += d[vi, sch.var[vi, vs]] @ _E_XY.T
        slot = sch.slot
        has = slot >= 0
        legs = np.arange(N_LEGS)[None, :]
        return {
            "p": x[L.i_p[:K]],
            "v": x[L.i_v[:K]],
            "th": th,
            "R": _so3.exp(th) @ tk.R[:K],
            "w": x[L.i_w[:K]],
            "f": x[L.i_f[:N]] * (tk.Fs * ~tk.air[:N, :, None]),
            "c": x[L.i_c[:N]],
            "d": d,
            "feet": feet,
            "p_feet": np.where(has[..., None], feet[legs, np.maximum(slot, 0)], 0.0),
        }

    def _violations(
        self, sol: dict[str, np.ndarray], tk: _Tick, record: bool = True
    ) -> tuple[float, float, np.ndarray, np.ndarray]:
        """Checks the nonlinear constraints on a solution; points the cut rows of violated ones at the violation
        (record False: only checks).

        Returns (worst leg-length violation m, worst cone violation as a fraction of μ f_n, new length cuts
        (K_max-1,4), new cone cuts (N_max,4)).
        """
        prm, pr, sch, K, N = self.params, tk.pr, tk.sch, tk.K, tk.N
        model = pr.model
        legs = np.arange(N_LEGS)[None, :]
        # Leg length with the true (nonlinear) hip position.
        hip = sol["p"][1:, None, :] + np.einsum("kij,lj->kli", sol["R"][1:], model.p_body_hip)
        ksi = np.maximum(tk.knot_slot[: K - 1], 0)
        foot_c = sol["feet"][legs, ksi] + model.foot_radius_m * sch.nrm[legs, ksi]
        vec = hip - foot_c
        dist = _so3.norm(vec)
        act = self._khas[: K - 1]
        # A relaxed row (foot maybe up) allows M (1 − c) more.
        c = sol["c"]
        c_sel = np.ones((K - 1, N_LEGS))
        nxt = self._use_next[: K - 1]
        c_sel[:] = c[: K - 1]
        c_sel[: K - 2] = np.where(nxt[: K - 2], c[1 : K - 1], c_sel[: K - 2])
        give = np.where(self._relax[: K - 1], self._big_m[: K - 1, :, 0] * (1.0 - c_sel), 0.0)
        too_long = dist - model.leg_length_max_m - give
        over = np.where(act, np.maximum(too_long, model.leg_length_min_m - dist - give), 0.0)
        new_len = np.zeros_like(self._len_on)
        new_len[: K - 1] = over > prm.leg_length_tol_m
        if record and new_len.any():
            self._len_on |= new_len
            self._len_dir[new_len] = (vec / np.maximum(dist, 1e-9)[..., None])[new_len[: K - 1]]
            flip = new_len[: K - 1] & self._relax[: K - 1]
            s0 = self._side[: K - 1, :, 0]
            s0[:] = np.where(flip, np.where(too_long > 0.0, 1.0, -1.0), s0)
        # Friction cone.
        f = sol["f"]
        t1, t2, n = tk.t1[:N], tk.t2[:N], tk.n[:N]
        fn = np.sum(f * n, -1)
        ft = np.stack([np.sum(f * t1, -1), np.sum(f * t2, -1)], -1)
        ftn = _so3.norm(ft)
        # Relative to the cone's radius, and never for less than cone_tol_N of excess (lightly loaded feet).
        excess = ftn - pr.mu * fn
        cone_rel = np.where(
            excess > prm.cone_tol_N, excess / np.maximum(pr.mu * np.maximum(fn, pr.fz_min_N), 1e-9), 0.0
        )
        new_cone = np.zeros(self._cone_dir.shape[:2], dtype=bool)
        new_cone[:N] = (cone_rel > prm.cone_tol) & (ftn > 1e-9)
        if record and new_cone.any():
            # The pyramid turns to face the violating force (exact there); the two cut rows keep the faces it
            # had before (their tangent planes stay): the polytope tightens around where the forces go.
            self._cone_dir[new_cone, 1] = self._cone_dir[new_cone, 0]
            self._cone_on[new_cone, 1] = self._cone_on[new_cone, 0]
            self._cone_dir[new_cone, 0] = self._pyr_dir[new_cone]
            self._cone_on[new_cone, 0] = True
            self._pyr_dir[new_cone] = (ft / np.maximum(ftn, 1e-12)[..., None])[new_cone[:N]]
        return (
            float(max(over.max(initial=0.0), 0.0)),
            float(max(cone_rel.max(initial=0.0), 0.0)),
            new_len,
            new_cone,
        )

    # ----------------------------------------------------------------------------------------------------------
    def _finish(
        self,
        tk: _Tick,
        res: Any,
        sol: dict[str, np.ndarray],
        t0: float,
        t_qp: float,
        qp_iter: int,
        rounds: int,
        n_cuts: int,
        len_viol: float,
        cone_viol: float,
    ) -> CentroidalSolution:
        prm, pr, sch, N = self.params, tk.pr, tk.sch, tk.N
        model = pr.model
        t = pr.t_knots
        # Integrated solution: the QP's forces through the nonlinear discrete dynamics.
        P_i, V_i, R_i, W_i = integrate_plan(pr.initial, sol["f"], sol["p_feet"], t, model, pr.gravity)
        err = compare(sol["p"], sol["R"], sol["w"], P_i, R_i, W_i, prm.error_length_m)
        # Timing and places the solution chose.
        c = sol["c"]
        fn = np.sum(sol["f"] * tk.n[:N], -1)
        in_contact = ((c >= 0.5) | (fn >= 0.5 * pr.fz_min_N)) & (sch.c_hi > 0.0)
        tds: list[AdjustedTouchdown] = []
        los: list[AdjustedLiftoff] = []
        for i in range(N_LEGS):
            for s, sl in enumerate(sch.slots[i]):
                ph = sl.phase
                t_td = ph.t_touchdown
                k0, k1 = sl.td_window
                if k1 > k0:
                    hit = np.nonzero(in_contact[k0:k1, i])[0]
                    t_td = float(t[k0 + hit[0]]) if hit.size else float(t[k1])
                p_td = sol["feet"][i, s].copy()
                tds.append(
                    AdjustedTouchdown(
                        i, ph.key, ph.t_touchdown, t_td, ph.p_world_foot.copy(), p_td, sl.planted
                    )
                )
                if math.isfinite(ph.t_liftoff):
                    t_lo = ph.t_liftoff
                    k0, k1 = sl.lo_window
                    if k1 > k0:
                        hit = np.nonzero(in_contact[k0:k1, i])[0]
                        t_lo = float(t[k0 + hit[-1] + 1]) if hit.size else float(t[k0])
                    los.append(AdjustedLiftoff(i, ph.key, ph.t_liftoff, t_lo))
        d_by_key = {
            sl.phase.key: sol["d"][i, sl.var].copy()
            for i in range(N_LEGS)
            for sl in sch.slots[i]
            if sl.var >= 0
        }
        self._prev = _Previous(t.copy(), sol["p"].copy(), sol["v"].copy(), sol["R"].copy(), sol["w"].copy(),
                               sol["f"].copy(), c.copy(), d_by_key)  # fmt: skip
        tick_ms = (time.perf_counter() - t0) * 1e3
        if int(res.info.status_val) != 1:  # type: ignore[attr-defined]
            status = "inaccurate"
        elif len_viol > 2 * prm.leg_length_tol_m or cone_viol > 2 * prm.cone_tol:
            status = "cuts_unsatisfied"
        elif err.metric > prm.linearization_error_threshold_m:
            status = "linearization_error"
        elif tick_ms > prm.time_budget_ms:
            status = "over_budget"
        else:
            status = "solved"
        msg = (
            f"{status}: {rounds} cut round(s), {n_cuts} cut(s), linearization error {err.metric * 1e3:.2f} mm, "
            f"qp {t_qp:.2f} ms, tick {tick_ms:.2f} ms"
        )
        return CentroidalSolution(
            status=status,
            ok=status == "solved",
            message=msg,
            t_knots=t.copy(),
            p_world=sol["p"],
            v_world=sol["v"],
            R_world_body=sol["R"],
            omega_world=sol["w"],
            f_world=sol["f"],
            contact=c,
            in_contact=in_contact,
            p_world_foot=sol["p_feet"],
            touchdowns=tuple(tds),
            liftoffs=tuple(los),
            linearization_error=err.metric,
            orientation_error_rad=float(np.max(err.orientation_rad)),
            cost=float(res.info.obj_val) + tk.cost_const,  # type: ignore[attr-defined]
            qp_ms=t_qp,
            tick_ms=tick_ms,
            qp_iterations=qp_iter,
            cut_iterations=rounds,
            n_cuts=n_cuts,
            max_leg_length_violation_m=len_viol,
            max_cone_violation=cone_viol,
            integrated={"p_world": P_i, "v_world": V_i, "R_world_body": R_i, "omega_world": W_i},
        )
