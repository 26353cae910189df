"""A tight reference solve of the solver's last QP with Clarabel (interior point, 1e-9), for tests and the bench.

Not used on the hot path; Clarabel is a development dependency, imported only when this runs.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from planning.centroidal.solver import CentroidalSolver

_BIG = 1e20


def reference_forces(solver: CentroidalSolver, tol: float = 1e-9) -> tuple[np.ndarray, str]:
    """Returns (forces (N,4,3) N, Clarabel's status) of the solver's last QP (linearization and cuts as solved)."""
    import clarabel

    snap = solver.last_snapshot
    if snap is None:
        raise RuntimeError("reference_forces: the solver has not solved anything yet")
    L = snap.layout
    P = sp.csc_matrix((snap.P_x[L.P_order], L.P.indices, L.P.indptr), shape=L.P.shape)
    A = sp.csc_matrix((snap.A_x[L.A_order], L.A.indices, L.A.indptr), shape=L.A.shape).tocsr()
    l, u, q = snap.l, snap.u, snap.q
    eq = np.abs(u - l) <= 1e-12
    up = ~eq & (u < _BIG)
    lo = ~eq & (l > -_BIG)
    A_all = sp.vstack([A[eq], A[up], -A[lo]]).tocsc()
    b = np.concatenate([u[eq], u[up], -l[lo]])
    cones = [clarabel.ZeroConeT(int(eq.sum())), clarabel.NonnegativeConeT(int(up.sum() + lo.sum()))]
    st = clarabel.DefaultSettings()
    st.verbose = False
    st.tol_gap_abs = tol
    st.tol_gap_rel = tol
    st.tol_feas = tol
    st.tol_ktratio = 1e-7
    st.max_iter = 200
    res = clarabel.DefaultSolver(sp.triu(P).tocsc(), q, A_all, b, cones, st).solve()
    x = np.asarray(res.x)
    return x[L.i_f[: snap.N]] * snap.force_scale, str(res.status)
