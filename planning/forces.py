"""Contact-force distribution: the balance controller's body wrench → per-foot contact forces (one QP a tick).

Forces are the forces the ground applies to the feet, in the world frame, legs in the order FL, FR, RL, RR.
The decision variable is scaled, x = f / (m g), so a standing robot has entries near 0.25 and the problem is well
conditioned whatever the robot's mass; torques are scaled by m g · `torque_length_m`.

The QP is built once with a fixed sparsity pattern (dense 12×12 upper-triangular cost, dense 3-column block per leg
in the constraints); each tick changes only values and bounds (`Px`, `q`, `Ax` when μ or the normals change, `l`,
`u`) and warm-starts from the previous answer. A swing leg keeps its rows and columns, but its rows get infinite
bounds and its columns drop out of the wrench map, so its optimum is exactly zero; the final clamp writes that zero
exactly. (Pinning swing legs with [0, 0] bounds is equivalent on paper but makes OSQP's adaptive ρ oscillate.)

The friction-pyramid helpers here are shared with the stance handler (planning/stance.py).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import osqp
import scipy.sparse as sp

N_LEGS = 4
OSQP_INF = 1e30  # OSQP's own infinity; bounds beyond it are clamped to it
_SOLVED = "solved"
FEASIBLE_AS_PLANNED = "feasible as planned"  # the stance handler's shortcut: the plan needed no correction
_SOLVED_INACCURATE = "solved inaccurate"
_USABLE = (_SOLVED, _SOLVED_INACCURATE)
_STOPPED_SHORT = (_SOLVED_INACCURATE, "maximum iterations reached")
_E_Z = np.array([0.0, 0.0, 1.0])


# --------------------------------------------------------------------------------------------------------------
# Status shared by the force distributor and the stance handler.


@dataclass(frozen=True, slots=True)
class SolveStatus:
    """What happened in one solve; `ok` is True when the QP answer was used as is.

    solver: OSQP's status text ("solved", "solved inaccurate", "primal infeasible", "maximum iterations reached", ...).
    iterations: ADMM iterations this tick (all attempts).
    fallback: the QP did not converge; the answer is its last iterate (or, after an infeasibility verdict, the
        requested forces) repaired into the constraints.
    fz_min_relaxed: some stance leg ended below fz_min (the torque limits did not leave room for it; stance
        handler only: the distributor's bounds are always feasible).
    torque_clipped: the torques were clipped to their limits, so they no longer equal -Jᵀf + τ_bias exactly.
    sanitized: names of input fields that held non-finite or out-of-range values and were repaired.
    """

    solver: str
    iterations: int = 0
    fallback: bool = False
    fz_min_relaxed: bool = False
    torque_clipped: bool = False
    sanitized: tuple[str, ...] = field(default_factory=tuple)

    @property
    def ok(self) -> bool:
        return (
            self.solver in (_SOLVED, FEASIBLE_AS_PLANNED)
            and not self.fallback
            and not self.fz_min_relaxed
            and not self.torque_clipped
            and not self.sanitized
        )


# --------------------------------------------------------------------------------------------------------------
# OSQP helpers, shared with planning/stance.py.


class _Solution:
    """What the callers read of an OSQP result: the primal iterate x (n,)."""

    __slots__ = ("x",)

    def __init__(self, x: np.ndarray | None) -> None:
        self.x = x


def _solve_once(solver: osqp.OSQP) -> tuple[Any, str, int]:
    """One OSQP solve: (result with .x, status text, iterations). Calls the extension directly when the wrapper
    exposes it: the wrapper's solve() copies every info field into a fresh namespace each call (~20 µs)."""
    # only a plain OSQP object: a wrapper around one (e.g. the benchmark's timer) sees its public solve() called
    ext = getattr(solver, "_solver", None) if type(solver) is osqp.OSQP else None
    if ext is None or not hasattr(ext, "solution"):
        res = solver.solve(raise_error=False)
        return res, str(res.info.status), int(res.info.iter)
    ext.solve()
    info = ext.info
    return _Solution(ext.solution.x), str(info.status), int(info.iter)


def qp_update(
    solver: osqp.OSQP,
    *,
    q: np.ndarray | None = None,
    l: np.ndarray | None = None,  # noqa: E741 - OSQP's name
    u: np.ndarray | None = None,
    Px: np.ndarray | None = None,
    Ax: np.ndarray | None = None,
) -> None:
    """OSQP.update(q, l, u, Px, Ax) (full value arrays, fixed sparsity) without the wrapper's per-call constant
    lookups and derivative bookkeeping; the same data reaches the solver (bounds clamped to ±OSQP_INF)."""
    ext = getattr(solver, "_solver", None) if type(solver) is osqp.OSQP else None
    if ext is None or not hasattr(ext, "update_data_vec"):
        given = {"q": q, "l": l, "u": u, "Px": Px, "Ax": Ax}
        solver.update(**{k: v for k, v in given.items() if v is not None})
        return
    if l is not None:
        l = np.maximum(l, -OSQP_INF)  # noqa: E741
    if u is not None:
        u = np.minimum(u, OSQP_INF)
    if q is not None or l is not None or u is not None:
        ext.update_data_vec(q=q, l=l, u=u)
    if Px is not None or Ax is not None:
        ext.update_data_mat(P_x=Px, P_i=None, A_x=Ax, A_i=None)


def solve_with_retry(solver: osqp.OSQP, retry_rho: float) -> tuple[Any, str, int]:
    """Return (OSQP result, status text, iterations): one solve, and when it stops short, one more from there
    with ρ reset to `retry_rho`.

    OSQP 1.1's adaptive ρ can lock into a cycle (ρ jumping between ~1e-2 and ~1e5 as one residual reaches
    machine zero) on problems with several active constraints; a restart from another ρ breaks the cycle.
    """
    res, status, iterations = _solve_once(solver)
    if status in _STOPPED_SHORT:
        solver.update_settings(rho=retry_rho)
        res, status, more = _solve_once(solver)
        iterations += more
    return res, status, iterations


def iterate_usable(status: str, x: np.ndarray | None) -> bool:
    """Return True when OSQP's x is worth repairing: finite and not an infeasibility certificate's iterate."""
    return x is not None and "infeasible" not in status and bool(np.isfinite(x).all())


# --------------------------------------------------------------------------------------------------------------
# Friction pyramid helpers (per-leg contact frames), shared with planning/stance.py.


def pyramid_mu(mu: float, inscribed: bool) -> float:
    """Return the face coefficient of the 4-face pyramid: μ/√2 inscribes the Coulomb cone, μ circumscribes it."""
    if not math.isfinite(mu) or mu < 0.0:
        mu = 0.0
    return mu / math.sqrt(2.0) if inscribed else mu


def contact_frames(n_world_contact: np.ndarray | None, out: np.ndarray | None = None) -> np.ndarray:
    """Return R_world_contact (4,3,3): per leg, columns t1, t2, n (unit, right-handed; n the contact normal).

    None, zero or non-finite normals mean flat ground (n = +z). t1 is world x projected on the contact plane
    (world y when the normal is close to x), so a flat-ground frame is the identity.
    """
    R = np.empty((N_LEGS, 3, 3)) if out is None else out
    if n_world_contact is None:
        R[:] = np.eye(3)
        return R
    n = np.array(n_world_contact, dtype=float).reshape(N_LEGS, 3)
    norm = np.linalg.norm(n, axis=1)
    bad = ~np.isfinite(norm) | (norm < 1e-9)
    n[bad] = _E_Z
    norm[bad] = 1.0
    n /= norm[:, None]
    ref = np.zeros((N_LEGS, 3))
    near_x = np.abs(n[:, 0]) > 0.9
    ref[~near_x, 0] = 1.0
    ref[near_x, 1] = 1.0
    t1 = ref - np.sum(ref * n, axis=1)[:, None] * n
    t1 /= np.linalg.norm(t1, axis=1)[:, None]
    R[:, :, 0] = t1
    R[:, :, 1] = np.cross(n, t1)
    R[:, :, 2] = n
    return R


def pyramid_violation(f_world_leg: np.ndarray, R_world_contact: np.ndarray, mu_face: float) -> np.ndarray:
    """Return per leg (4,) the largest pyramid violation in N: max(|f_t1| - μ f_n, |f_t2| - μ f_n, -f_n, 0)."""
    f_contact = np.einsum("ijk,ij->ik", R_world_contact, f_world_leg)
    fn = f_contact[:, 2]
    viol = np.maximum(np.abs(f_contact[:, 0]), np.abs(f_contact[:, 1])) - mu_face * fn
    return np.maximum(np.maximum(viol, -fn), 0.0)


def clamp_to_pyramid(
    f_world_leg: np.ndarray,
    R_world_contact: np.ndarray,
    mu_face: float,
    fn_lo_n: np.ndarray,
    fn_hi_n: np.ndarray,
    out: np.ndarray,
    scratch: np.ndarray,
) -> np.ndarray:
    """Write into `out` (4,3) the forces with the normal part clipped to [fn_lo, fn_hi] and tangents to ±μ f_n.

    A cheap exact-feasibility repair (not the Euclidean projection); it moves a QP answer that is feasible up to
    the solver tolerance by about that tolerance. Legs with fn_lo = fn_hi = 0 come out as zero.
    `scratch` is a (4,3) work buffer; `out` may be `f_world_leg`.
    """
    np.einsum("ijk,ij->ik", R_world_contact, f_world_leg, out=scratch)  # contact-frame components
    fn = scratch[:, 2]
    np.minimum(fn, fn_hi_n, out=fn)
    np.maximum(fn, fn_lo_n, out=fn)
    np.maximum(fn, 0.0, out=fn)
    ft_max = mu_face * fn
    for k in (0, 1):
        np.minimum(scratch[:, k], ft_max, out=scratch[:, k])
        np.maximum(scratch[:, k], -ft_max, out=scratch[:, k])
    np.einsum("ijk,ik->ij", R_world_contact, scratch, out=out)
    return out


def pyramid_rows(R_world_contact: np.ndarray, mu_face: float, out: np.ndarray) -> np.ndarray:
    """Write into `out` (4,3,5) the constraint rows per leg: 4 faces (±t - μ n)·f ≤ 0, then the normal row n·f.

    Layout out[leg, component, row] is the CSC order of a dense 5×3 block (column = force component).
    """
    t1 = R_world_contact[:, :, 0]
    t2 = R_world_contact[:, :, 1]
    n = R_world_contact[:, :, 2]
    out[:, :, 0] = t1 - mu_face * n
    out[:, :, 1] = -t1 - mu_face * n
    out[:, :, 2] = t2 - mu_face * n
    out[:, :, 3] = -t2 - mu_face * n
    out[:, :, 4] = n
    return out


def fill_wrench_matrix(
    p_com_foot_world: np.ndarray, force_gain: float, torque_gain: float, out: np.ndarray
) -> None:
    """Write into `out` (6,12) the map f → [force_gain Σ f; torque_gain Σ r × f] (r = foot position from the CoM)."""
    out[0:3] = 0.0
    out[0, 0::3] = out[1, 1::3] = out[2, 2::3] = force_gain
    rx = p_com_foot_world[:, 0] * torque_gain
    ry = p_com_foot_world[:, 1] * torque_gain
    rz = p_com_foot_world[:, 2] * torque_gain
    out[3, 0::3] = 0.0
    out[3, 1::3] = -rz
    out[3, 2::3] = ry
    out[4, 0::3] = rz
    out[4, 1::3] = 0.0
    out[4, 2::3] = -rx
    out[5, 0::3] = -ry
    out[5, 1::3] = rx
    out[5, 2::3] = 0.0


def dense_upper_csc(n: int) -> tuple[sp.csc_matrix, np.ndarray]:
    """Return an n×n upper-triangular CSC matrix with every entry stored (value 1 on the diagonal, else 0) and the
    flat row-major indices that gather a dense (n,n) array into its data vector (for `update(Px=...)`)."""
    rows = np.concatenate([np.arange(j + 1) for j in range(n)])
    indptr = np.concatenate([[0], np.cumsum(np.arange(1, n + 1))])
    cols = np.repeat(np.arange(n), np.arange(1, n + 1))
    data = (rows == cols).astype(float)
    return sp.csc_matrix((data, rows, indptr), shape=(n, n)), rows * n + cols


def block_constraint_csc(rows_per_leg: int) -> sp.csc_matrix:
    """Return the (4·rows_per_leg)×12 CSC matrix whose leg blocks are dense (every entry stored, values 0)."""
    indptr = np.arange(3 * N_LEGS + 1) * rows_per_leg
    indices = np.concatenate([np.arange(rows_per_leg) + rows_per_leg * (j // 3) for j in range(3 * N_LEGS)])
    data = np.zeros(indices.size)
    return sp.csc_matrix((data, indices, indptr), shape=(rows_per_leg * N_LEGS, 3 * N_LEGS))


def setup_osqp(
    P: sp.csc_matrix,
    A: sp.csc_matrix,
    l: np.ndarray,
    u: np.ndarray,
    eps_abs: float,
    eps_rel: float,
    max_iter: int,
    polish: bool,
) -> osqp.OSQP:
    """Returns an OSQP solver set up once (quiet, warm-started) on P, A, l, u with q = 0; ticks update it in place."""
    solver = osqp.OSQP()
    solver.setup(
        P, np.zeros(P.shape[0]), A, l, u, verbose=False, eps_abs=eps_abs, eps_rel=eps_rel, max_iter=max_iter,
        polishing=polish, warm_starting=True,
    )  # fmt: skip
    return solver


def checked(name: str, value: object, shape: tuple[int, ...]) -> np.ndarray:
    """Return `value` as a float array of `shape`; raise ValueError naming the field when the shape is wrong."""
    arr = np.asarray(value, dtype=float)
    if arr.shape != shape:
        raise ValueError(f"{name}: expected shape {shape}, got {arr.shape}")
    return arr


def checked_mask(name: str, value: object) -> np.ndarray:
    """Return the contact mask as a (4,) bool array; raise ValueError naming the field when the shape is wrong."""
    arr = np.asarray(value)
    if arr.shape != (N_LEGS,):
        raise ValueError(f"{name}: expected shape ({N_LEGS},), got {arr.shape}")
    return arr.astype(bool, copy=False)


# --------------------------------------------------------------------------------------------------------------
# The force distributor.


@dataclass(frozen=True)
class ForceDistributorParams:
    """Weights and solver settings of the force-distribution QP.

    Cost, all in scaled units (forces / (m g), torques / (m g · torque_length_m)):
        w_force ‖Σ f - F‖² + w_torque ‖Σ r × f - T‖² + alpha ‖f - f_ref‖²
    With the defaults a 1 N·m torque error costs as much as a √10 ≈ 3.2 N force error.
    """

    w_force: float = 1.0  # weight of the net-force residual, per (m g)²
    w_force_horizontal: float | None = None  # weight of its x, y part when different (None: w_force)
    w_torque: float = 10.0  # weight of the torque residual about the CoM, per (m g · torque_length_m)²
    torque_length_m: float = 1.0  # m; turns a torque residual into a force-sized one
    # Regularization toward f_ref (default: the least-norm forces that make the wrench), per (m g)². Larger
    # converges faster (ADMM's rate follows P's conditioning), smaller tracks the wrench closer when the prior is
    # outside the pyramid: 1e-2 gives ~0.1 N / N·m error and ≤ ~1300 iterations on random stances.
    alpha: float = 1e-2
    inscribed_pyramid: bool = True  # faces at μ/√2 so the pyramid lies inside the Coulomb cone
    eps_abs: float = 1e-7  # OSQP tolerances, scaled units
    eps_rel: float = 1e-7
    max_iter: int = 2000  # per attempt; realistic problems take 50–450, rare ones up to ~1300
    retry_rho: float = 1.0  # ADMM ρ of the second attempt when the first stops short
    # Off: OSQP 1.1's polish prints "Polishing not needed ..." to fd 1 whatever `verbose` says, once per tick;
    # the tight tolerances above already give forces to ~1e-3 N.
    polish: bool = False


class ForceDistributor:
    """Distributes a desired body wrench over the stance feet (friction pyramid, normal-force bounds).

    One OSQP problem with 12 variables and 20 rows (per leg: 4 pyramid faces, 1 normal-force row), set up once.
    """

    def __init__(
        self, mass_kg: float, params: ForceDistributorParams | None = None, gravity_mps2: float = 9.81
    ):
        if not (math.isfinite(mass_kg) and mass_kg > 0.0):
            raise ValueError(f"mass_kg: must be a positive finite number, got {mass_kg!r}")
        self.params = params or ForceDistributorParams()
        self.mass_kg = float(mass_kg)
        self.force_scale_n = self.mass_kg * gravity_mps2  # m g, N
        p = self.params
        self._sqrt_wf = math.sqrt(p.w_force)
        self._sqrt_wt = math.sqrt(p.w_torque) / p.torque_length_m
        # horizontal force rows relative to the vertical one (walking: attitude first, foot placement steers)
        self._h_ratio = (
            math.sqrt(p.w_force_horizontal / p.w_force) if p.w_force_horizontal is not None else 1.0
        )

        n_var, n_row = 3 * N_LEGS, 5 * N_LEGS
        P0, self._p_gather = dense_upper_csc(n_var)
        A0 = block_constraint_csc(5)
        self._R = contact_frames(None)
        self._R_is_eye = _is_identity_frames(self._R)  # kept in step with every write to _R
        self._mu_face = pyramid_mu(0.6, p.inscribed_pyramid)
        self._rows = np.zeros((N_LEGS, 3, 5))  # constraint values, CSC order
        pyramid_rows(self._R, self._mu_face, self._rows)
        A0.data[:] = self._rows.ravel()
        self._l = np.full(n_row, -OSQP_INF)
        self._u = np.zeros(n_row)
        self._l[4::5] = 0.0
        self._u[4::5] = OSQP_INF
        self._solver = setup_osqp(P0, A0, self._l, self._u, p.eps_abs, p.eps_rel, p.max_iter, p.polish)

        # Work buffers: the hot path writes into these.
        self._G = np.zeros((6, n_var))  # scaled wrench map
        self._w = np.zeros(6)  # scaled desired wrench
        self._P = np.zeros((n_var, n_var))
        self._Px = np.zeros(P0.nnz)
        self._q = np.zeros(n_var)
        self._x_ref = np.zeros(n_var)
        self._f = np.zeros((N_LEGS, 3))
        self._scratch = np.zeros((N_LEGS, 3))
        self._fn_lo = np.zeros(N_LEGS)
        self._fn_hi = np.zeros(N_LEGS)
        self._f_out = self._f.view()
        self._f_out.flags.writeable = False
        self._y0 = np.zeros(n_row)
        self._col_mask = np.zeros(n_var)
        self._GGt = np.zeros((6, 6))
        self.last_solve_ms = 0.0
        self.last_status = SolveStatus(solver="not run")

    @property
    def f_world_leg(self) -> np.ndarray:
        """The last answer (4,3), N, world frame; a read-only view that the next solve overwrites."""
        return self._f_out

    def solve(
        self,
        force_world_des: np.ndarray,
        torque_world_des: np.ndarray,
        p_com_foot_world: np.ndarray,
        contact: np.ndarray,
        *,
        mu: float = 0.6,
        fz_min_n: float = 5.0,
        fz_max_n: float = math.inf,
        n_world_contact: np.ndarray | None = None,
        f_world_ref: np.ndarray | None = None,
    ) -> tuple[np.ndarray, SolveStatus]:
        """Return the contact forces f (4,3) [N, world] that best produce the wrench, and what happened.

        force_world_des (3,) N and torque_world_des (3,) N·m: desired net wrench on the body about the CoM (the
        gravity compensation included: standing still asks for (0, 0, m g)). p_com_foot_world (4,3) m: contact
        points relative to the CoM. contact (4,) bool: stance legs. mu: friction coefficient; fz_min_n/fz_max_n:
        bounds on each stance leg's normal force, N. n_world_contact (4,3): contact normals (default +z).
        f_world_ref (4,3) N: forces to regularize toward (default: the least-norm forces that produce the wrench,
        a prior that leaves the wrench unbiased while no constraint is active).

        Never raises on values: non-finite inputs are repaired (a leg with a non-finite position is treated as
        swinging) and named in `status.sanitized`; if OSQP does not converge its last iterate (or the reference
        forces) is clamped into the pyramid. Wrong shapes raise ValueError naming the field.
        """
        t0 = time.perf_counter()
        p = self.params
        fs = self.force_scale_n
        F = checked("force_world_des", force_world_des, (3,))
        T = checked("torque_world_des", torque_world_des, (3,))
        r = checked("p_com_foot_world", p_com_foot_world, (N_LEGS, 3))
        stance = checked_mask("contact", contact)
        sanitized: list[str] = []

        if not np.isfinite(F).all():
            F = np.nan_to_num(F, nan=0.0, posinf=0.0, neginf=0.0)
            sanitized.append("force_world_des")
        if not np.isfinite(T).all():
            T = np.nan_to_num(T, nan=0.0, posinf=0.0, neginf=0.0)
            sanitized.append("torque_world_des")
        if not np.isfinite(r).all():
            good = np.isfinite(r).all(axis=1)
            stance = stance & good
            r = np.where(good[:, None], r, 0.0)
            sanitized.append("p_com_foot_world")
        if not (math.isfinite(mu) and mu >= 0.0):
            sanitized.append("mu")
        mu_face = pyramid_mu(mu, p.inscribed_pyramid)
        fz_lo, fz_hi = _normal_bounds(fz_min_n, fz_max_n, sanitized)

        # Constraint matrix: only μ and the normals enter it, so update Ax only when they change.
        if n_world_contact is not None:
            checked("n_world_contact", n_world_contact, (N_LEGS, 3))
            R_new = contact_frames(n_world_contact)
            a_changed = mu_face != self._mu_face or not np.array_equal(R_new, self._R)
            self._R[:] = R_new
            self._R_is_eye = _is_identity_frames(self._R)
        else:
            a_changed = mu_face != self._mu_face or not self._R_is_eye
            if a_changed:
                self._R[:] = np.eye(3)
                self._R_is_eye = True
        self._mu_face = mu_face
        if a_changed:
            pyramid_rows(self._R, mu_face, self._rows)

        # Cost: P = GᵀG + αI, q = -(Gᵀw + α x_ref) with G, w the weighted, scaled wrench map and target.
        G = self._G
        fill_wrench_matrix(r, self._sqrt_wf, self._sqrt_wt, G)
        # Swing legs decouple: their block of P is αI and of q zero, so their optimum is 0.
        self._col_mask.reshape(N_LEGS, 3)[:] = stance[:, None]
        G *= self._col_mask
        self._w[0:3] = F
        self._w[0:3] *= self._sqrt_wf / fs
        if self._h_ratio != 1.0:
            G[0:2] *= self._h_ratio
            self._w[0:2] *= self._h_ratio
        self._w[3:6] = T
        self._w[3:6] *= self._sqrt_wt / fs
        np.dot(G.T, G, out=self._P)
        self._P.flat[:: 3 * N_LEGS + 1] += p.alpha
        self._P.take(self._p_gather, out=self._Px)
        x_ref = self._x_ref.reshape(N_LEGS, 3)
        if f_world_ref is not None:
            ref = checked("f_world_ref", f_world_ref, (N_LEGS, 3))
            if not np.isfinite(ref).all():
                ref = np.nan_to_num(ref, nan=0.0, posinf=0.0, neginf=0.0)
                sanitized.append("f_world_ref")
            np.multiply(ref, 1.0 / fs, out=x_ref)
        else:
            # The least-norm forces that produce the wrench (damped for stance sets that cannot make all of it):
            # unlike zero or equal shares, this prior does not bias the wrench while no constraint is active.
            np.dot(G, G.T, out=self._GGt)
            damping = 1e-9 * float(np.trace(self._GGt)) + 1e-12
            self._GGt.flat[::7] += damping
            np.dot(G.T, np.linalg.solve(self._GGt, self._w), out=self._x_ref)
        x_ref[~stance] = 0.0
        np.dot(G.T, self._w, out=self._q)
        self._q += p.alpha * self._x_ref
        np.negative(self._q, out=self._q)

        # Bounds. Swing legs get no rows at all: their decoupled cost already puts them at zero, and pinning
        # them with [0, 0] rows instead makes OSQP's adaptive ρ oscillate. The final clamp makes them exactly 0.
        np.copyto(self._fn_lo, np.where(stance, fz_lo, 0.0))
        np.copyto(self._fn_hi, np.where(stance, fz_hi, 0.0))
        l_leg = self._l.reshape(N_LEGS, 5)
        u_leg = self._u.reshape(N_LEGS, 5)
        l_leg[:, 0:4] = -OSQP_INF
        u_leg[:, 0:4] = 0.0
        l_leg[:, 4] = self._fn_lo / fs
        np.minimum(self._fn_hi / fs, OSQP_INF, out=u_leg[:, 4])
        l_leg[~stance] = -OSQP_INF
        u_leg[~stance] = OSQP_INF

        if a_changed:
            qp_update(self._solver, q=self._q, l=self._l, u=self._u, Px=self._Px, Ax=self._rows.ravel())
        else:
            qp_update(self._solver, q=self._q, l=self._l, u=self._u, Px=self._Px)
        res, solver_status, iterations = solve_with_retry(self._solver, p.retry_rho)
        x = res.x
        fallback = solver_status not in _USABLE
        if iterate_usable(solver_status, x):
            np.multiply(x.reshape(N_LEGS, 3), fs, out=self._f)
        else:
            np.multiply(x_ref, fs, out=self._f)  # the reference, clamped below
        clamp_to_pyramid(self._f, self._R, mu_face, self._fn_lo, self._fn_hi, self._f, self._scratch)
        if fallback:
            self._solver.warm_start(x=self._f.reshape(-1) / fs, y=self._y0)

        self.last_status = SolveStatus(
            solver=solver_status, iterations=iterations, fallback=fallback, sanitized=tuple(sanitized)
        )
        self.last_solve_ms = (time.perf_counter() - t0) * 1e3
        return self._f_out, self.last_status

    @property
    def solver(self) -> osqp.OSQP:
        """The underlying OSQP object (for benchmarks: time `.solve()` alone)."""
        return self._solver


def _normal_bounds(fz_min_n: float, fz_max_n: float, sanitized: list[str]) -> tuple[float, float]:
    """Return a usable (fz_min, fz_max) pair in N: finite non-negative minimum, maximum ≥ minimum (inf allowed)."""
    lo = float(fz_min_n)
    hi = float(fz_max_n)
    if not (math.isfinite(lo) and lo >= 0.0):
        lo = 0.0
        sanitized.append("fz_min_n")
    if math.isnan(hi) or hi < lo:
        hi = max(lo, 0.0) if not math.isnan(hi) else math.inf
        sanitized.append("fz_max_n")
    return lo, hi


def _is_identity_frames(R: np.ndarray) -> bool:
    return bool(R[0, 0, 0] == 1.0 and np.array_equal(R, np.broadcast_to(np.eye(3), R.shape)))
