"""Stance handler (seed 004, handler 250): planned contact forces → stance-leg joint torques.

The centroidal solver may trade a constraint away; here the torque limits and the friction pyramid are enforced
again at the joints. Each tick one QP picks the forces f closest to the planned ones f_des,

    minimize   ½ (f - f_des)ᵀ P (f - f_des)
    subject to |τ_bias - Jᵀ f| ≤ τ_max          (per stance joint)
               f in the friction pyramid, fz_min ≤ n·f ≤ fz_max   (per stance leg)
               f = 0                             (per swing leg: its cost block is decoupled, no rows needed)

and the stance torques are τ = -Jᵀ f + τ_bias (f is the force the ground applies to the foot, so the leg pushes
with -f). P weights normal and tangential deviations per leg and, when the foot positions are given, the change of
the net wrench about the CoM, so a leg that hits its limits hands the missing force to the others.

Guarantees, whatever the inputs: stance torques within their limits, applied forces within the pyramid (n·f ≥ 0),
swing legs zero, no exception on values. When the QP is infeasible (the limits cannot carry fz_min) it is solved
again with fz_min = 0 (legs whose τ_bias alone exceeds a limit never get torque rows). The QP's answer
(its last iterate when it did not converge; the planned forces after an infeasibility verdict) is then clamped
into the pyramid and scaled down per leg until the torques fit exactly; only when no scale fits (τ_bias beyond
the limits) are the torques clipped. `last_status` reports which of these happened.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np
import osqp

from planning.forces import (
    FEASIBLE_AS_PLANNED,
    N_LEGS,
    OSQP_INF,
    SolveStatus,
    block_constraint_csc,
    checked,
    checked_mask,
    clamp_to_pyramid,
    contact_frames,
    dense_upper_csc,
    fill_wrench_matrix,
    iterate_usable,
    pyramid_mu,
    pyramid_rows,
    qp_update,
    setup_osqp,
    solve_with_retry,
)

_USABLE = ("solved", "solved inaccurate")
_X_TYPICAL = 4.0  # largest |f| / force_scale_n the cost is left unscaled for
_ROWS = 8  # per leg: 3 joint torques, 4 pyramid faces, 1 normal force


@dataclass(frozen=True)
class StanceHandlerParams:
    """Weights, bounds and solver settings of the stance handler.

    Weights are per force_scale_n² of deviation from the planned forces; the wrench weights act only when the
    foot positions are passed (torque residual per force_scale_n · 1 m).
    """

    force_scale_n: float = 100.0  # N; the QP's variable is f / force_scale_n (~ a quarter of Spot's weight)
    w_normal: float = 1.0  # deviation along each leg's contact normal
    w_tangent: float = 1.0  # deviation in the contact plane
    w_wrench_force: float = 1.0  # change of the net force Σ f
    w_wrench_torque: float = 1.0  # change of the net torque Σ r × f about the CoM
    fz_min_n: float = 5.0  # N; least normal force of a stance leg (keeps the contact loaded)
    fz_max_n: float = math.inf  # N
    inscribed_pyramid: bool = True  # faces at μ/√2 so the pyramid lies inside the Coulomb cone
    eps_abs: float = 1e-7  # OSQP tolerances, scaled units
    eps_rel: float = 1e-7
    max_iter: int = 1000  # per attempt; bounds the time of absurd inputs (~3 ms); realistic ones take 25–500
    retry_rho: float = 1.0  # ADMM ρ of the second attempt when the first stops short
    polish: bool = False  # OSQP 1.1's polish prints to fd 1 whatever `verbose` says
    skip_feasible: bool = (
        True  # return a plan that already meets every limit without solving (it is the optimum)
    )

    def __post_init__(self) -> None:
        for name in ("force_scale_n", "w_normal", "w_tangent"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0.0):
                raise ValueError(f"{name}: must be a positive finite number, got {value!r}")
        for name in ("w_wrench_force", "w_wrench_torque", "fz_min_n"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0.0):
                raise ValueError(f"{name}: must be a non-negative finite number, got {value!r}")
        if not self.fz_max_n >= self.fz_min_n:
            raise ValueError(f"fz_max_n: must be >= fz_min_n ({self.fz_min_n}), got {self.fz_max_n!r}")


class StanceHandler:
    """Turns planned contact forces into stance-leg joint torques that respect torque limits and friction.

    One OSQP problem (12 variables, 32 rows: per leg 3 torque rows, 4 pyramid faces, 1 normal-force row), set up
    once with a fixed pattern; each tick updates Px, q, Ax (the Jacobians change), l, u and warm-starts.
    """

    def __init__(self, params: StanceHandlerParams | None = None):
        self.params = p = params or StanceHandlerParams()
        n_var, n_row = 3 * N_LEGS, _ROWS * N_LEGS
        P0, self._p_gather = dense_upper_csc(n_var)
        A0 = block_constraint_csc(_ROWS)
        # Set up with a plausible problem (identity Jacobians, flat ground) so OSQP's scaling fits the real ones.
        self._B = np.zeros((N_LEGS, 3, _ROWS))  # constraint values, CSC order [leg, force component, row]
        self._B[:, :, 0:3] = -np.eye(3)
        R0 = contact_frames(None)
        pyr = np.zeros((N_LEGS, 3, 5))
        pyramid_rows(R0, pyramid_mu(0.6, p.inscribed_pyramid), pyr)
        self._B[:, :, 3:8] = pyr
        A0.data[:] = self._B.ravel()
        self._l = np.full(n_row, -OSQP_INF)
        self._u = np.full(n_row, OSQP_INF)
        self._solver = setup_osqp(P0, A0, self._l, self._u, p.eps_abs, p.eps_rel, p.max_iter, p.polish)

        # Work buffers; the hot path writes into these.
        self._R = np.zeros((N_LEGS, 3, 3))
        self._pyr = pyr
        self._W = np.zeros((N_LEGS, 3, 3))
        self._G = np.zeros((6, n_var))
        self._P = np.zeros((n_var, n_var))
        self._Px = np.zeros(P0.nnz)
        self._q = np.zeros(n_var)
        self._x_des = np.zeros(n_var)
        self._tau_scale = np.ones((N_LEGS, 3))
        self._fn_lo = np.zeros(N_LEGS)
        self._fn_hi = np.zeros(N_LEGS)
        self._f = np.zeros((N_LEGS, 3))
        self._g = np.zeros((N_LEGS, 3))
        self._scratch = np.zeros((N_LEGS, 3))
        self._tau = np.zeros((N_LEGS, 3))
        self._y0 = np.zeros(n_row)
        self._zero_bias = np.zeros((N_LEGS, 3))
        self._col_mask = np.zeros(n_var)
        self._f_view = self._f.view()
        self._f_view.flags.writeable = False
        self._tau_view = self._tau.view()
        self._tau_view.flags.writeable = False
        self._w_diag = np.array([p.w_tangent, p.w_tangent, p.w_normal])
        self.last_solve_ms = 0.0
        self.last_status = SolveStatus(solver="not run")

    @property
    def f_world_applied(self) -> np.ndarray:
        """Forces (4,3) [N, world] the last torques correspond to; zero on swing legs. Read-only, overwritten."""
        return self._f_view

    @property
    def tau_leg(self) -> np.ndarray:
        """The last joint torques (4,3) [N·m]; zero on swing legs. Read-only, overwritten by the next solve."""
        return self._tau_view

    @property
    def solver(self) -> osqp.OSQP:
        """The underlying OSQP object (for benchmarks: time `.solve()` alone)."""
        return self._solver

    def solve(
        self,
        f_world_des: np.ndarray,
        J_world_leg: np.ndarray,
        contact: np.ndarray,
        tau_max_leg: np.ndarray,
        *,
        tau_bias_leg: np.ndarray | None = None,
        mu: float = 0.6,
        n_world_contact: np.ndarray | None = None,
        p_com_foot_world: np.ndarray | None = None,
    ) -> np.ndarray:
        """Return stance-leg joint torques τ (4,3) [N·m] (zeros on swing legs) realizing forces near f_des.

        f_world_des (4,3) N: planned ground-on-foot forces, world frame. J_world_leg (4,3,3): d p_world_foot / d q
        per leg. contact (4,) bool: stance legs. tau_max_leg (4,3) N·m: symmetric torque limits (inf allowed).
        tau_bias_leg (4,3) N·m: torque added to -Jᵀf on stance legs (gravity/bias compensation; default zero).
        mu: friction coefficient. n_world_contact (4,3): contact normals (default +z). p_com_foot_world (4,3) m:
        contacts relative to the CoM; when given, P also penalizes the change of the net wrench.

        The torques and the forces actually applied are also kept in `tau_leg` and `f_world_applied` (read-only
        views overwritten by the next call: copy to keep). Never raises on values; wrong shapes raise ValueError.
        """
        t0 = time.perf_counter()
        p = self.params
        fs = p.force_scale_n
        sanitized: list[str] = []
        f_des = checked("f_world_des", f_world_des, (N_LEGS, 3))
        J = checked("J_world_leg", J_world_leg, (N_LEGS, 3, 3))
        stance = checked_mask("contact", contact)
        T = checked("tau_max_leg", tau_max_leg, (N_LEGS, 3))
        b = self._bias(tau_bias_leg, sanitized)
        if not np.isfinite(f_des).all():
            f_des = np.nan_to_num(f_des, nan=0.0, posinf=0.0, neginf=0.0)
            sanitized.append("f_world_des")
        if not np.isfinite(J).all():
            J = np.nan_to_num(J, nan=0.0, posinf=0.0, neginf=0.0)  # that leg's torque becomes its bias alone
            sanitized.append("J_world_leg")
        if not (T >= 0.0).all():  # a NaN or a negative limit (one NumPy pass instead of two)
            T = np.where(np.isnan(T), 0.0, np.abs(T))
            sanitized.append("tau_max_leg")
        if not (math.isfinite(mu) and mu >= 0.0):
            sanitized.append("mu")
        mu_face = pyramid_mu(mu, p.inscribed_pyramid)
        if (
            p.skip_feasible
            and n_world_contact is None
            and not sanitized
            and self._feasible_as_planned(f_des, J, stance, T, b, mu_face)
        ):
            # The plan already satisfies every constraint, so it is the QP's optimum (zero cost): skip the solve.
            self.last_status = SolveStatus(solver=FEASIBLE_AS_PLANNED, iterations=0)
            self.last_solve_ms = (time.perf_counter() - t0) * 1e3
            return self._tau_view
        if n_world_contact is not None:
            contact_frames(checked("n_world_contact", n_world_contact, (N_LEGS, 3)), out=self._R)
        else:
            contact_frames(None, out=self._R)

        # Cost: P = blockdiag(R diag(w_t, w_t, w_n) Rᵀ) + GᵀG (wrench term on stance legs), q = -P x_des.
        np.einsum("ijk,k,ilk->ijl", self._R, self._w_diag, self._R, out=self._W)
        G = self._G
        if p_com_foot_world is not None and (p.w_wrench_force > 0.0 or p.w_wrench_torque > 0.0):
            r = checked("p_com_foot_world", p_com_foot_world, (N_LEGS, 3))
            use = stance.copy()
            if not np.isfinite(r).all():
                use &= np.isfinite(r).all(axis=1)
                r = np.nan_to_num(r, nan=0.0, posinf=0.0, neginf=0.0)
                sanitized.append("p_com_foot_world")
            fill_wrench_matrix(r, math.sqrt(p.w_wrench_force), math.sqrt(p.w_wrench_torque), G)
            self._col_mask.reshape(N_LEGS, 3)[:] = use[:, None]
            G *= self._col_mask
            np.dot(G.T, G, out=self._P)
        else:
            self._P[:] = 0.0
        for i in range(N_LEGS):
            self._P[3 * i : 3 * i + 3, 3 * i : 3 * i + 3] += self._W[i]
        np.multiply(f_des.reshape(-1), 1.0 / fs, out=self._x_des)
        self._x_des.reshape(N_LEGS, 3)[~stance] = 0.0
        # OSQP equilibrates the cost once, at setup; a plan far out of range (|f_des| ≫ force_scale_n) gives
        # duals far from that scale and ADMM crawls. Scaling the whole cost down keeps q of order one and leaves
        # the minimizer unchanged.
        cost_scale = 1.0 / max(1.0, float(np.abs(self._x_des).max()) / _X_TYPICAL)
        np.dot(self._P, self._x_des, out=self._q)
        self._q *= -cost_scale
        self._P.take(self._p_gather, out=self._Px)
        self._Px *= cost_scale

        # Constraints: torque rows -Jᵀ f scaled by 1/τ_scale, then the pyramid and normal rows.
        np.copyto(self._tau_scale, np.where(np.isfinite(T), np.maximum(T, 1.0), 1.0))
        np.multiply(J, -fs / self._tau_scale[:, None, :], out=self._B[:, :, 0:3])
        pyramid_rows(self._R, mu_face, self._pyr)
        self._B[:, :, 3:8] = self._pyr
        self._set_bounds(b, T, stance)

        qp_update(self._solver, q=self._q, l=self._l, u=self._u, Px=self._Px, Ax=self._B.ravel())
        res, status, iterations = solve_with_retry(self._solver, p.retry_rho)
        relaxed_qp = False
        if status.startswith("primal infeasible"):
            # The limits cannot carry fz_min on some leg: retry letting the normal force go to zero. f = 0 is
            # then feasible on every leg (legs whose bias alone breaks a limit have no torque rows).
            relaxed_qp = True
            self._l[7::_ROWS] = 0.0
            qp_update(self._solver, l=self._l)
            res, status, more = solve_with_retry(self._solver, p.retry_rho)
            iterations += more
        x = res.x
        fallback = status not in _USABLE
        if iterate_usable(status, x):
            np.multiply(x.reshape(N_LEGS, 3), fs, out=self._f)
        else:
            np.copyto(self._f, f_des)
        if relaxed_qp:
            self._fn_lo[:] = 0.0
        clamp_to_pyramid(self._f, self._R, mu_face, self._fn_lo, self._fn_hi, self._f, self._scratch)
        if fallback:
            self._solver.warm_start(x=self._f.reshape(-1) / fs, y=self._y0)

        clipped = self._fit_torques(J, b, T, stance)
        fn = np.einsum("ij,ij->i", self._R[:, :, 2], self._f)
        relaxed = bool(np.any(stance & (fn < p.fz_min_n - 1e-6)))
        self.last_status = SolveStatus(
            solver=status,
            iterations=iterations,
            fallback=fallback,
            fz_min_relaxed=relaxed,
            torque_clipped=clipped,
            sanitized=tuple(sanitized),
        )
        self.last_solve_ms = (time.perf_counter() - t0) * 1e3
        return self._tau_view

    # ----------------------------------------------------------------------------------------------------------

    def _feasible_as_planned(
        self,
        f_des: np.ndarray,
        J: np.ndarray,
        stance: np.ndarray,
        T: np.ndarray,
        b: np.ndarray,
        mu_face: float,
    ) -> bool:
        """Returns True (and writes forces and torques) when f_des on flat contacts needs no correction: every
        stance force inside the pyramid and the normal-force bounds, every torque within its limit."""
        p = self.params
        f = self._f
        np.copyto(f, f_des)
        f[~stance] = 0.0
        # four legs: the bounds and the pyramid tested on Python floats (the same comparisons, a fifth of the time
        # of a dozen NumPy calls on (4,) arrays; this runs at every physics step)
        fz_min, fz_max = p.fz_min_n, p.fz_max_n
        for (fx, fy, fz), down in zip(f.tolist(), stance.tolist(), strict=True):
            lim = mu_face * fz
            if (down and not (fz >= fz_min and fz <= fz_max)) or not (abs(fx) <= lim and abs(fy) <= lim):
                return False
        tau = self._tau
        np.einsum("lji,lj->li", J, f, out=tau)
        np.subtract(b, tau, out=tau)
        tau[~stance] = 0.0
        return bool((np.abs(tau) <= T).all())

    def _bias(self, tau_bias_leg: np.ndarray | None, sanitized: list[str]) -> np.ndarray:
        if tau_bias_leg is None:
            return self._zero_bias
        b = checked("tau_bias_leg", tau_bias_leg, (N_LEGS, 3))
        if not np.isfinite(b).all():
            sanitized.append("tau_bias_leg")
            return np.nan_to_num(b, nan=0.0, posinf=0.0, neginf=0.0)
        return b

    def _set_bounds(self, b: np.ndarray, T: np.ndarray, stance: np.ndarray) -> None:
        """Write l, u: torque rows (τ_bias ± τ_max, scaled), pyramid and normal rows on stance legs; none on swing."""
        p = self.params
        fs = p.force_scale_n
        l_leg = self._l.reshape(N_LEGS, _ROWS)
        u_leg = self._u.reshape(N_LEGS, _ROWS)
        lo = (-T - b) / self._tau_scale
        hi = (T - b) / self._tau_scale
        l_leg[:, 0:3] = np.maximum(lo, -OSQP_INF)
        u_leg[:, 0:3] = np.minimum(hi, OSQP_INF)
        # A leg whose bias alone breaks a limit would make the whole QP infeasible; it gets no torque rows and
        # _fit_torques scales (or, failing that, clips) it, so it cannot spoil the other legs.
        hopeless = (np.abs(b) > T).any(axis=1)
        l_leg[hopeless, 0:3] = -OSQP_INF
        u_leg[hopeless, 0:3] = OSQP_INF
        l_leg[:, 3:7] = -OSQP_INF
        u_leg[:, 3:7] = 0.0
        np.copyto(self._fn_lo, np.where(stance, p.fz_min_n, 0.0))
        np.copyto(self._fn_hi, np.where(stance, p.fz_max_n, 0.0))
        l_leg[:, 7] = self._fn_lo / fs
        u_leg[:, 7] = np.minimum(self._fn_hi / fs, OSQP_INF)
        # Swing legs: no rows at all. Their cost block is decoupled (x_des = 0, no wrench coupling), so the QP
        # answer is zero anyway; pinning them with [0, 0] rows instead makes OSQP's adaptive ρ oscillate.
        l_leg[~stance] = -OSQP_INF
        u_leg[~stance] = OSQP_INF

    def _fit_torques(self, J: np.ndarray, b: np.ndarray, T: np.ndarray, stance: np.ndarray) -> bool:
        """Scale each stance leg's force by the largest s in [0, 1] whose torques τ = b - s Jᵀf fit the limits,
        write forces and torques; return True when some leg had no such s and its torques were clipped.

        The QP's answer fits already up to the solver tolerance (s ≈ 1); this makes the limits exact. s f stays in
        the pyramid (a cone), so friction is never traded for torque.
        """
        g = self._g
        np.einsum("ick,ic->ik", J, self._f, out=g)  # Jᵀ f per leg
        tiny = 1e-12
        with np.errstate(divide="ignore", invalid="ignore"):
            a_minus = (b - T) / g
            a_plus = (b + T) / g
        fits_at_any_s = np.abs(b) <= T
        lo = np.where(
            g > tiny, a_minus, np.where(g < -tiny, a_plus, np.where(fits_at_any_s, -np.inf, np.inf))
        )
        hi = np.where(
            g > tiny, a_plus, np.where(g < -tiny, a_minus, np.where(fits_at_any_s, np.inf, -np.inf))
        )
        s_lo = np.maximum(lo.max(axis=1), 0.0)
        s_hi = np.minimum(hi.min(axis=1), 1.0)
        feasible = s_lo <= s_hi
        s = np.where(feasible, s_hi, 1.0)
        if not feasible[stance].all():
            # No scale fits: take the candidate scale with the least total excess torque (ties → larger s).
            cand = np.concatenate([np.zeros((N_LEGS, 1)), np.ones((N_LEGS, 1)), lo, hi], axis=1)
            np.clip(cand, 0.0, 1.0, out=cand)
            excess = np.maximum(np.abs(b[:, None, :] - cand[:, :, None] * g[:, None, :]) - T[:, None, :], 0.0)
            total = excess.sum(axis=2)
            best = total <= total.min(axis=1, keepdims=True) * (1.0 + 1e-12) + 1e-12
            s_best = np.where(best, cand, -1.0).max(axis=1)
            s = np.where(feasible, s, s_best)
        s = np.where(stance, s, 0.0)
        self._f *= s[:, None]
        g *= s[:, None]
        np.subtract(b, g, out=self._tau)
        self._tau[~stance] = 0.0
        before = self._scratch
        np.copyto(before, self._tau)
        np.minimum(self._tau, T, out=self._tau)
        np.maximum(self._tau, -T, out=self._tau)
        excess = np.abs(before - self._tau)
        return bool((excess > 1e-9 * (1.0 + np.where(np.isfinite(T), T, 0.0))).any())
