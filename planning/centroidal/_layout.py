"""The fixed sparsity pattern of the centroidal QP, built once for a maximum size.

Variables (x): per knot k < K: [p(3) m, v(3) m/s, θ(3) rad, ω(3) rad/s]; per interval k < N = K−1 and leg i:
f (3, in units of the force scale), c (relaxed contact, 1); per leg i and foothold variable s < S: d (2) m, the
horizontal shift of an adjustable touchdown's contact point (fixed contact points are data, not variables).

Rows (A x in [l, u]), in order:
  init   12          x_0 = measured state
  dyn    N × 12      p, v, θ, ω rows of the linearized discrete map
  fric   N × 4 × 8   4 pyramid faces, f_n <= c fz_max, f_n >= c fz_min, two cone cuts (tangent planes)
  cbnd   N × 4       c in [c_lo, c_hi]
  mono   (N−1) × 4   c_{k+1} − c_k >= 0 (touchdown window) / <= 0 (liftoff window) / free
  kin    (K−1) × 4 × 2  leg-length cut (tangent plane of the circle of FIG. 2E), hip line; each with the contact
                        variable of one adjacent interval (relaxed by M (1 − c) inside a timing window)
  foot   4 × S × (2 + E)  box and polygon on d

The angular rows couple every interval to every foothold variable (the pattern cannot know which touchdown an
interval will use), so S is kept small: those columns are what the factorization fills in.

Every block is stored as COO entries in a fixed order; ``order`` maps that order onto CSC data so a tick writes
values with one gather (``Ax = vals[order]``). Rows that are unused this tick keep their entries and get infinite
bounds; intervals past the problem's end get dt = 0 (identity dynamics, zero forces).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

N_LEGS = 4
FRIC_ROWS = 8
KIN_ROWS = 2


@dataclass
class _Pattern:
    rows: list[np.ndarray] = field(default_factory=list)
    cols: list[np.ndarray] = field(default_factory=list)
    blocks: dict[str, tuple[slice, tuple[int, ...]]] = field(default_factory=dict)
    n: int = 0

    def add(self, name: str, rows: np.ndarray, cols: np.ndarray) -> None:
        r, c = np.broadcast_arrays(rows, cols)
        self.blocks[name] = (slice(self.n, self.n + r.size), r.shape)
        self.rows.append(r.ravel())
        self.cols.append(c.ravel())
        self.n += r.size

    def csc(self, shape: tuple[int, int]) -> tuple[sp.csc_matrix, np.ndarray]:
        rows = np.concatenate(self.rows)
        cols = np.concatenate(self.cols)
        key = cols.astype(np.int64) * shape[0] + rows
        order = np.argsort(key, kind="stable")
        if np.any(np.diff(key[order]) == 0):
            raise AssertionError("duplicate entries in the QP pattern")
        indptr = np.zeros(shape[1] + 1, dtype=np.int64)
        np.cumsum(np.bincount(cols, minlength=shape[1]), out=indptr[1:])
        # Placeholder values: ones on the diagonal, small elsewhere (keeps a cost pattern convex at setup).
        vals = np.where(rows[order] == np.repeat(np.arange(shape[1]), np.diff(indptr)), 1.0, 1e-3)
        M = sp.csc_matrix((vals, rows[order], indptr), shape=shape)
        return M, order


class Layout:
    """Indices of variables and rows, and the A and P patterns, for K knots, S foothold variables per leg, E edges."""

    def __init__(self, n_knots: int, n_slots: int, n_edges: int) -> None:
        K, S, E = n_knots, n_slots, n_edges
        N = K - 1
        self.K, self.N, self.S, self.E = K, N, S, E
        n = 0
        self.ix = np.arange(K * 12).reshape(K, 12)
        n += K * 12
        self.i_p, self.i_v, self.i_th, self.i_w = (self.ix[:, j : j + 3] for j in (0, 3, 6, 9))
        self.i_f = n + np.arange(N * 12).reshape(N, N_LEGS, 3)
        n += N * 12
        self.i_c = n + np.arange(N * N_LEGS).reshape(N, N_LEGS)
        n += N * N_LEGS
        self.i_d = n + np.arange(N_LEGS * S * 2).reshape(N_LEGS, S, 2)
        n += N_LEGS * S * 2
        self.n = n

        m = 0
        self.r_init = np.arange(12)
        m += 12
        self.r_dyn = m + np.arange(N * 12).reshape(N, 12)
        m += N * 12
        self.r_fric = m + np.arange(N * N_LEGS * FRIC_ROWS).reshape(N, N_LEGS, FRIC_ROWS)
        m += N * N_LEGS * FRIC_ROWS
        self.r_cb = m + np.arange(N * N_LEGS).reshape(N, N_LEGS)
        m += N * N_LEGS
        self.r_mono = m + np.arange((N - 1) * N_LEGS).reshape(N - 1, N_LEGS)
        m += (N - 1) * N_LEGS
        self.r_kin = m + np.arange((K - 1) * N_LEGS * KIN_ROWS).reshape(K - 1, N_LEGS, KIN_ROWS)
        m += (K - 1) * N_LEGS * KIN_ROWS
        self.r_foot = m + np.arange(N_LEGS * S * (2 + E)).reshape(N_LEGS, S, 2 + E)
        m += N_LEGS * S * (2 + E)
        self.m = m

        A = _Pattern()
        A.add("init", self.r_init, self.ix[0])
        rp, rv, rt, rw = (self.r_dyn[:, j : j + 3] for j in (0, 3, 6, 9))
        A.add("pp1", rp, self.i_p[1:])
        A.add("pp0", rp, self.i_p[:-1])
        A.add("pv0", rp, self.i_v[:-1])
        A.add("pf", rp[:, None, :], self.i_f)
        A.add("vv1", rv, self.i_v[1:])
        A.add("vv0", rv, self.i_v[:-1])
        A.add("vf", rv[:, None, :], self.i_f)
        A.add("tt1", rt, self.i_th[1:])
        A.add("tt0", rt[:, :, None], self.i_th[:-1][:, None, :])
        A.add("tw0", rt[:, :, None], self.i_w[:-1][:, None, :])
        A.add("tw1", rt[:, :, None], self.i_w[1:][:, None, :])
        A.add("tv0", rt[:, :, None], self.i_v[:-1][:, None, :])
        A.add("tf", rt[:, :, None, None], self.i_f[:, None, :, :])
        A.add("ww1", rw, self.i_w[1:])
        A.add("ww0", rw[:, :, None], self.i_w[:-1][:, None, :])
        A.add("wt0", rw[:, :, None], self.i_th[:-1][:, None, :])
        A.add("wp0", rw[:, :, None], self.i_p[:-1][:, None, :])
        A.add("wv0", rw[:, :, None], self.i_v[:-1][:, None, :])
        A.add("wf", rw[:, :, None, None], self.i_f[:, None, :, :])
        A.add("wd", rw[:, :, None, None, None], self.i_d[None, None])
        A.add("fr", self.r_fric[..., None], self.i_f[:, :, None, :])
        A.add("frc", self.r_fric[:, :, 4:6], self.i_c[:, :, None])
        A.add("cb", self.r_cb, self.i_c)
        A.add("mo1", self.r_mono, self.i_c[1:])
        A.add("mo0", self.r_mono, self.i_c[:-1])
        A.add("kp", self.r_kin[..., None], self.i_p[1:][:, None, None, :])
        A.add("kt", self.r_kin[..., None], self.i_th[1:][:, None, None, :])
        A.add("kd", self.r_kin[..., None, None], self.i_d[None, :, None, :, :])
        # The contact variable of the interval ending (kc0) or starting (kc1) at the knot: a row of a foot that may
        # not be down yet (or any more) is relaxed by M (1 − c) (big-M), exact when c = 1.
        A.add("kc0", self.r_kin, self.i_c[:, :, None])
        A.add("kc1", self.r_kin[: N - 1], self.i_c[1:, :, None])
        A.add("db", self.r_foot[:, :, :2], self.i_d)
        A.add("dp", self.r_foot[:, :, 2:, None], self.i_d[:, :, None, :])
        self.A_blocks = A.blocks
        self.A_nnz = A.n
        self.A, self.A_order = A.csc((self.m, self.n))

        P = _Pattern()
        loc = np.array([0, 1, 2, 6, 7, 8])  # p and θ of a knot: the hip-over-foot cost couples them
        ia, ib = np.triu_indices(6)
        self.pt_pairs = (ia, ib)
        P.add("pt", self.ix[:, loc[ia]], self.ix[:, loc[ib]])
        # p, θ of every knot × every foothold variable: the hip-over-foot cost of a touchdown that may move.
        P.add("pd", self.ix[:, loc][:, :, None, None, None], self.i_d[None, None])
        P.add("vv", self.i_v, self.i_v)
        P.add("ww", self.i_w, self.i_w)
        P.add("ff", self.i_f, self.i_f)
        P.add("cc", self.i_c, self.i_c)
        P.add("dd", self.i_d, self.i_d)
        self.P_blocks = P.blocks
        self.P_nnz = P.n
        self.P, self.P_order = P.csc((self.n, self.n))
