"""The contact schedule of a problem on its grid: per interval and leg, is the foot down, optional, or in the air.

Timing adjustment is a convex relaxation on the grid. Each interval/leg has a contact variable c in [0, 1] with
c·fz_min <= f_n <= c·fz_max. Outside any timing window c is fixed (0 swing, 1 stance). Inside a touchdown window
(earliest .. latest touchdown, knots on both edges and at the nominal time) c is free but non-decreasing; inside a
liftoff window free but non-increasing. The foot's place during a window is known (the touchdown's place, itself a
decision variable), so loading it early or late is physically meaningful. A linear cost on c charges each interval
of early contact (or missing contact after the nominal time) 2·w·|t_mid − t_nominal|·dt, which sums to w·Δt² for a
shift Δt: a quadratic penalty on the timing shift, exact on the grid.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from planning.centroidal.problem import LEG_NAMES, N_LEGS, CentroidalProblem, ContactPhase, polygon_halfplanes


@dataclass
class Slot:
    """One contact phase inside the horizon; ``var`` is its foothold variable (-1: the place is fixed)."""

    phase: ContactPhase
    planted: bool  # down already at t_0: its place and touchdown time are fixed
    var: int
    box: float  # |dx|, |dy| <= box (m); 0 when the place is fixed
    poly_a: np.ndarray  # (M,2) half-planes on the shift d: poly_a d <= poly_b
    poly_b: np.ndarray  # (M,)
    td_window: tuple[int, int]  # interval range [k0, k1) of the touchdown window (empty when none)
    lo_window: tuple[int, int]


@dataclass
class ContactSchedule:
    """Per interval (N) and leg: contact bounds, costs and the foothold slot; per knot (K) the slot of the foot."""

    c_lo: np.ndarray  # (N,4)
    c_hi: np.ndarray  # (N,4)
    q_c: np.ndarray  # (N,4) linear cost on c (already × touchdown_time weight)
    slot: np.ndarray  # (N,4) int, -1: no foot
    mono: np.ndarray  # (N-1,4) int: +1 c non-decreasing k→k+1, -1 non-increasing, 0 free
    knot_slot: np.ndarray  # (K,4) int: the foot constraining leg i at knot k (-1: none)
    stance_knot: np.ndarray  # (K,4) bool: surely in stance at knot k (hip-over-foot cost)
    slots: list[list[Slot]]  # per leg, in time order
    nom: np.ndarray  # (4,P,3) nominal contact point of each slot
    nrm: np.ndarray  # (4,P,3) contact normal of each slot
    var: np.ndarray  # (4,P) foothold variable of each slot, -1 when fixed
    n_fixed_for_capacity: (
        int  # adjustable touchdowns held at their nominal place (more than the solver has room for)
    )


@functools.lru_cache(maxsize=64)
@functools.lru_cache(maxsize=64)
def _octagon(radius: float) -> tuple[np.ndarray, np.ndarray]:
    """The half-planes of the octagon inscribing a circle of radius (m), computed once per radius (read-only)."""
    ang = np.arange(8) * (np.pi / 4.0) + np.pi / 8.0
    a = np.stack([np.cos(ang), np.sin(ang)], axis=1)
    b = np.full(8, radius * math.cos(np.pi / 8.0))
    a.setflags(write=False)
    b.setflags(write=False)
    return a, b


def build_schedule(
    problem: CentroidalProblem, max_adjustable: int, max_edges: int, timing: bool = True
) -> ContactSchedule | str:
    """Returns the schedule of the problem's phases on its grid, or a message when it does not fit the solver.

    max_adjustable: foothold variables per leg; later adjustable touchdowns beyond it keep their nominal place.
    """
    t = problem.t_knots
    N = t.size - 1
    K = N + 1
    t0, tN = t[0], t[-1]
    tm = 0.5 * (t[:-1] + t[1:])
    dt = t[1:] - t[:-1]
    w_t = problem.weights.touchdown_time
    phases = sorted(problem.phases, key=lambda p: (p.leg, p.t_touchdown))
    # Per phase (P): times and windows, all phases at once.
    arr = np.array(
        [(p.leg, p.t_touchdown, p.t_liftoff, *p.touchdown_window_s, *p.liftoff_window_s) for p in phases]
        if phases
        else np.zeros((0, 7))
    ).reshape(-1, 7)
    leg, td, lo = arr[:, 0].astype(np.int64), arr[:, 1], arr[:, 2]
    e1, l1, e2, l2 = (arr[:, j] * float(timing) for j in (3, 4, 5, 6))
    planted = td <= t0 + 1e-9
    e1 = np.where(planted, 0.0, e1)
    l1 = np.where(planted, 0.0, l1)
    # A foot still in the air cannot have touched down in the past, nor can a foot already up lift off then:
    # windows start at t0 at the earliest.
    e1 = np.minimum(e1, np.maximum(td - t0, 0.0))
    e2 = np.minimum(e2, np.maximum(lo - t0, 0.0))
    # Windows of one leg's consecutive phases that overlap share the nominal gap (liftoff → touchdown) out in
    # proportion to what each asked for, so both stay choices and the nominal timing stays one of them.
    if leg.size > 1:
        same = leg[1:] == leg[:-1]
        gap = np.maximum(td[1:] - lo[:-1], 0.0)
        ask_lo, ask_td = np.minimum(l2[:-1], gap), np.minimum(e1[1:], gap)
        over = same & (ask_lo + ask_td > gap)
        share = np.where(over, gap / np.maximum(ask_lo + ask_td, 1e-12), 1.0)
        l2[:-1] = np.where(same, ask_lo * share, l2[:-1])
        e1[1:] = np.where(same, ask_td * share, e1[1:])
    keep = ~((lo + l2 <= t0 + 1e-9) | (td - e1 >= tN - 1e-9))
    leg, td, lo, e1, l1, e2, l2, planted = (x[keep] for x in (leg, td, lo, e1, l1, e2, l2, planted))
    phases = [p for p, k in zip(phases, keep, strict=True) if k]
    has_tw = (e1 + l1 > 0.0)[:, None]
    has_lw = (e2 + l2 > 0.0)[:, None]
    T = tm[None, :]
    in_td = (T >= (td - e1)[:, None]) & (T < (td + l1)[:, None]) & has_tw
    in_lo = (T >= (lo - e2)[:, None]) & (T < (lo + l2)[:, None]) & has_lw
    sure = (T >= (td + l1)[:, None]) & (T < (lo - e2)[:, None])
    any_c = in_td | in_lo | sure  # (P,N)
    c_lo = np.zeros((N, N_LEGS))
    c_hi = np.zeros((N, N_LEGS))
    q_c = np.zeros((N, N_LEGS))
    slot = np.full((N, N_LEGS), -1, dtype=np.int64)
    mono = np.zeros((max(N - 1, 0), N_LEGS), dtype=np.int64)
    # Timing costs: touchdown early (c = 1 before nominal) or late (c = 0 after nominal); liftoff likewise.
    d_td = 2.0 * w_t * (tm[None, :] - td[:, None]) * dt[None, :]
    d_lo = 2.0 * w_t * (tm[None, :] - lo[:, None]) * dt[None, :]
    q_ph = np.where(in_td, -d_td, 0.0) + np.where(in_lo, d_lo, 0.0)  # (P,N): + early td, − late td, ...
    slots: list[list[Slot]] = [[] for _ in range(N_LEGS)]
    n_capacity = 0
    td_span = _spans(in_td)
    lo_span = _spans(in_lo)
    # Every phase at once (a leg's phases are consecutive rows, in time order): the grid arrays. A phase's intervals
    # may not meet an earlier phase's of the same leg.
    n_ph = len(phases)
    if n_ph:
        j_all = np.arange(n_ph)
        first = np.searchsorted(leg, leg)  # each phase's leg's first row
        onehot = (leg[:, None] == np.arange(N_LEGS)).astype(float)  # (P,4)
        cum = np.zeros((n_ph + 1, N))
        np.cumsum(any_c, axis=0, out=cum[1:])
        earlier = cum[j_all] - cum[first]  # intervals of the leg's earlier phases
        clash = (any_c & (earlier > 0.0)).any(axis=1)
        first_clash = int(np.argmax(clash)) if clash.any() else n_ph
        count = any_c.T @ onehot  # (N,4)
        slot[:] = np.where(count > 0.0, (any_c * (j_all - first)[:, None]).T @ onehot, -1.0)
        c_lo[:] = (sure.T @ onehot) > 0.0
        c_hi[:] = count > 0.0
        q_c[:] = q_ph.T @ onehot
        if N > 1:
            # Later phases win, and within a phase its liftoff window over its touchdown window.
            t_up = in_td[:, :-1] & in_td[:, 1:]
            l_dn = in_lo[:, :-1] & in_lo[:, 1:]
            val = np.where(l_dn, -1, np.where(t_up, 1, 0))
            hit = (t_up | l_dn)[:, :, None] & (onehot > 0.0)[:, None, :]  # (P,N-1,4)
            last = np.where(hit, j_all[:, None, None], -1).max(axis=0)  # (N-1,4)
            mono[:] = np.where(last >= 0, val[np.maximum(last, 0), np.arange(N - 1)[:, None]], 0)
    else:
        first_clash = 0
    for j, ph in enumerate(phases):
        i = int(leg[j])
        if j == first_clash:
            return f"phases: leg {LEG_NAMES[i]} has overlapping contact phases at {ph.t_touchdown:.3f} s"
        # Foothold shift set.
        adjustable = (not planted[j]) and ph.adjustable_place
        n_var = sum(1 for x in slots[i] if x.var >= 0)
        var = n_var if (adjustable and n_var < max_adjustable) else -1
        n_capacity += int(adjustable and var < 0)
        if var < 0:
            box, pa, pb = 0.0, _NO_EDGES, _NO_OFFSETS
        elif ph.region_xy is not None:
            pa, pb = polygon_halfplanes(ph.region_xy)
            pb = pb - pa @ ph.p_world_foot[:2]
            box = ph.adjust_radius_m if ph.adjust_radius_m > 0.0 else 1.0
        else:
            pa, pb = _octagon(ph.adjust_radius_m)
            box = ph.adjust_radius_m
        if pa.shape[0] > max_edges:
            return (
                f"phases ({LEG_NAMES[i]} at {ph.t_touchdown:.3f} s).region_xy: {pa.shape[0]} edges, "
                f"the solver takes at most {max_edges}"
            )
        slots[i].append(Slot(ph, bool(planted[j]), var, box, pa, pb, td_span[j], lo_span[j]))
    knot_slot = np.full((K, N_LEGS), -1, dtype=np.int64)
    knot_slot[1:] = slot  # the foot of the interval that ends at the knot ...
    knot_slot[:-1] = np.where(slot >= 0, slot, knot_slot[:-1])  # ... unless one starts there
    stance_knot = np.zeros((K, N_LEGS), dtype=bool)
    stance_knot[:-1] |= c_lo > 0.5
    stance_knot[1:] |= c_lo > 0.5
    P = max(1, max(len(x) for x in slots))
    nom = np.zeros((N_LEGS, P, 3))
    nrm = np.zeros((N_LEGS, P, 3))
    nrm[..., 2] = 1.0
    var_idx = np.full((N_LEGS, P), -1, dtype=np.int64)
    for i in range(N_LEGS):
        for j, sl in enumerate(slots[i]):
            nom[i, j] = sl.phase.p_world_foot
            nrm[i, j] = sl.phase.normal
            var_idx[i, j] = sl.var
    return ContactSchedule(
        c_lo, c_hi, q_c, slot, mono, knot_slot, stance_knot, slots, nom, nrm, var_idx, n_capacity
    )


_NO_EDGES = np.zeros((0, 2))
_NO_OFFSETS = np.zeros(0)


def _spans(mask: np.ndarray) -> list[tuple[int, int]]:
    """Returns per row of mask (P,N) the range [first, last + 1) of its True entries, or (0, 0)."""
    if mask.size == 0:
        return [(0, 0)] * mask.shape[0]
    anyr = np.asarray(mask.any(axis=1)).tolist()
    first = np.argmax(mask, axis=1)
    last = mask.shape[1] - np.argmax(mask[:, ::-1], axis=1)
    return [
        (int(f), int(e)) if a else (0, 0) for a, f, e in zip(anyr, first.tolist(), last.tolist(), strict=True)
    ]
