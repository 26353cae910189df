"""The constrained step QP: footholds of the next steps near the nominal footholds of the chosen cadence.

Decision variables (fixed layout, K = n_steps slots, a slot is one touchdown of one leg):
  p_k (2): foothold xy (world, m) · dc_k (2): body offset (m) during the support phase that follows touchdown k ·
  one slack (m, >= 0) per constraint family and slot.

Cost: w_nominal |p_k - p_nom_k|² + w_body_shift |dc_k|² + Σ weight_family · slack (an exact L1 penalty: a family with
a large weight is hard whenever the problem allows it, and the slacks report which family gave way when it does not).

Constraint families (each row is linear; directions that depend on the answer are taken from the nominal or from the
last iterate, so the pattern never changes and the OSQP problem is built once and updated in place):

  reach_rect   the reachable rectangle: the first step of a swinging leg lies within p0 + v0 T ± a_max T²/2 of
               its current position; later steps lie within a stride box around the leg's previous foothold
  reach_oct    the reach octagon around the hip at touchdown (leg length)
  step_keep    step keep-out: half-planes approximating no-step regions, added iteratively (solve, find footholds
               in no-step cells, add the nearest boundary's half-plane, re-solve)
  margin       keep-out margin: the same half-planes pushed out by margin_m (soft)
  body_keep    body keep-out: feet away from body obstacles, and the refined body away from them
  self_coll    self-collision: each foot stays out of a trapezoid around its lateral and longitudinal neighbors
  cop          CoP-offset range: with two feet down, each carries at least cop_fraction of the weight; with three or
               four, the body point stays inside the support polygon
  balance      the body point stays near the support line (two feet) or deep in the polygon (soft, harder than margin)

Replanning at ~300 Hz on the maps of the moment: `solve` takes a StepRequest and the TerrainMaps and gives a StepPlan.
Legs are FL, FR, RL, RR = 0..3. Times are seconds from now.
"""

from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
import osqp
from numpy.typing import NDArray
from scipy import sparse

from planning.terrain.maps import TerrainMaps

FAMILIES: tuple[str, ...] = (
    "reach_rect", "reach_oct", "step_keep", "margin", "body_keep", "self_coll", "cop", "balance",
)  # fmt: skip
HARD: frozenset[str] = frozenset({"reach_rect", "reach_oct", "step_keep", "body_keep", "self_coll", "cop"})
_F = {name: i for i, name in enumerate(FAMILIES)}

LEG_IS_FRONT = np.array([True, True, False, False])
LEG_IS_LEFT = np.array([True, False, True, False])
LATERAL_NEIGHBOR = np.array([1, 0, 3, 2])
LONGITUDINAL_NEIGHBOR = np.array([2, 3, 0, 1])


@dataclass(frozen=True)
class StepQPParams:
    """Step QP tuning (lengths m, times s, weights per m of slack unless noted).

    n_steps: footholds planned (K); w_nominal: pull toward the nominal footholds (1/m²); w_body_shift: cost of
    shifting the body (1/m²); max_body_shift_m: bound on that shift; weights: per family, in FAMILIES order
    (balance harder than margin); margin_m: keep-out margin; foot_body_clearance_m: feet from body obstacles;
    body_radius_m: refined body point from body obstacles; max_foot_accel: swing foot acceleration (m/s²);
    stride_box_m: (forward, lateral) half sizes of the box around a leg's previous foothold; leg_length_m: hip to
    foot at full reach; hip_height_m: hip above the ground; self_lateral_m, self_longitudinal_m: minimum spacing
    to the lateral and longitudinal neighbors (body frame); self_taper: trapezoid slant (lateral spacing grows by
    this much per m of longitudinal offset, negative narrows); cop_fraction: least share of the weight per foot
    (two feet down); cop_margin_m: body point inside the support polygon by this much (three or four feet);
    balance_lateral_m: body point off the support line by at most this (two feet); balance_margin_m: the polygon
    margin wanted (three or four feet); keep_planes: half-planes per foothold; keep_clearance_m: the hard plane lies this far out of the no-step region;
    max_retargets: times per replan a foothold whose planes conflict is aimed at another free spot;
    reach_search_m: how far that spot is searched (m); snap_search_m: a nominal foothold on or near a no-step
    region (step SDF below snap_clearance_m) is first moved along the body heading, forward or back, to the
    nearer of the first spots with that clearance (across a gap onto the next stone, or back onto the current
    one), no more than snap_ahead_m ahead of / snap_behind_m behind its hip at touchdown along the heading (m);
    0 (the default) turns this off, e.g. 0.45 on stepping stones; snap_clearance_m: the clearance wanted (m);
    snap_hold_m: a leg already in the air keeps the side it was sent to (in the last replan, for the same
    touchdown; needs StepRequest.t_now) while that spot is within this of a candidate (m), so a foot in flight is
    not sent back and forth across a gap; snap_lateral_m: the search also runs this far to either side of the
    heading line (m); snap_middle: a side whose free run (from the first spot with half of snap_clearance_m on) has no spot with
    snap_clearance_m gives the run's spot farthest from the edges (largest step SDF: the middle of a stone, not its
    edge: a foot tracking a few cm off lands on the stone still) when no spot on it has snap_clearance_m;
    snap_spread_m: a front foot's forward candidate and a hind foot's backward one count this much nearer (m; the
    stance stays long, not all four feet on one stone with the body's weight near a hind foot);
    reuse_radius_m: a slot whose nominal foothold moved less than this since the last replan (same maps) keeps its
    planes; max_rounds: solve-add rounds;
    softened_tol_m: a slack above this counts as softened.
    """

    n_steps: int = 8
    w_nominal: float = 10.0
    w_body_shift: float = 40.0
    max_body_shift_m: float = 0.10
    weights: tuple[float, ...] = (1e4, 1e4, 3e3, 30.0, 3e3, 1e3, 1e3, 100.0)
    margin_m: float = 0.04
    foot_body_clearance_m: float = 0.05
    body_radius_m: float = 0.15
    max_foot_accel: float = 40.0
    stride_box_m: tuple[float, float] = (0.45, 0.25)
    leg_length_m: float = 0.68
    hip_height_m: float = 0.52
    self_lateral_m: float = 0.10
    self_longitudinal_m: float = 0.25
    self_taper: float = 0.0
    cop_fraction: float = 0.1
    cop_margin_m: float = 0.0
    balance_lateral_m: float = 0.04
    balance_margin_m: float = 0.05
    keep_planes: int = 4
    keep_clearance_m: float = 0.01
    max_retargets: int = 4
    reach_search_m: float = 0.5
    snap_search_m: float = 0.0
    snap_clearance_m: float = 0.06
    snap_ahead_m: float = 0.40
    snap_behind_m: float = 0.25
    snap_hold_m: float = 0.08
    snap_lateral_m: float = 0.0
    snap_middle: bool = False
    snap_spread_m: float = 0.0
    reuse_radius_m: float = 0.05
    max_rounds: int = 10
    softened_tol_m: float = 2e-3
    w_slack_quadratic: float = 100.0
    rho: float = 0.1
    eps_abs: float = 1e-4
    eps_rel: float = 1e-4
    max_iter: int = 4000


@dataclass(frozen=True, eq=False)
class StepRequest:
    """What one replan needs (world frame, times from now).

    legs: (K,) leg of each slot, in touchdown order, every leg once per 4 slots; t_liftoff, t_touchdown: (K,) (s;
    a liftoff <= 0 means the leg is swinging now); p_nominal: (K, 2) nominal footholds (m); p_hip: (K, 2) hip xy at
    touchdown (m); hip_height: (K,) hip above the nominal ground at touchdown (m); c_body: (K, 2) body xy in the
    middle of the support phase after touchdown k (m); yaw_body: (K,) body yaw then (rad); p_feet: (4, 2) feet now
    (m); v_feet: (4, 2) feet velocities now (m/s); t_now: the time of the request (s, any clock; NaN: unknown), with
    which a swing in flight is recognized from one replan to the next (see StepQPParams.snap_hold_m).
    """

    legs: NDArray[np.intp]
    t_liftoff: NDArray[np.float64]
    t_touchdown: NDArray[np.float64]
    p_nominal: NDArray[np.float64]
    p_hip: NDArray[np.float64]
    hip_height: NDArray[np.float64]
    c_body: NDArray[np.float64]
    yaw_body: NDArray[np.float64]
    p_feet: NDArray[np.float64]
    v_feet: NDArray[np.float64]
    t_now: float = float("nan")


@dataclass(frozen=True, eq=False)
class StepPlan:
    """The answer. footholds: (K, 3) world (m; z from the ground height map); legs, t_touchdown as requested;
    body_shift: (K, 2) body offsets (m); slack: {family: max slack (m)}; softened: families whose slack exceeds
    the tolerance; hard_softened: those among the hard ones; in_no_step: (K,) footholds on no-step cells;
    rounds: solves done; status: OSQP's last status; solve_ms: the whole replan; bare_solver_ms: OSQP solves only;
    p_nominal: (K, 2) the nominal footholds the QP started from (after snapping, m)."""

    footholds: NDArray[np.float64]
    legs: NDArray[np.intp]
    t_touchdown: NDArray[np.float64]
    body_shift: NDArray[np.float64]
    slack: dict[str, float]
    softened: tuple[str, ...]
    hard_softened: tuple[str, ...]
    in_no_step: NDArray[np.bool_]
    rounds: int
    status: str
    solve_ms: float
    bare_solver_ms: float
    p_nominal: NDArray[np.float64] | None = None


_RAYS = np.stack([np.cos(np.arange(16) * np.pi / 8), np.sin(np.arange(16) * np.pi / 8)], axis=1)
_OCT_N = np.stack([np.cos(np.arange(8) * np.pi / 4), np.sin(np.arange(8) * np.pi / 4)], axis=1)


class _Block(NamedTuple):
    """One constraint family's rows: vars_of[k]: the variables of slot k's rows (the slack last); ents[k][i]: the
    constraint matrix entries of row i of slot k, one per variable; rows[k][i]: its row index; pos[k]: each of
    vars_of[k]'s variables but the slack -> its place in the row."""

    vars_of: list[list[int]]
    ents: list[list[NDArray[np.intp]]]
    rows: list[list[int]]
    pos: list[dict[int, int]]


class StepQP:
    """The step QP, built once with a fixed sparsity pattern; `solve` updates it in place and warm-starts."""

    def __init__(self, params: StepQPParams | None = None) -> None:
        self.params = p = params or StepQPParams()
        if len(p.weights) != len(FAMILIES):
            raise ValueError(f"StepQPParams.weights: need {len(FAMILIES)} values ({', '.join(FAMILIES)})")
        K = self.K = p.n_steps
        if K < 4:
            raise ValueError("StepQPParams.n_steps: need at least 4 slots (one per leg)")
        nf = len(FAMILIES)
        self.n_var = 4 * K + nf * K
        self._ip = lambda k: 2 * k  # noqa: E731
        self._idc = lambda k: 2 * K + 2 * k  # noqa: E731
        self._is = lambda k, fam: 4 * K + nf * k + _F[fam]  # noqa: E731

        rows: list[int] = []
        cols: list[int] = []
        self._n_rows = 0

        def add_row(var_idx: list[int]) -> tuple[int, list[int]]:
            r = self._n_rows
            self._n_rows += 1
            ent = []
            for c in var_idx:
                ent.append(len(rows))
                rows.append(r)
                cols.append(c)
            return r, ent

        def p_of(k: int) -> list[int]:
            return [self._ip(k), self._ip(k) + 1]

        def dc_of(k: int) -> list[int]:
            return [self._idc(k), self._idc(k) + 1]

        def recent(k: int, span: int) -> list[int]:
            """Variables of slots k-span+1 .. k that exist (a superset pattern for any 4-leg order)."""
            out: list[int] = []
            for j in range(k - span + 1, k + 1):
                if j >= 0:
                    out += p_of(j)
            return out

        # Per family: the variables of each slot's rows, and per row its entry indices (one per variable, in that
        # order) and its row index, for the per-replan filling.
        def block(n_rows: int, vars_of: list[list[int]]) -> _Block:
            ents: list[list[NDArray[np.intp]]] = [[] for _ in range(K)]
            rows: list[list[int]] = [[] for _ in range(K)]
            for k in range(K):
                for _i in range(n_rows):
                    r, ent = add_row(vars_of[k])
                    rows[k].append(r)
                    ents[k].append(np.asarray(ent, dtype=np.intp))
            pos = [{v: i for i, v in enumerate(vars_k[:-1])} for vars_k in vars_of]
            return _Block(vars_of, ents, rows, pos)

        # reach_rect: p_k, p_{k-4}, slack
        self.b_rect = block(
            4, [p_of(k) + (p_of(k - 4) if k >= 4 else []) + [self._is(k, "reach_rect")] for k in range(K)]
        )
        # reach_oct's coefficients never change (the octagon's normals on p_k - dc_k, the slack): set once, below.
        self.b_oct = block(8, [p_of(k) + dc_of(k) + [self._is(k, "reach_oct")] for k in range(K)])
        self.b_keep = block(p.keep_planes, [p_of(k) + [self._is(k, "step_keep")] for k in range(K)])
        self.b_margin = block(p.keep_planes, [p_of(k) + [self._is(k, "margin")] for k in range(K)])
        self.b_fbody = block(1, [p_of(k) + [self._is(k, "body_keep")] for k in range(K)])
        self.b_cbody = block(1, [dc_of(k) + [self._is(k, "body_keep")] for k in range(K)])
        self.b_self = block(2, [recent(k, 4) + [self._is(k, "self_coll")] for k in range(K)])
        self.b_cop = block(4, [recent(k, 4) + dc_of(k) + [self._is(k, "cop")] for k in range(K)])
        self.b_bal = block(4, [recent(k, 4) + dc_of(k) + [self._is(k, "balance")] for k in range(K)])
        # Bounds: slacks >= 0, |dc| <= max shift.
        self.r_bounds = []
        for v in range(2 * K, self.n_var):
            r, _ = add_row([v])
            self.r_bounds.append(r)
        self.n_rows = self._n_rows
        nnz = len(rows)
        coo = sparse.coo_matrix(
            (np.arange(1, nnz + 1, dtype=np.float64), (rows, cols)), shape=(self.n_rows, self.n_var)
        )
        csc = coo.tocsc()
        csc.sort_indices()
        order = csc.data.astype(np.intp) - 1  # entry index at each CSC slot
        self._perm = order
        self._vals = np.zeros(nnz)  # the matrix values by entry index (add_row's order)
        self.A = csc.copy()
        self.l = np.full(self.n_rows, -np.inf)
        self.u = np.full(self.n_rows, np.inf)
        # Bound rows.
        for v, r in zip(range(2 * K, self.n_var), self.r_bounds, strict=True):
            ent = np.flatnonzero(np.asarray(rows) == r)
            self._vals[ent] = 1.0
            if v < 4 * K:
                self.l[r], self.u[r] = -p.max_body_shift_m, p.max_body_shift_m
            else:
                self.l[r], self.u[r] = 0.0, np.inf
        # reach_oct rows: n·p_k - n·dc_k - slack <= bound, for the octagon's 8 normals n.
        self._oct_rows = np.asarray(self.b_oct.rows, dtype=np.intp)  # (K, 8)
        for k in range(K):
            for i, n in enumerate(_OCT_N):
                self._vals[self.b_oct.ents[k][i]] = [n[0], n[1], -n[0], -n[1], -1.0]
        # Rows cleared at each replan before the keep-out planes and body rows are set again.
        self._clear_ents = np.concatenate(
            [e for b in (self.b_keep, self.b_margin, self.b_fbody, self.b_cbody) for ek in b.ents for e in ek]
        )
        self._clear_rows = np.asarray(
            [
                r
                for b in (self.b_keep, self.b_margin, self.b_fbody, self.b_cbody)
                for rk in b.rows
                for r in rk
            ],
            dtype=np.intp,
        )
        # The keep-out and margin rows' entries (K, keep_planes, 3: p_k's x, y, the slack) and rows (K, keep_planes),
        # for setting many planes in one indexing.
        self._keep_ents = np.asarray(self.b_keep.ents, dtype=np.intp)
        self._margin_ents = np.asarray(self.b_margin.ents, dtype=np.intp)
        self._keep_rows = np.asarray(self.b_keep.rows, dtype=np.intp)
        self._margin_rows = np.asarray(self.b_margin.rows, dtype=np.intp)
        support = (self.b_cop, self.b_bal)
        self._support_ents = np.concatenate([e for b in support for ek in b.ents for e in ek])
        self._support_rows = np.asarray([r for b in support for rk in b.rows for r in rk], dtype=np.intp)
        # Cost.
        diag = np.full(self.n_var, 2 * p.w_slack_quadratic)
        diag[: 2 * K] = 2 * p.w_nominal
        diag[2 * K : 4 * K] = 2 * p.w_body_shift
        self.P = sparse.diags(diag).tocsc()
        self.q = np.zeros(self.n_var)
        for k in range(K):
            for fam in FAMILIES:
                self.q[self._is(k, fam)] = p.weights[_F[fam]]
        self._keep_planes: list[list[tuple[NDArray[np.float64], float]]] = [[] for _ in range(K)]
        self._x_prev: NDArray[np.float64] | None = None
        self._prev_maps: TerrainMaps | None = None
        # Per leg: (touchdown time on the request's clock, where that swing was sent) of the last snapped swing.
        self._snapped: list[tuple[float, NDArray[np.float64]] | None] = [None] * 4
        self._prev_slots: list[tuple[int, NDArray[np.float64], list[tuple[NDArray[np.float64], float]]]] = []
        # Placeholder values so the pattern survives setup; real values come with the first update.
        self.A.data[:] = 1.0
        self.solver = osqp.OSQP()
        self.solver.setup(
            self.P, self.q, self.A, self.l, self.u,
            eps_abs=p.eps_abs, eps_rel=p.eps_rel, max_iter=p.max_iter, polishing=False, verbose=False,
            warm_starting=True, adaptive_rho=True, check_termination=5, rho=p.rho,
        )  # fmt: skip
        self.last_bare_ms = 0.0
        # rows' coefficients gathered while _fill_static runs: (entry index arrays, their values in order)
        self._batch: tuple[list[NDArray[np.intp]], list[float]] | None = None
        self._td_l: list[float] = []

    # -- value filling ------------------------------------------------------------------------------------------

    def _set_row(self, block: _Block, k: int, i: int, coeffs: list[float], lo: float, hi: float) -> None:
        if self._batch is None:
            self._vals[block.ents[k][i]] = coeffs
        else:  # gathered, set in one indexing by _flush (_fill_static sets each row at most once)
            self._batch[0].append(block.ents[k][i])
            self._batch[1].extend(coeffs)
        r = block.rows[k][i]
        self.l[r], self.u[r] = lo, hi

    def _flush(self) -> None:
        """Sets the gathered rows' coefficients (see _set_row) and stops gathering."""
        batch, self._batch = self._batch, None
        if batch is not None and batch[0]:
            self._vals[np.concatenate(batch[0])] = batch[1]

    def _set_keep_row(self, k: int, i: int, g: NDArray[np.float64], b: float) -> None:
        """Step keep-out plane i of slot k: g·p >= b + keep_clearance (hard), >= b + margin (soft)."""
        p = self.params
        coeffs = [g[0], g[1], 1.0]  # the rows' variables: p_k (x, y), the slack
        self._set_row(self.b_keep, k, i, coeffs, b + p.keep_clearance_m, np.inf)
        self._set_row(self.b_margin, k, i, coeffs, b + p.margin_m, np.inf)

    def _set_region_rows(self, regions: list[tuple[NDArray[np.float64], NDArray[np.float64]] | None]) -> None:
        """Every slot's region as its keep-out and margin rows (see _set_keep_row), all slots in one indexing
        (the keep and margin rows cleared before)."""
        p = self.params
        if len(regions) != self.K:
            raise ValueError(
                f"StepQP.solve: regions: need {self.K} entries (one per slot), got {len(regions)}"
            )
        slots, planes, gs, bs = [], [], [], []
        for k, r in enumerate(regions):
            if r is None:
                self._keep_planes[k] = []
                continue
            g, b = _region_arrays(r, p.keep_clearance_m, p.keep_planes)
            self._keep_planes[k] = list(zip(g, b.tolist(), strict=True))
            slots.append(np.full(len(b), k, dtype=np.intp))
            planes.append(np.arange(len(b), dtype=np.intp))
            gs.append(g)
            bs.append(b)
        if not slots:
            return
        ks, js = np.concatenate(slots), np.concatenate(planes)
        g_all, b_all = np.concatenate(gs), np.concatenate(bs)
        coeffs = np.column_stack([g_all, np.ones(len(b_all))])
        self._vals[self._keep_ents[ks, js]] = coeffs
        self._vals[self._margin_ents[ks, js]] = coeffs
        self.l[self._keep_rows[ks, js]] = b_all + p.keep_clearance_m
        self.l[self._margin_rows[ks, js]] = b_all + p.margin_m

    def _clear_row(self, block: _Block, k: int, i: int) -> None:
        if self._batch is None:
            self._vals[block.ents[k][i]] = 0.0
        else:
            self._batch[0].append(block.ents[k][i])
            self._batch[1].extend([0.0] * len(block.ents[k][i]))
        r = block.rows[k][i]
        self.l[r], self.u[r] = -np.inf, np.inf

    def _coeff_on(self, block: _Block, k: int, var_coeffs: dict[int, float], slack: float) -> list[float]:
        """Gives the row's coefficient list in the block's variable order (the slack is the last variable; a
        variable the block's rows do not hold is left out)."""
        pos = block.pos[k]
        out = [0.0] * (len(pos) + 1)
        for v, c in var_coeffs.items():
            i = pos.get(v)
            if i is not None:
                out[i] = c
        out[-1] = slack
        return out

    # -- the replan ---------------------------------------------------------------------------------------------

    def solve(
        self,
        req: StepRequest,
        maps: TerrainMaps | None,
        regions: list[tuple[NDArray[np.float64], NDArray[np.float64]] | None] | None = None,
    ) -> StepPlan:
        """Gives the step plan for `req` on `maps` (None: no terrain constraints).

        regions: per slot (K) a convex region (A (m, 2), b (m,): A p <= b; None: the slot is free) in which the
        foothold must lie (hard, the step_keep family; the margin family pulls it margin_m - keep_clearance_m
        further in, soft). With regions the keep-out planes are not searched and there is no snapping: one solve."""
        t0 = time.perf_counter()
        p = self.params
        K = self.K
        self._check(req)
        legs = np.asarray(req.legs, dtype=np.intp)
        if maps is not None and p.snap_search_m > 0.0 and regions is None:
            req = self._snap(req, legs, maps)
        self._fixed_feet = np.asarray(req.p_feet, dtype=np.float64)
        # Cost toward the nominal footholds.
        self.q[: 2 * K] = -2 * p.w_nominal * req.p_nominal.reshape(-1)
        self._fill_static(req, legs)
        # Keep-out planes found in the last replan on the same maps carry over to the slot with the same leg and
        # nearly the same nominal foothold (the active set's warm start); the others start empty.
        reuse = maps is not None and maps is self._prev_maps
        prev = self._prev_slots if reuse and regions is None else []
        carried: list[list[tuple[NDArray[np.float64], float]]] = []
        for k in range(K):
            match: list[tuple[NDArray[np.float64], float]] = []
            for leg, p_nom, planes in prev:
                if leg == legs[k] and float(np.sum((p_nom - req.p_nominal[k]) ** 2)) < p.reuse_radius_m**2:
                    match = list(planes)
                    break
            carried.append(match)
        self._retargets = [0] * K
        self._tried: list[list[NDArray[np.float64]]] = [[] for _ in range(K)]
        # Every keep-out, margin and body row cleared at once, then the planes that stand set again.
        self._vals[self._clear_ents] = 0.0
        self.l[self._clear_rows] = -np.inf
        self.u[self._clear_rows] = np.inf
        if regions is not None:
            self._set_region_rows(regions)
        else:
            for k in range(K):
                self._keep_planes[k] = carried[k]
                for i in range(min(len(self._keep_planes[k]), p.keep_planes)):
                    self._set_keep_row(k, i, *self._keep_planes[k][i])
        bare = 0.0
        rounds = 0
        x = None
        status = ""
        for rounds in range(1, p.max_rounds + 1):  # noqa: B007 (reported)
            self.solver.update(q=self.q, l=self.l, u=self.u, Ax=self._vals[self._perm])
            if self._x_prev is not None:
                self.solver.warm_start(x=self._x_prev)
            tb = time.perf_counter()
            res = self.solver.solve(raise_error=False)
            bare += time.perf_counter() - tb
            status = str(res.info.status)
            if res.x is None or not np.all(np.isfinite(res.x)):
                break
            x = res.x
            self._x_prev = x.copy()
            if maps is None or regions is not None or not self._add_keep_outs(x, req, maps):
                break
        if x is None:
            x = np.concatenate([req.p_nominal.reshape(-1), np.zeros(self.n_var - 2 * K)])
        self._prev_maps = maps
        self._prev_slots = [
            (int(legs[k]), req.p_nominal[k].copy(), list(self._keep_planes[k])) for k in range(K)
        ]
        feet = x[: 2 * K].reshape(K, 2)
        slack_all = x[4 * K :].reshape(K, len(FAMILIES))
        top = slack_all.max(axis=0).tolist()  # each family's largest slack over the slots
        slack = {fam: float(max(0.0, top[_F[fam]])) for fam in FAMILIES}
        softened = tuple(f for f in FAMILIES if slack[f] > p.softened_tol_m)
        if maps is not None:
            z = np.asarray(maps.height_at(feet[:, 0], feet[:, 1]), dtype=np.float64)
            in_no_step = np.asarray(maps.no_step(feet[:, 0], feet[:, 1]), dtype=bool)
        else:
            z = np.zeros(K)
            in_no_step = np.zeros(K, dtype=bool)
        self.last_bare_ms = bare * 1e3
        return StepPlan(
            footholds=np.column_stack([feet, z]),
            legs=legs.copy(),
            t_touchdown=np.asarray(req.t_touchdown, dtype=np.float64).copy(),
            body_shift=x[2 * K : 4 * K].reshape(K, 2).copy(),
            slack=slack,
            softened=softened,
            hard_softened=tuple(f for f in softened if f in HARD),
            in_no_step=in_no_step,
            rounds=rounds,
            status=status,
            solve_ms=(time.perf_counter() - t0) * 1e3,
            bare_solver_ms=bare * 1e3,
            p_nominal=np.asarray(req.p_nominal, dtype=np.float64).copy(),
        )

    def _check(self, req: StepRequest) -> None:
        K = self.K
        shapes = {
            "legs": (K,), "t_liftoff": (K,), "t_touchdown": (K,), "p_nominal": (K, 2), "p_hip": (K, 2),
            "hip_height": (K,), "c_body": (K, 2), "yaw_body": (K,), "p_feet": (4, 2), "v_feet": (4, 2),
        }  # fmt: skip
        for name, shape in shapes.items():
            a = np.asarray(getattr(req, name))
            if a.shape != shape:
                raise ValueError(f"StepRequest.{name}: expected shape {shape}, got {a.shape}")
            if not np.isfinite(a).all():
                raise ValueError(f"StepRequest.{name}: contains NaN or inf")
        legs = np.asarray(req.legs)
        if np.any((legs < 0) | (legs > 3)):
            raise ValueError("StepRequest.legs: leg indices must be 0..3 (FL, FR, RL, RR)")
        for k in range(4, K):
            if legs[k] != legs[k - 4]:
                raise ValueError(
                    "StepRequest.legs: every leg must step once per 4 slots (legs[k] == legs[k-4])"
                )

    def _fill_static(self, req: StepRequest, legs: NDArray[np.intp]) -> None:
        """Rows whose values do not depend on the iterate: reach, self-collision, CoP, balance (their coefficients
        gathered and set in one indexing at the end)."""
        self._batch = ([], [])
        try:
            self._fill_static_rows(req, legs)
        finally:
            self._flush()

    def _fill_static_rows(self, req: StepRequest, legs: NDArray[np.intp]) -> None:
        p = self.params
        K = self.K
        # reach_oct: n·(p - hip - dc) <= r cos(pi/8) ... the inscribed octagon of the reach circle (its
        # coefficients are set once; the bounds of all slots at once).
        dz = np.asarray(req.hip_height, dtype=np.float64)
        r = np.sqrt(np.maximum(p.leg_length_m**2 - dz**2, 1e-4)) * np.cos(np.pi / 8)
        self.l[self._oct_rows] = -np.inf
        # cop and balance rows: cleared for every slot; _fill_support sets those that stand.
        self._vals[self._support_ents] = 0.0
        self.l[self._support_rows] = -np.inf
        self.u[self._support_rows] = np.inf
        # n·hip as two products and a sum per row, all rows at once (not a matrix product, which may round
        # differently).
        p_hip = np.asarray(req.p_hip, dtype=np.float64)
        self.u[self._oct_rows] = r[:, None] + (p_hip[:, 0:1] * _OCT_N[:, 0] + p_hip[:, 1:2] * _OCT_N[:, 1])
        t_td = req.t_touchdown
        t_lo = req.t_liftoff
        # the slots of each leg, and the times as Python floats, for the stance lookups below
        slots_of = [[int(j) for j in np.flatnonzero(legs == leg)] for leg in range(4)]
        lo_l, td_l = np.asarray(t_lo, dtype=np.float64).tolist(), np.asarray(t_td, dtype=np.float64).tolist()
        self._td_l = td_l
        # the body's heading per slot (its cosine and sine as Python floats), the feet now and their velocities
        cos_l = np.cos(np.asarray(req.yaw_body, dtype=np.float64)).tolist()
        sin_l = np.sin(np.asarray(req.yaw_body, dtype=np.float64)).tolist()
        feet_l = np.asarray(req.p_feet, dtype=np.float64).tolist()
        vfeet_l = np.asarray(req.v_feet, dtype=np.float64).tolist()
        for k in range(K):
            leg = int(legs[k])
            cy, sy = cos_l[k], sin_l[k]
            ip = self._ip(k)
            # reach_rect (on Python floats: e·center as two products and a sum)
            if k < 4:
                fx, fy = feet_l[leg]
                if lo_l[k] <= 0.0:  # swinging now: dynamics of the swing foot
                    T = max(td_l[k], 0.0)
                    vx, vy = vfeet_l[leg]
                    fx, fy = fx + vx * T, fy + vy * T
                    half = 0.5 * p.max_foot_accel * T * T
                    rect = ((1.0, 0.0, half), (0.0, 1.0, half))
                else:
                    rect = ((cy, sy, p.stride_box_m[0]), (-sy, cy, p.stride_box_m[1]))
                # Rows on (p_k, slack): e·p_k - s <= c + h and e·p_k + s >= c - h.
                for a, (e0, e1, h) in enumerate(rect):
                    c = e0 * fx + e1 * fy
                    self._set_row(self.b_rect, k, 2 * a, [e0, e1, -1.0], -np.inf, c + h)
                    self._set_row(self.b_rect, k, 2 * a + 1, [e0, e1, 1.0], c - h, np.inf)
            else:
                # Rows on (p_k, p_{k-4}, slack): the stride box around the leg's previous foothold.
                for a, (e0, e1, h) in enumerate(((cy, sy, p.stride_box_m[0]), (-sy, cy, p.stride_box_m[1]))):
                    self._set_row(self.b_rect, k, 2 * a, [e0, e1, -e0, -e1, -1.0], -np.inf, h)
                    self._set_row(self.b_rect, k, 2 * a + 1, [e0, e1, -e0, -e1, 1.0], -h, np.inf)
            # Where every leg stands at touchdown k and in the middle of phase k.
            t_mid = self._phase_mid(k, td_l)
            stance_td = self._stance(k, td_l[k], slots_of, lo_l, td_l)
            stance_mid = self._stance(k, t_mid, slots_of, lo_l, td_l)
            # self_coll: lateral and longitudinal neighbors at touchdown, in the body frame at touchdown (on Python
            # floats: e·ref as two products and a sum).
            side = 1.0 if LEG_IS_LEFT[leg] else -1.0
            front = 1.0 if LEG_IS_FRONT[leg] else -1.0
            for i, (nb, e0, e1, d_min) in enumerate(
                ((LATERAL_NEIGHBOR[leg], -sy * side, cy * side, p.self_lateral_m),
                 (LONGITUDINAL_NEIGHBOR[leg], cy * front, sy * front, p.self_longitudinal_m))
            ):  # fmt: skip
                ref = stance_td.get(int(nb))
                if ref is None:
                    self._clear_row(self.b_self, k, i)
                    continue
                vc = {ip: e0, ip + 1: e1}
                lo = d_min
                if isinstance(ref, int):
                    jp = self._ip(ref)
                    vc[jp] = vc.get(jp, 0.0) - e0
                    vc[jp + 1] = vc.get(jp + 1, 0.0) - e1
                else:
                    lo += e0 * float(ref[0]) + e1 * float(ref[1])
                self._set_row(self.b_self, k, i, self._coeff_on(self.b_self, k, vc, 1.0), lo, np.inf)
            # cop and balance around the body point of phase k.
            self._fill_support(k, req, stance_mid)

    @staticmethod
    def _phase_mid(k: int, t_td: list[float]) -> float:
        later = [t for t in t_td if t > t_td[k] + 1e-6]
        t_next = min(later) if later else t_td[k] + 0.2
        return 0.5 * (t_td[k] + t_next)

    def _stance(
        self, k: int, t: float, slots_of: list[list[int]], t_lo: list[float], t_td: list[float]
    ) -> dict[int, int | NDArray[np.float64]]:
        """Gives {leg: slot index or fixed xy} for the legs in stance at time t (slots up to k only); slots_of[leg]:
        that leg's slots."""
        out: dict[int, int | NDArray[np.float64]] = {}
        t_landed = t + 1e-9
        for leg, slots in enumerate(slots_of):
            last = -1  # the latest slot landed by t (-1: none)
            for j in slots:
                if t_lo[j] <= t < t_td[j]:
                    break  # swinging
                if t_td[j] <= t_landed and j > last:
                    last = j
            else:
                if last < 0:
                    out[leg] = self._fixed_feet[leg]
                elif last <= k:
                    out[leg] = last
        return out

    def _fill_support(self, k: int, req: StepRequest, stance: dict[int, int | NDArray[np.float64]]) -> None:
        """The cop and balance rows of phase k (on Python floats: each 2-vector dot as two products and a sum)."""
        p = self.params
        # (its cop and balance rows were cleared by _fill_static, all slots at once)
        n_st = len(stance)
        if n_st < 2:
            return
        td = self._td_l  # the touchdown times as Python floats (set by _fill_static_rows)
        t_k = td[k]
        if any(abs(t - t_k) < 1e-6 for t in td[k + 1 :]):
            return  # a later slot lands at the same time: its phase carries the rows
        cx, cy = (float(v) for v in req.c_body[k])
        idc = self._idc(k)
        nominal = {
            leg: (req.p_nominal[ref] if isinstance(ref, int) else ref).tolist() for leg, ref in stance.items()
        }
        row = self._support_row
        if n_st == 2:
            a, b = sorted(stance)
            d0, d1 = nominal[b][0] - nominal[a][0], nominal[b][1] - nominal[a][1]
            L = math.sqrt(d0 * d0 + d1 * d1)
            if L < 1e-6:
                return
            d0, d1 = d0 / L, d1 / L
            n0, n1 = -d1, d0
            lam = p.cop_fraction * L
            dc = d0 * cx + d1 * cy
            # d·(c + dc - p_a) >= lam
            coeffs, const = row(self.b_cop, k, idc, d0, d1, ((a, -d0, -d1),), stance)
            self._set_row(self.b_cop, k, 0, coeffs, lam - dc - const, np.inf)
            # d·(p_b - c - dc) >= lam
            coeffs, const = row(self.b_cop, k, idc, -d0, -d1, ((b, d0, d1),), stance)
            self._set_row(self.b_cop, k, 1, coeffs, lam + dc - const, np.inf)
            # |n·(c + dc - (p_a + p_b)/2)| <= balance_lateral
            nc = n0 * cx + n1 * cy
            for i, sgn in ((0, 1.0), (1, -1.0)):
                h = -0.5 * sgn
                w0, w1 = h * n0, h * n1
                coeffs, const = row(
                    self.b_bal, k, idc, sgn * n0, sgn * n1, ((a, w0, w1), (b, w0, w1)), stance
                )
                lo = -p.balance_lateral_m - sgn * nc - const
                self._set_row(self.b_bal, k, i, coeffs, lo, np.inf)
            return
        # Three or four feet: the support polygon of the nominal positions, counterclockwise.
        order = list(stance)
        pts = np.array([nominal[leg] for leg in order])
        ctr = pts.mean(axis=0)
        ang = np.arctan2(pts[:, 1] - ctr[1], pts[:, 0] - ctr[0])
        ccw = [order[i] for i in np.argsort(ang)]
        for i in range(len(ccw)):
            la, lb = ccw[i], ccw[(i + 1) % len(ccw)]
            e0, e1 = nominal[lb][0] - nominal[la][0], nominal[lb][1] - nominal[la][1]
            L = math.sqrt(e0 * e0 + e1 * e1)
            if L < 1e-6:
                continue
            n0, n1 = -e1 / L, e0 / L  # inward for a counterclockwise polygon
            nc = n0 * cx + n1 * cy
            for blk, m in ((self.b_cop, p.cop_margin_m), (self.b_bal, p.balance_margin_m)):
                coeffs, const = row(blk, k, idc, n0, n1, ((la, -n0, -n1),), stance)
                self._set_row(blk, k, i, coeffs, m - nc - const, np.inf)

    def _support_row(
        self,
        block: _Block,
        k: int,
        idc: int,
        c0: float,
        c1: float,
        terms: tuple[tuple[int, float, float], ...],
        stance: dict[int, int | NDArray[np.float64]],
    ) -> tuple[list[float], float]:
        """Gives a cop or balance row of slot k: its coefficients in the block's variable order (c0, c1 on the body
        shift idc, idc + 1; w·p_leg for each term (leg, w0, w1) of a leg whose foothold is a variable; the slack 1)
        and its constant (the terms' w·p of the fixed feet, summed in order; 0 for the others)."""
        pos = block.pos[k]
        out = [0.0] * (len(pos) + 1)
        out[-1] = 1.0
        i = pos.get(idc)
        if i is not None:
            out[i] = c0
        i = pos.get(idc + 1)
        if i is not None:
            out[i] = c1
        consts: list[float] = []
        for leg, w0, w1 in terms:
            ref = stance[leg]
            if isinstance(ref, int):
                jp = self._ip(ref)
                # (a leg's slot is never the body's shift nor another term's: each variable is set once; 0.0 + w
                # as the dictionary's accumulation gave)
                i = pos.get(jp)
                if i is not None:
                    out[i] = 0.0 + w0
                i = pos.get(jp + 1)
                if i is not None:
                    out[i] = 0.0 + w1
                consts.append(0.0)
            else:
                consts.append(w0 * float(ref[0]) + w1 * float(ref[1]))
        return out, (consts[0] if len(consts) == 1 else consts[0] + consts[1])

    def _snap(self, req: StepRequest, legs: NDArray[np.intp], maps: TerrainMaps) -> StepRequest:
        """Gives the request with its nominal footholds moved off no-step regions along the heading (see
        snap_footholds); a leg in the air keeps the side it was sent to while that is still a candidate."""
        p = self.params
        hold: list[NDArray[np.float64] | None] = [None] * self.K
        t_td = float(req.t_now) + np.asarray(req.t_touchdown, dtype=np.float64)
        for k in range(4):
            last = self._snapped[int(legs[k])]
            if req.t_liftoff[k] <= 0.0 and last is not None and abs(last[0] - t_td[k]) < 0.05:
                hold[k] = last[1]
        p_nom, moved = snap_footholds(
            maps, req.p_nominal, req.yaw_body, req.p_hip, (p.snap_behind_m, p.snap_ahead_m), p.snap_search_m,
            p.snap_clearance_m, hold, p.snap_hold_m, p.snap_lateral_m, p.snap_middle,
            np.where(np.asarray(legs) < 2, p.snap_spread_m, -p.snap_spread_m),
        )  # fmt: skip
        for k in range(4):
            leg = int(legs[k])
            ok = req.t_liftoff[k] <= 0.0 and moved[k] and np.isfinite(t_td[k])
            self._snapped[leg] = (float(t_td[k]), p_nom[k].copy()) if ok else None
        if not np.any(moved):
            return req
        return dataclasses.replace(req, p_nominal=p_nom)

    # -- keep-out planes ----------------------------------------------------------------------------------------

    def _add_keep_outs(self, x: NDArray[np.float64], req: StepRequest, maps: TerrainMaps) -> bool:
        """Adds the nearest boundary's half-plane for every foothold in (or within the margin of) a no-step region,
        and body keep-outs; gives whether any was added."""
        p = self.params
        K = self.K
        feet = x[: 2 * K].reshape(K, 2)
        sd = np.atleast_1d(maps.sdf_step(feet[:, 0], feet[:, 1]))
        grad = np.atleast_2d(maps.sdf_step_grad(feet[:, 0], feet[:, 1]))
        sdb = np.atleast_1d(maps.sdf_body(feet[:, 0], feet[:, 1]))
        gradb = np.atleast_2d(maps.sdf_body_grad(feet[:, 0], feet[:, 1]))
        c = req.c_body + x[2 * K : 4 * K].reshape(K, 2)
        sdc = np.atleast_1d(maps.sdf_body(c[:, 0], c[:, 1]))
        gradc = np.atleast_2d(maps.sdf_body_grad(c[:, 0], c[:, 1]))
        snap = p.snap_search_m > 0.0
        if snap:
            p_nom = req.p_nominal
            sd_nom = np.atleast_1d(maps.sdf_step(p_nom[:, 0], p_nom[:, 1]))
            grad_nom = np.atleast_2d(maps.sdf_step_grad(p_nom[:, 0], p_nom[:, 1]))
        added = False
        tol = 1e-3
        slack_keep = x[4 * K + _F["step_keep"] :: len(FAMILIES)]
        for k in range(K):
            ip = self._ip(k)
            planes = self._keep_planes[k]
            stuck = slack_keep[k] > p.softened_tol_m and bool(planes)
            full = len(planes) >= p.keep_planes
            if np.isfinite(sd[k]) and sd[k] < p.margin_m - tol and (stuck or full):
                # The planes found so far cannot be met together (or there is no room for another): aim at a free
                # spot instead, the one nearest the nominal foothold among those reachable in a straight line from
                # here that were not aimed at already, and keep only the planes that spot satisfies.
                if self._retargets[k] < p.max_retargets:
                    heading = float(req.yaw_body[k]) if snap else None
                    target = self._free_target(maps, feet[k], req.p_nominal[k], self._tried[k], heading)
                    if target is not None:
                        self._retargets[k] += 1
                        self._tried[k].append(target)
                        g = _unit(np.asarray(maps.sdf_step_grad(target[0], target[1])), target - feet[k])
                        q = target - float(maps.sdf_step(target[0], target[1])) * g
                        kept = [
                            (g0, b0) for g0, b0 in planes if float(g0 @ target) >= b0 + p.keep_clearance_m
                        ]
                        kept = kept[: p.keep_planes - 1] + [(g, float(g @ q))]
                        self._keep_planes[k] = planes = kept
                        for i in range(p.keep_planes):
                            if i < len(planes):
                                self._set_keep_row(k, i, *planes[i])
                            else:
                                self._clear_row(self.b_keep, k, i)
                                self._clear_row(self.b_margin, k, i)
                        added = True
            elif np.isfinite(sd[k]) and sd[k] < p.margin_m - tol:
                g = _unit(grad[k], feet[k] - req.p_nominal[k])
                q = feet[k] - sd[k] * g
                if snap and sd_nom[k] >= p.margin_m:
                    # The (snapped) nominal is free: the plane keeps the foot on the nominal's side of the
                    # boundary nearest the nominal, not on whichever side the iterate happened to fall.
                    g = _unit(grad_nom[k], feet[k] - req.p_nominal[k])
                    q = req.p_nominal[k] - sd_nom[k] * g
                if all(float(g @ g0) < 0.95 or abs(float(g @ q) - b0) > 0.01 for g0, b0 in planes):
                    i = len(planes)
                    planes.append((g, float(g @ q)))
                    self._set_keep_row(k, i, g, float(g @ q))
                    added = True
            if (
                np.isfinite(sdb[k])
                and sdb[k] < p.foot_body_clearance_m - tol
                and self.l[self.b_fbody.rows[k][0]] == -np.inf
            ):
                g = _unit(gradb[k], feet[k] - req.p_nominal[k])
                q = feet[k] - sdb[k] * g
                vc = {ip: g[0], ip + 1: g[1]}
                self._set_row(self.b_fbody, k, 0, self._coeff_on(self.b_fbody, k, vc, 1.0),
                              float(g @ q) + p.foot_body_clearance_m, np.inf)  # fmt: skip
                added = True
            if (
                np.isfinite(sdc[k])
                and sdc[k] < p.body_radius_m - tol
                and self.l[self.b_cbody.rows[k][0]] == -np.inf
            ):
                g = _unit(gradc[k], np.zeros(2))
                q = c[k] - sdc[k] * g
                idc = self._idc(k)
                vc = {idc: g[0], idc + 1: g[1]}
                lo = float(g @ q) + p.body_radius_m - float(g @ req.c_body[k])
                self._set_row(self.b_cbody, k, 0, self._coeff_on(self.b_cbody, k, vc, 1.0), lo, np.inf)
                added = True
        return added

    def _free_target(
        self,
        maps: TerrainMaps,
        p_now: NDArray[np.float64],
        p_nom: NDArray[np.float64],
        tried: list,
        heading: float | None = None,
    ) -> NDArray[np.float64] | None:
        """Gives the free spot (step SDF >= margin) nearest p_nom among the first free points along 16 rays from
        p_now, away from spots already tried; None when there is none within reach_search_m. With a heading (rad,
        snapping on) only rays within 45° of it or of its reverse are searched: a foot goes fore or aft to a
        stone, never sideways across the body's midline onto the other side's stone."""
        p = self.params
        rays = _RAYS
        if heading is not None:
            rays = rays[
                np.abs(rays @ np.array([np.cos(heading), np.sin(heading)])) >= np.cos(np.pi / 4) - 1e-9
            ]
        ts = np.arange(0.0, p.reach_search_m, maps.resolution_m / 2)
        pts = p_now[None, None, :] + ts[None, :, None] * rays[:, None, :]
        sd = np.asarray(maps.sdf_step(pts[..., 0], pts[..., 1]))
        ok = sd >= p.margin_m + p.keep_clearance_m
        has = ok.any(axis=1)
        if not has.any():
            return None
        first = np.argmax(ok, axis=1)
        cand = pts[np.arange(len(rays)), first][has]
        for t in tried:
            cand = cand[np.sum((cand - t) ** 2, axis=1) > 0.1**2]
        if cand.shape[0] == 0:
            return None
        return cand[int(np.argmin(np.sum((cand - p_nom) ** 2, axis=1)))].copy()

    _fixed_feet: NDArray[np.float64]
    _retargets: list[int]


def snap_footholds(
    maps: TerrainMaps,
    p_nominal: NDArray[np.float64],
    yaw: NDArray[np.float64],
    p_hip: NDArray[np.float64],
    hip_range_m: tuple[float, float],
    search_m: float,
    clearance_m: float,
    hold: list[NDArray[np.float64] | None] | None = None,
    hold_m: float = 0.08,
    lateral_m: float = 0.0,
    middle: bool = False,
    spread_m: NDArray[np.float64] | None = None,
) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """Moves footholds off no-step regions along the heading: gives (footholds (K, 2), moved (K,)).

    A foothold p_nominal[k] (world, m) whose step SDF is below clearance_m is moved along the heading
    (cos yaw[k], sin yaw[k]) forward and back to the first spot with that clearance on each side, up to search_m
    away, and no more than hip_range_m = (behind, ahead) (m) from the hip p_hip[k] along the heading; the nearer of the two is taken (a stepping stone's gap: onto
    the next stone or back onto the current one, never into the gap's edge). hold[k], when given, is where the
    slot was sent before: the candidate within hold_m of it wins, and when there is no candidate it stays the
    target while it is free. lateral_m: the search also runs along lines
    parallel to the heading up to this far to either side (m; the nearest candidate in distance wins), so a foothold
    near a stone's inner corner still finds the stone. A foothold with no candidate stays. middle: each side's spot
    is the first with clearance_m along the free run (SDF at least clearance_m / 2) from the first free spot on,
    or the run's largest SDF when none has (a narrow stone's middle). spread_m[k] (m): the forward candidate counts
    this much nearer (negative: the backward one, by its size).
    """
    p_out = np.array(p_nominal, dtype=np.float64, copy=True).reshape(-1, 2)
    K = p_out.shape[0]
    moved = np.zeros(K, dtype=bool)
    sd = np.atleast_1d(np.asarray(maps.sdf_step(p_out[:, 0], p_out[:, 1]), dtype=np.float64))
    on_map = np.atleast_1d(np.asarray(maps.in_map(p_out[:, 0], p_out[:, 1]), dtype=bool))
    todo = np.flatnonzero(on_map & (sd < clearance_m))
    if todo.size == 0:
        return p_out, moved
    step = 0.5 * maps.resolution_m
    ts = np.arange(step, search_m + 1e-9, step)
    lat = np.array([0.0, 1.0, -1.0, 2.0, -2.0]) * 0.5 * lateral_m
    # The search lines of every foothold to move, forward then back, each at every lateral offset: one SDF lookup.
    signs = np.array([1.0, -1.0])
    e_all = np.stack([np.cos(yaw[todo]), np.sin(yaw[todo])], axis=-1)  # (n, 2)
    n_all = np.stack([-e_all[:, 1], e_all[:, 0]], axis=-1)
    # pts[j, s, l, i] = p_out + dl * n + sign * t * e, summed in that order
    pts_all = (
        p_out[todo][:, None, None, None, :] + lat[None, None, :, None, None] * n_all[:, None, None, None, :]
    ) + (signs[None, :, None, None, None] * ts[None, None, None, :, None]) * e_all[:, None, None, None, :]
    sd_all = np.asarray(maps.sdf_step(pts_all[..., 0], pts_all[..., 1]), dtype=np.float64)
    ok_all: NDArray[np.bool_] = np.asarray(sd_all >= (0.5 * clearance_m if middle else clearance_m))
    for j, k in enumerate(todo):
        along = (pts_all[j] - p_hip[k]) @ e_all[j]
        ok_all[j] &= (along >= -hip_range_m[0]) & (along <= hip_range_m[1])
    has_all: NDArray[np.bool_] = np.asarray(ok_all.any(axis=-1))
    first_all = np.argmax(ok_all, axis=-1)
    for j, k in enumerate(todo):
        best: NDArray[np.float64] | None = None
        best_d = np.inf
        h = hold[k] if hold is not None and k < len(hold) else None
        for si, sign in enumerate(signs):
            for li, dl in enumerate(lat):
                if not has_all[j, si, li]:
                    continue
                pts = pts_all[j, si, li]
                sd_pts = sd_all[j, si, li]
                ok = ok_all[j, si, li]
                i = int(first_all[j, si, li])
                if middle:
                    run = i + int(np.argmin(ok[i:])) if not ok[i:].all() else len(ok)
                    full = sd_pts[i:run] >= clearance_m
                    i += int(np.argmax(full)) if full.any() else int(np.argmax(sd_pts[i:run]))
                d = float(np.hypot(ts[i], dl))
                if spread_m is not None and k < len(spread_m):
                    d -= sign * float(spread_m[k])
                if h is not None and float(np.linalg.norm(pts[i] - h)) <= hold_m:
                    d -= 1.0
                if d < best_d:
                    best, best_d = pts[i], d
        if best is None and h is not None and float(maps.sdf_step(h[0], h[1])) >= clearance_m:
            best = np.asarray(h, dtype=np.float64)  # no candidate now: a swing keeps the spot it was sent to
        if best is not None:
            p_out[k] = best
            moved[k] = True
    return p_out, moved


def _region_arrays(
    region: tuple[NDArray[np.float64], NDArray[np.float64]], clearance_m: float, max_planes: int
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Gives a convex region A p <= b as keep rows g (m, 2), b' (m,): g_i·p >= b'_i + clearance_m is
    -A_i·p >= -b_i."""
    A, b = np.asarray(region[0], dtype=np.float64), np.asarray(region[1], dtype=np.float64)
    if A.ndim != 2 or A.shape[1] != 2 or b.shape != (A.shape[0],):
        raise ValueError(f"StepQP.solve: a region needs A (m, 2) and b (m,), got {A.shape} and {b.shape}")
    if A.shape[0] > max_planes:
        raise ValueError(
            f"StepQP.solve: a region has {A.shape[0]} half-planes, more than keep_planes ({max_planes})"
        )
    return -A, -b - clearance_m


def _unit(g: NDArray[np.float64], fallback: NDArray[np.float64]) -> NDArray[np.float64]:
    n = float(np.linalg.norm(g))
    if n > 1e-9:
        return g / n
    n = float(np.linalg.norm(fallback))
    if n > 1e-9:
        return -fallback / n
    return np.array([1.0, 0.0])
