"""Linear inverted pendulum (LIP): capture points and closed-form state prediction along step paths.

LIP: x'' = ω² (x - u) with ω = sqrt(g / z), x the CoM's ground projection, u the CoP (both world xy, m).
The capture point (divergent component) ξ = x + x'/ω obeys ξ' = ω (ξ - u); the convergent component
ζ = x - x'/ω obeys ζ' = -ω (ζ - u); so x = (ξ + ζ)/2 and x' = ω (ξ - ζ)/2. For a CoP that is constant, or
moves linearly, over a support segment, both have closed forms, and over a sequence of segments ξ at any event
time is a cumulative sum — which is what makes scoring dozens of step paths cheap.

Two CoP estimates over a path (the seed's FIG. 8 discussion):
- ``"cof"``: the CoP is the center of footprint (mean of the stance feet) of each support segment.
- ``"tracking"``: the robot is expected to follow the planned capture-point trajectory ξ_p(t) = p_b(t) + v_b/ω of
  the path's body motion. In each support segment the CoP starts at the center of footprint and moves linearly,
  through the stance, a fraction β of the way to the CoP a capture-point tracking controller would command,
  u = ξ - v_b/ω + k (ξ - ξ_p) (ξ taken at the segment start), clamped to the support polygon. The segments are
  chained in order (vectorized over paths). With the CoP held at the CoF the prediction drifts off within a
  cycle; this one stays near the plan as long as the footholds make the plan feasible — which is what scoring
  needs to tell footholds apart.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np

from planning.steps.state import F64, I64, N_LEGS, BodyMotion, StepPath, WalkState

GRAVITY_MPS2 = 9.81  # m/s²

CopEstimate = Literal["cof", "tracking"]


def lip_omega(z_m: float) -> float:
    """Returns the LIP natural frequency ω = sqrt(g / z), 1/s, for a CoM height z (m) above the ground."""
    if not (math.isfinite(z_m) and z_m > 0.0):
        raise ValueError(f"z: CoM height must be finite and > 0, got {z_m}")
    return math.sqrt(GRAVITY_MPS2 / z_m)


def state_omega(state: WalkState, fallback_height_m: float) -> float:
    """Returns ω for the state's CoM height above its stance feet (fallback height when implausible)."""
    z = float(state.p_world_com[2]) - state.ground_z()
    if not 0.3 * fallback_height_m < z < 3.0 * fallback_height_m:
        z = fallback_height_m
    return lip_omega(z)


def capture_point(p_com: F64, v_com: F64, z: float) -> F64:
    """Returns the capture point (2,) world m: x + v/ω for CoM position p_com (≥2,) m, velocity v_com (≥2,) m/s,
    CoM height z (m) above the ground."""
    w = lip_omega(z)
    p = np.asarray(p_com, dtype=np.float64)
    v = np.asarray(v_com, dtype=np.float64)
    return p[:2] + v[:2] / w


def capture_point_relative(xi_world: F64, p_world_foot: F64) -> F64:
    """Returns Eq. 2, Δ = x + x'/ω - p: the capture point (..., 2) relative to foot positions (..., 2) m."""
    return np.asarray(xi_world)[..., :2] - np.asarray(p_world_foot)[..., :2]


def lip_predict(
    x0: F64, v0: F64, u0: F64, tau: float, omega: float, u1: F64 | None = None
) -> tuple[F64, F64]:
    """Returns (x, v) after tau s of LIP motion from x0 (m), v0 (m/s), with the CoP constant at u0 (m) or, when
    u1 is given, moving linearly from u0 to u1 over the interval."""
    x0, v0, u0 = (np.asarray(a, dtype=np.float64) for a in (x0, v0, u0))
    w, wt = omega, omega * tau
    xi0, zeta0 = x0 + v0 / w, x0 - v0 / w
    ep, em = math.exp(wt), math.exp(-wt)
    xi = u0 + (xi0 - u0) * ep
    zeta = u0 + (zeta0 - u0) * em
    if u1 is not None:
        du = np.asarray(u1, dtype=np.float64) - u0
        xi = xi - _g_plus(wt) * du
        zeta = zeta + _g_minus(wt) * du
    return 0.5 * (xi + zeta), 0.5 * w * (xi - zeta)


def _g_plus(x: F64 | float) -> F64:
    """(e^x - 1 - x)/x, the ramp term of ξ (→ x/2 for small x)."""
    x = np.asarray(x, dtype=np.float64)
    small = x < 1e-4
    xs = np.where(small, 1.0, x)
    return np.where(small, 0.5 * x, np.expm1(xs) / xs - 1.0)


def _g_minus(x: F64 | float) -> F64:
    """1 - (1 - e^-x)/x, the ramp term of ζ (→ x/2 for small x)."""
    x = np.asarray(x, dtype=np.float64)
    small = x < 1e-4
    xs = np.where(small, 1.0, x)
    return np.where(small, 0.5 * x, 1.0 + np.expm1(-xs) / xs)


# ---- support polygon ----------------------------------------------------------------------------------------------
_PAIRS = np.array(
    [(i, j) for i in range(N_LEGS) for j in range(i, N_LEGS)], dtype=np.int64
)  # (10,2) incl. i=j
_TRIS = np.array([(0, 1, 2), (0, 1, 3), (0, 2, 3), (1, 2, 3)], dtype=np.int64)


@dataclass(frozen=True)
class Support:
    """Support polygons prepared for repeated projection: edges (pairs of stance feet, a foot paired with itself
    for a single foot) and triangles of stance feet, for rows of shape ``shape`` (e.g. (M,) or (N,E))."""

    a: F64  # (...,10,2) edge start
    ab: F64  # (...,10,2) edge vector
    inv_len2: F64  # (...,10)
    edge_ok: np.ndarray  # (...,10)
    p0: F64  # (...,4,2) triangle corners
    e01: F64
    e12: F64
    p1: F64
    p2: F64
    e20: F64
    tri_ok: np.ndarray  # (...,4)
    any_stance: np.ndarray  # (...)

    @staticmethod
    def of(feet: F64, stance: np.ndarray) -> Support:
        """feet: (...,4,2) foot xy, m; stance: (...,4) bool."""
        a = feet[..., _PAIRS[:, 0], :]
        ab = feet[..., _PAIRS[:, 1], :] - a
        len2 = np.einsum("...i,...i->...", ab, ab)
        p0, p1, p2 = feet[..., _TRIS[:, 0], :], feet[..., _TRIS[:, 1], :], feet[..., _TRIS[:, 2], :]
        e01, e12, e20 = p1 - p0, p2 - p1, p0 - p2
        area = e01[..., 0] * (p2 - p0)[..., 1] - e01[..., 1] * (p2 - p0)[..., 0]
        tri_ok = stance[..., _TRIS[:, 0]] & stance[..., _TRIS[:, 1]] & stance[..., _TRIS[:, 2]]
        return Support(
            a=a,
            ab=ab,
            inv_len2=np.where(len2 > 1e-12, 1.0 / np.maximum(len2, 1e-12), 0.0),
            edge_ok=stance[..., _PAIRS[:, 0]] & stance[..., _PAIRS[:, 1]],
            p0=p0,
            e01=e01,
            e12=e12,
            p1=p1,
            p2=p2,
            e20=e20,
            tri_ok=tri_ok & (np.abs(area) > 1e-12),
            any_stance=np.asarray(stance.any(axis=-1)),
        )

    def project(self, q: F64, j: int | None = None) -> F64:
        """Returns the points of the polygons nearest to q (...,2) (rows of column j when given)."""
        s_ = (slice(None), j) if j is not None else (Ellipsis,)
        a, ab = self.a[s_], self.ab[s_]
        qq = q[..., None, :]
        s = np.clip(np.einsum("...pi,...pi->...p", qq - a, ab) * self.inv_len2[s_], 0.0, 1.0)
        c = a + s[..., None] * ab
        d = c - qq
        d2 = np.where(self.edge_ok[s_], np.einsum("...pi,...pi->...p", d, d), np.inf)
        edge = np.take_along_axis(c, np.argmin(d2, axis=-1)[..., None, None], axis=-2)[..., 0, :]

        def side(p: F64, e: F64) -> F64:
            return e[..., 0] * (qq[..., 1] - p[..., 1]) - e[..., 1] * (qq[..., 0] - p[..., 0])

        c0, c1, c2 = (
            side(self.p0[s_], self.e01[s_]),
            side(self.p1[s_], self.e12[s_]),
            side(self.p2[s_], self.e20[s_]),
        )
        inside = self.tri_ok[s_] & (((c0 >= 0) & (c1 >= 0) & (c2 >= 0)) | ((c0 <= 0) & (c1 <= 0) & (c2 <= 0)))
        keep = inside.any(axis=-1) | ~self.any_stance[s_]
        return np.where(keep[..., None], q, edge)


class _SupportColumns:
    """Support polygons of (N,E) rows laid out per column in x/y components, for projecting one column at a time
    in a sequential loop: Support.project(q, j) with the same arithmetic and less overhead.

    feet: (N,E,4,2) foot xy, m; stance: (N,E,4) bool."""

    def __init__(self, feet: F64, stance: np.ndarray) -> None:
        # Support.of's arithmetic on contiguous per-component (E,N,4) arrays
        fx = np.ascontiguousarray(np.swapaxes(feet[..., 0], 0, 1))
        fy = np.ascontiguousarray(np.swapaxes(feet[..., 1], 0, 1))
        st = np.ascontiguousarray(np.swapaxes(stance, 0, 1))
        i, j = _PAIRS[:, 0], _PAIRS[:, 1]
        self.ax, self.ay = fx[..., i], fy[..., i]
        self.abx, self.aby = fx[..., j] - self.ax, fy[..., j] - self.ay
        len2 = self.abx * self.abx + self.aby * self.aby
        self.inv_len2 = np.where(len2 > 1e-12, 1.0 / np.maximum(len2, 1e-12), 0.0)
        self.edge_ok = st[..., i] & st[..., j]
        t0, t1, t2 = _TRIS[:, 0], _TRIS[:, 1], _TRIS[:, 2]
        p0x, p1x, p2x = fx[..., t0], fx[..., t1], fx[..., t2]
        p0y, p1y, p2y = fy[..., t0], fy[..., t1], fy[..., t2]
        e01x, e01y = p1x - p0x, p1y - p0y
        area = e01x * (p2y - p0y) - e01y * (p2x - p0x)
        # the three sides of every triangle stacked: (3,E,N,4) corner and edge components
        self.tpx = np.stack([p0x, p1x, p2x])
        self.tpy = np.stack([p0y, p1y, p2y])
        self.tex = np.stack([e01x, p2x - p1x, p0x - p2x])
        self.tey = np.stack([e01y, p2y - p1y, p0y - p2y])
        self.tri_ok = st[..., t0] & st[..., t1] & st[..., t2] & (np.abs(area) > 1e-12)
        self.no_stance: np.ndarray = ~np.asarray(st.any(axis=-1))
        self.rows = np.arange(fx.shape[1])
        # per column: whether any polygon has an area (a trot's two feet make segments: no inside to test)
        self.any_tri: list[bool] = [bool(x) for x in np.asarray(self.tri_ok.any(axis=(1, 2)))]
        self.any_bare: list[bool] = [bool(x) for x in np.asarray(self.no_stance.any(axis=1))]

    def project(self, q: F64, j: int) -> F64:
        """Returns the points (N,2) of column j's polygons nearest to q (N,2)."""
        qx, qy = q[:, 0:1], q[:, 1:2]
        ax, ay, abx, aby = self.ax[j], self.ay[j], self.abx[j], self.aby[j]
        s = np.minimum(np.maximum(((qx - ax) * abx + (qy - ay) * aby) * self.inv_len2[j], 0.0), 1.0)  # clip
        cx = ax + s * abx
        cy = ay + s * aby
        dx = cx - qx
        dy = cy - qy
        d2 = np.where(self.edge_ok[j], dx * dx + dy * dy, np.inf)
        k = np.argmin(d2, axis=-1)
        edge = np.empty_like(q)
        edge[:, 0] = cx[self.rows, k]
        edge[:, 1] = cy[self.rows, k]
        if not self.any_tri[j]:  # no polygon with an area in this column: q is inside none
            if not self.any_bare[j]:
                return edge
            return np.where(self.no_stance[j][:, None], q, edge)
        # which side of each triangle edge q is on (3,N,4); inside: on the same side of all three
        c = self.tex[:, j] * (qy - self.tpy[:, j]) - self.tey[:, j] * (qx - self.tpx[:, j])
        inside = self.tri_ok[j] & ((c >= 0).all(axis=0) | (c <= 0).all(axis=0))
        keep = inside.any(axis=-1) | self.no_stance[j]
        return np.where(keep[:, None], q, edge)


def project_to_support(q: F64, feet: F64, stance: np.ndarray) -> F64:
    """Returns the points (M,2) of the support polygons nearest to q (M,2).

    feet: (M,4,2) foot xy, m; stance: (M,4) bool. The polygon is the convex hull of the stance feet (a segment
    for two, a point for one); rows without a stance foot return q unchanged.
    """
    return Support.of(feet, stance).project(q)


# ---- batched prediction along step paths ------------------------------------------------------------------------
@dataclass(frozen=True)
class PathBatch:
    """N step paths with the same touchdown legs, stacked. leg: (K,). t_td, t_lo: (N,K) s. t_lo_now: (N,4) s.
    p_td: (N,K,3) m."""

    leg: I64
    t_td: F64
    t_lo: F64
    t_lo_now: F64
    p_td: F64
    body: BodyMotion

    @staticmethod
    def of(paths: list[StepPath]) -> PathBatch:
        leg = paths[0].leg
        for p in paths[1:]:
            if not np.array_equal(p.leg, leg):
                raise ValueError("paths: every candidate must have the reference's touchdown legs, in order")
        return PathBatch(
            leg=leg,
            t_td=np.stack([p.t_touchdown for p in paths]),
            t_lo=np.stack([p.t_liftoff for p in paths]),
            t_lo_now=np.stack([p.t_liftoff_now for p in paths]),
            p_td=np.stack([p.p_world_touchdown for p in paths]),
            body=paths[0].body,
        )

    @property
    def n(self) -> int:
        return int(self.t_td.shape[0])

    def rows(self, sl: slice) -> PathBatch:
        """Returns the batch of the paths in rows ``sl``."""
        return PathBatch(self.leg, self.t_td[sl], self.t_lo[sl], self.t_lo_now[sl], self.p_td[sl], self.body)

    def with_first(self, path: StepPath) -> PathBatch:
        """Returns this batch with ``path`` (same touchdown legs) stacked in front as row 0."""
        if not np.array_equal(path.leg, self.leg):
            raise ValueError("paths: every candidate must have the reference's touchdown legs, in order")
        return PathBatch(
            leg=self.leg,
            t_td=np.concatenate([path.t_touchdown[None], self.t_td]),
            t_lo=np.concatenate([path.t_liftoff[None], self.t_lo]),
            t_lo_now=np.concatenate([path.t_liftoff_now[None], self.t_lo_now]),
            p_td=np.concatenate([path.p_world_touchdown[None], self.p_td]),
            body=self.body,
        )


class StepPaths(list[StepPath]):
    """A list of step paths that also carries them stacked (``batch``), so scoring need not restack them."""

    def __init__(self, paths: list[StepPath], batch: PathBatch) -> None:
        super().__init__(paths)
        self.batch = batch


def batch_of(paths: list[StepPath]) -> PathBatch:
    """Returns the paths stacked: the carried batch of a StepPaths (when unchanged), else a new one."""
    b = getattr(paths, "batch", None)
    if isinstance(b, PathBatch) and b.n == len(paths):
        return b
    return PathBatch.of(paths)


@dataclass(frozen=True)
class Events:
    """The contact events of a batch, sorted per path, and the support state between them.

    times: (N,E) sorted event times (clipped to [t0, last touchdown]). bounds: (N,E+1) segment bounds, segment j
    being [bounds_j, bounds_j+1). stance_seg: (N,E,4) legs in stance in each segment. slot_seg: (N,E,4) index of
    each leg's current foot position into ``p_all`` in each segment. pos_td: (N,K) sorted position of each
    touchdown. slot_td: (N,K,4) index into ``p_all`` of every leg's foothold just after each touchdown (a leg in
    the air that has not landed yet counts at its next touchdown). p_all: (N,4+K,2) current feet then touchdowns.
    """

    times: F64
    bounds: F64
    stance_seg: np.ndarray
    slot_seg: I64
    pos_td: I64
    slot_td: I64
    p_all: F64


_EVENT_CONSTS: dict[tuple[str, bytes], tuple[I64, np.ndarray, I64, I64]] = {}


def _event_consts(leg: I64) -> tuple[I64, np.ndarray, I64, I64]:
    """Per touchdown-leg sequence (K,): each event's leg, type (touchdown) and slot, and each leg's first
    touchdown index (−1: none) — constant over ticks of a gait, so cached."""
    key = (leg.dtype.str, leg.tobytes())
    out = _EVENT_CONSTS.get(key)
    if out is None:
        k = leg.shape[0]
        ev_leg = np.concatenate([leg, leg, np.arange(N_LEGS)])
        ev_type = np.concatenate([np.ones(k, bool), np.zeros(k, bool), np.zeros(N_LEGS, bool)])
        ev_slot = np.concatenate([N_LEGS + np.arange(k), N_LEGS + np.arange(k), np.arange(N_LEGS)])
        first = np.full(N_LEGS, -1, dtype=np.int64)
        for i in range(k - 1, -1, -1):
            first[leg[i]] = i
        if len(_EVENT_CONSTS) > 256:
            _EVENT_CONSTS.clear()
        out = _EVENT_CONSTS[key] = (ev_leg, ev_type, ev_slot, first)
    return out


def sort_events(batch: PathBatch, state: WalkState) -> Events:
    """Returns the sorted contact events and support segments of every path in the batch."""
    n, k = batch.t_td.shape
    t0 = state.t
    c0 = state.contact
    e = 2 * k + N_LEGS
    lo_now = np.where(np.isnan(batch.t_lo_now), np.inf, batch.t_lo_now)
    times = np.concatenate([batch.t_td, batch.t_lo, lo_now], axis=1)  # (N,E)
    ev_leg, ev_type, ev_slot, first = _event_consts(batch.leg)
    t_end = batch.t_td.max(axis=1) if k else np.full(n, t0)
    times = np.minimum(np.maximum(times, t0), t_end[:, None])  # np.clip, without its overhead
    order = np.argsort(times, axis=1, kind="stable")
    rows = np.arange(n)[:, None]
    ts = times[rows, order]
    s_leg, s_type, s_slot = ev_leg[order], ev_type[order], ev_slot[order]
    # Forward-fill, per leg, the last event so far: its type gives stance, its slot the foot's position.
    is_leg = s_leg[:, :, None] == np.arange(N_LEGS)  # (N,E,4)
    last = np.maximum.accumulate(np.where(is_leg, np.arange(e)[None, :, None], -1), axis=1)
    has = last >= 0
    lastc = np.maximum(last, 0)
    rows3 = rows[:, :, None]
    stance_after = np.where(has, s_type[rows3, lastc], c0)
    slot_after = np.where(has, s_slot[rows3, lastc], np.arange(N_LEGS))
    stance_seg = np.empty((n, e, N_LEGS), dtype=bool)
    stance_seg[:, 0] = c0
    stance_seg[:, 1:] = stance_after[:, :-1]
    slot_seg = np.empty((n, e, N_LEGS), dtype=slot_after.dtype)
    slot_seg[:, 0] = np.arange(N_LEGS)
    slot_seg[:, 1:] = slot_after[:, :-1]
    inv = np.empty_like(order)
    inv[rows, order] = np.arange(e)[None, :]
    pos_td = inv[:, :k].astype(np.int64)
    # Footholds per leg after each touchdown; legs in the air before their first touchdown count at it.
    init_cp = np.where(c0 | (first < 0), np.arange(N_LEGS), N_LEGS + first)
    slot_cp = np.where(has, slot_after, init_cp)
    slot_td = slot_cp[rows, pos_td] if k else np.zeros((n, 0, N_LEGS), np.int64)
    p_all = np.empty((n, N_LEGS + k, 2))
    p_all[:, :N_LEGS] = state.p_world_feet[:, :2]
    p_all[:, N_LEGS:] = batch.p_td[:, :, :2]
    bounds = np.empty((n, e + 1))
    bounds[:, 0] = t0
    bounds[:, 1:] = ts
    return Events(ts, bounds, stance_seg, slot_seg, pos_td, slot_td, p_all)


def gather_xy(p_all: F64, slots: I64) -> F64:
    """Returns p_all (N,S,2) gathered at slots (N,...) → (N,...,2)."""
    n = p_all.shape[0]
    flat = slots.reshape(n, -1)
    return p_all[np.arange(n)[:, None], flat].reshape(*slots.shape, 2)


@dataclass(frozen=True)
class Prediction:
    """LIP prediction of a batch of paths. xi_td: (N,K,2) capture point at each touchdown, world m.
    x_td, v_td: (N,K,2) CoM position (m) and velocity (m/s) at each touchdown (only when asked for).
    cop_start, cop_end: (N,E,2) CoP at the start and end of each support segment, m."""

    xi_td: F64
    x_td: F64 | None
    v_td: F64 | None
    cop_start: F64
    cop_end: F64


def predict_batch(
    batch: PathBatch,
    state: WalkState,
    omega: float,
    estimate: CopEstimate = "tracking",
    tracking_fraction: float = 1.0,
    events: Events | None = None,
    with_states: bool = False,
    feedback_gain: float = 2.0,
) -> Prediction:
    """Returns the LIP prediction (capture points at touchdowns) of every path in the batch, closed form."""
    ev = events if events is not None else sort_events(batch, state)
    n, k = batch.t_td.shape
    e = ev.times.shape[1]
    t0 = state.t
    x0 = state.p_world_com[:2]
    v0 = state.v_world_com[:2]
    xi0, zeta0 = x0 + v0 / omega, x0 - v0 / omega
    # CoF of each segment; a segment with no stance foot keeps the previous segment's CoP (or the CoM).
    feet = gather_xy(ev.p_all, ev.slot_seg)  # (N,E,4,2)
    w = ev.stance_seg
    cnt = w.sum(axis=2)
    cof = np.einsum("nel,neli->nei", w.astype(np.float64), feet) / np.maximum(cnt, 1)[..., None]
    if not np.all(cnt > 0):
        idx = np.maximum.accumulate(np.where(cnt > 0, np.arange(e), -1), axis=1)
        cof = np.where(
            (idx >= 0)[..., None], np.take_along_axis(cof, np.maximum(idx, 0)[..., None], axis=1), x0
        )
    # ξ at segment ends: ξ_e = exp(ω(t_e - t0)) (ξ0 - Σ_{j≤e} (a_j - a_j+1) u_j), a_j = exp(-ω(b_j - t0)).
    tracking = estimate == "tracking" and e > 0
    a = np.exp(-omega * (ev.bounds - t0)) if (with_states or not tracking) else None  # (N,E+1)
    u0, u1 = cof, cof
    if not tracking:
        assert a is not None
        grow = 1.0 / a[:, 1:]  # exp(ω(t_e - t0))
        da = (a[:, :-1] - a[:, 1:])[..., None]
        xi_end = grow[..., None] * (xi0 - np.cumsum(da * cof, axis=1))  # (N,E,2)
    if tracking:
        # Sequential over segments (vectorized over paths): the CoP ramps from the CoF toward what a
        # capture-point tracking controller would command at the segment start, clamped to the support. Only
        # segments that last somewhere need a step (most events are clipped to the end: zero length); the
        # others keep ξ and their CoF.
        tau = np.diff(ev.bounds, axis=1)
        act = np.flatnonzero((tau > 0.0).any(axis=0))
        tau_a = tau[:, act]
        ep = np.exp(omega * tau_a)[:, :, None]
        gp = _g_plus(omega * tau_a)[:, :, None]
        body = batch.body
        b_a = ev.bounds[:, act]  # segment starts
        v_plan = body.velocity_world(b_a)  # (N,A,2)
        xi_plan = body.position(b_a) + v_plan / omega
        v_plan_w = v_plan / omega
        support = _SupportColumns(feet[:, act], w[:, act])
        u1 = cof.copy()
        xi_end = np.empty_like(cof)
        xi = np.broadcast_to(xi0, (n, 2))
        prev = 0
        for col, j in enumerate(act.tolist()):
            xi_end[:, prev:j] = xi[:, None]
            cof_j = cof[:, j]
            d = xi - v_plan_w[:, col] + feedback_gain * (xi - xi_plan[:, col])
            u1_j = u1[:, j]
            u1_j += tracking_fraction * (support.project(d, col) - cof_j)
            xi = cof_j + (xi - cof_j) * ep[:, col] - gp[:, col] * (u1_j - cof_j)
            xi_end[:, j] = xi
            prev = j + 1
        xi_end[:, prev:] = xi[:, None]
    elif estimate not in ("cof", "tracking"):
        raise ValueError(f"estimate: must be 'cof' or 'tracking', got {estimate!r}")
    xi_td = xi_end[np.arange(n)[:, None], ev.pos_td] if k else np.zeros((n, 0, 2))
    x_td = v_td = None
    if with_states:
        assert a is not None
        b = 1.0 / a  # exp(ω(b_j - t0))
        shrink = a[:, 1:]
        db = (b[:, 1:] - b[:, :-1])[..., None]
        zeta_end = shrink[..., None] * (zeta0 + np.cumsum(db * u0, axis=1))
        if estimate == "tracking":
            tau = np.diff(ev.bounds, axis=1)
            zeta_end = zeta_end + shrink[..., None] * np.cumsum(
                (b[:, 1:] * _g_minus(omega * tau))[..., None] * (u1 - u0), axis=1
            )
        zeta_td = np.take_along_axis(zeta_end, ev.pos_td[..., None], axis=1) if k else np.zeros((n, 0, 2))
        x_td = 0.5 * (xi_td + zeta_td)
        v_td = 0.5 * omega * (xi_td - zeta_td)
    return Prediction(xi_td=xi_td, x_td=x_td, v_td=v_td, cop_start=u0, cop_end=u1)


@dataclass(frozen=True)
class TouchdownStates:
    """Predicted LIP state at each touchdown of one path. t: (K,) s. p_com, v_com, xi: (K,2) world m, m/s, m.
    xi_rel: (K,4,2) capture point relative to each leg's foothold (Eq. 2)."""

    t: F64
    p_com: F64
    v_com: F64
    xi: F64
    xi_rel: F64


def predict_touchdown_states(
    path: StepPath,
    state: WalkState,
    omega: float,
    estimate: CopEstimate = "tracking",
    tracking_fraction: float = 1.0,
    feedback_gain: float = 2.0,
) -> TouchdownStates:
    """Returns the LIP state and capture points at each touchdown of ``path`` from ``state``."""
    batch = PathBatch.of([path])
    ev = sort_events(batch, state)
    pr = predict_batch(
        batch,
        state,
        omega,
        estimate,
        tracking_fraction,
        events=ev,
        with_states=True,
        feedback_gain=feedback_gain,
    )
    assert pr.x_td is not None and pr.v_td is not None
    feet_td = gather_xy(ev.p_all, ev.slot_td)  # (1,K,4,2)
    return TouchdownStates(
        t=path.t_touchdown.copy(),
        p_com=pr.x_td[0],
        v_com=pr.v_td[0],
        xi=pr.xi_td[0],
        xi_rel=capture_point_relative(pr.xi_td[0][:, None, :], feet_td[0]),
    )
