"""Potential step paths: variations of the reference, screened against the robot's constraints.

Families, in the order they are tried (the order matters for lazy, first-below-threshold selection):
- ``reference``: the reference itself (wins with score 0 whenever it is feasible);
- ``clamped``: the reference's touchdowns moved into the reach octagon and off the body's midline;
- ``avoid``, ``avoid_long``, ``avoid_short`` (with maps): the clamped touchdowns that land on no-step cells moved
  to the nearest allowed point around them (any direction, only forward, only backward);
- ``push``: the template steps (below) moved after the measured velocity error by g·(v - v_cmd)/ω for gains g
  other than the reference's (full and lateral-only), halved for each later touchdown of a leg — steps that
  counteract the motion after a push more or less strongly than the reference;
- ``timing``: all future events earlier or later (footholds follow the body), for n ≥ 50 also a faster and a
  slower cadence;
- ``template``: the gait's template steps (neutral points at mid-stance, no feedback), stepping in place, and a
  wider and a narrower stance;
- ``offset``: each leg's next touchdown moved by rings of offsets in 8 heading-frame directions;
- ``footprint``: each leg's next touchdown placed on sample points of its footprint area (the reach octagon
  around the neutral point at touchdown).

Screening (constraints of the robot): reach (inside the octagon around the neutral point at touchdown and at
liftoff), self-collision (a keep-out distance from the other feet, and no crossing of the body's midline), the
no-step map when maps are given, and timing (touchdowns in the future, a minimum swing and stance time, a maximum
swing speed, a foot on the ground at all times). Infeasible candidates are dropped; if none is feasible, all are
kept with their violation, which selection penalizes heavily (so the least-violating wins).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from planning.steps.lip import PathBatch, StepPaths, gather_xy, sort_events, state_omega
from planning.steps.reference import eval_map, map_height, touchdown_rank
from planning.steps.state import F64, N_LEGS, StepMaps, StepPath, StepRobot, WalkState, rotate_cs, rotate_yaw


@dataclass(frozen=True)
class Constraints:
    """Screening limits.

    reach_x_m, reach_y_m: half-length and half-width of the reach octagon around a leg's neutral point, heading
    frame, m (capped by the leg's geometric reach at standing height times reach_fraction). reach_corner: -, the
    octagon is the box cut by |dx|/rx + |dy|/ry <= reach_corner (1 = diamond, 2 = box). keep_out_m: minimum distance
    from a touchdown to the other feet, m. midline_margin_m: a foot stays this far on its own side of the body's
    center line, m. min_swing_s, min_stance_s: s. min_time_to_touchdown_s: s. max_swing_speed_mps: average foot
    speed over a swing, m/s. min_support_legs: feet on the ground at any time. no_step_violation_m: violation
    counted per touchdown on a no-step cell, m.
    """

    reach_x_m: float = 0.32
    reach_y_m: float = 0.15
    reach_corner: float = 1.5
    reach_fraction: float = 0.9
    keep_out_m: float = 0.12
    midline_margin_m: float = 0.03
    min_swing_s: float = 0.10
    min_stance_s: float = 0.08
    min_time_to_touchdown_s: float = 0.005
    max_swing_speed_mps: float = 4.0
    min_support_legs: int = 1
    no_step_violation_m: float = 0.1


@dataclass(frozen=True)
class PotentialParams:
    """offset_step_m: spacing of the offset rings, m. timing_shift_s: s. push_gains: -, capture-point feedback
    gains of the push family (the reference uses ReferenceParams.capture_gain). push_min_error_mps: m/s, the
    push family is generated only above this velocity error. width_delta_m: m, wider /
    narrower template."""

    constraints: Constraints = field(default_factory=Constraints)
    offset_step_m: float = 0.035
    timing_shift_s: float = 0.03
    push_gains: tuple[float, ...] = (0.6, 1.4, 1.8)
    push_min_error_mps: float = 0.05
    width_delta_m: float = 0.04


@dataclass(frozen=True)
class Octagon:
    """Reach octagon dimensions for a robot. rx, ry: m. corner: -. neutral: (4,2) neutral points, body m."""

    rx: float
    ry: float
    corner: float
    neutral: F64

    @staticmethod
    def of(robot: StepRobot, c: Constraints) -> Octagon:
        h = robot.standing_height_m + float(np.mean(np.asarray(robot.p_body_hip)[:, 2]))
        geo = math.sqrt(max(robot.max_leg_length_m**2 - h**2, 1e-6)) * c.reach_fraction
        return Octagon(
            rx=min(c.reach_x_m, geo),
            ry=min(c.reach_y_m, geo),
            corner=c.reach_corner,
            neutral=np.asarray(robot.nominal_foot_body, dtype=np.float64)[:, :2],
        )

    def violation(self, d: F64) -> F64:
        """Returns how far (m, ~) heading-frame offsets d (...,2) from the neutral point lie outside."""
        ax, ay = np.abs(d[..., 0]), np.abs(d[..., 1])
        v = np.maximum(ax - self.rx, 0.0) + np.maximum(ay - self.ry, 0.0)
        return v + np.maximum(ax / self.rx + ay / self.ry - self.corner, 0.0) * min(self.rx, self.ry)

    def clamp(self, d: F64) -> F64:
        """Returns offsets d (...,2) moved into the octagon (box clamp, then onto the corner cut)."""
        s = np.sign(d)
        a = np.minimum(np.abs(d), [self.rx, self.ry])
        nrm = np.array([1.0 / self.rx, 1.0 / self.ry])
        excess = a @ nrm - self.corner
        a = a - np.maximum(excess, 0.0)[..., None] * nrm / (nrm @ nrm)
        return s * np.minimum(np.maximum(a, 0.0), [self.rx, self.ry])  # np.clip, without its overhead


# ---- generation -----------------------------------------------------------------------------------------------------
@dataclass
class _Family:
    """Candidates under construction: touchdown xy (M,K,2), time shift (M,) s, cadence scale (M,), kinds."""

    xy: list[F64] = field(default_factory=list)
    shift: list[float] = field(default_factory=list)
    scale: list[float] = field(default_factory=list)
    kind: list[str] = field(default_factory=list)

    def add(self, xy: F64, kind: str, shift: float = 0.0, scale: float = 1.0) -> None:
        self.xy.append(xy)
        self.shift.append(shift)
        self.scale.append(scale)
        self.kind.append(kind)


def _heading_to_world(yaw: F64, d: F64) -> F64:
    return rotate_yaw(yaw, d)


def _generate(
    reference: StepPath,
    state: WalkState,
    oct_: Octagon,
    n: int,
    p: PotentialParams,
    omega: float,
    maps: StepMaps | None,
) -> _Family:
    """Returns up to n candidates (touchdown xy and timing changes) in family order, unscreened."""
    fam = _Family()
    ref_xy = reference.p_world_touchdown[:, :2]
    leg = reference.leg
    k = leg.shape[0]
    body = reference.body
    t0 = body.t0
    rank = touchdown_rank(leg)
    first = (rank == 0)[:, None]
    t_lo = _liftoff_or_nominal(reference)
    t_mid = reference.t_touchdown + 0.5 * (t_lo - reference.t_touchdown)  # mid-stance
    neutral_mid = body.neutral_points(t_mid, oct_.neutral, leg)
    yaw_td = body.yaw(reference.t_touchdown)
    yaw_lo = body.yaw(t_lo)
    neutral_td = body.neutral_points(reference.t_touchdown, oct_.neutral, leg)
    neutral_lo = body.neutral_points(t_lo, oct_.neutral, leg)

    fam.add(ref_xy, "reference")
    # Clamped reference: alternate projections onto the touchdown and liftoff octagons, then off the midline.
    side = np.sign(oct_.neutral[leg, 1])
    body_td = body.position(reference.t_touchdown)
    margin = p.constraints.midline_margin_m + 0.005

    # the trigonometry of each yaw array, once (rotate_cs(*cs[y], d) == rotate_yaw(y, d))
    cs_td, cs_lo = (np.cos(yaw_td), np.sin(yaw_td)), (np.cos(yaw_lo), np.sin(yaw_lo))
    cs_td_inv, cs_lo_inv = (np.cos(-yaw_td), np.sin(-yaw_td)), (np.cos(-yaw_lo), np.sin(-yaw_lo))

    def clamp(xy: F64) -> F64:
        for _ in range(2):
            for nb, fwd, inv in ((neutral_td, cs_td, cs_td_inv), (neutral_lo, cs_lo, cs_lo_inv)):
                d = rotate_cs(*inv, xy - nb)
                xy = nb + rotate_cs(*fwd, oct_.clamp(d))
        d = rotate_cs(*cs_td_inv, xy - body_td)
        d[:, 1] = side * np.maximum(side * d[:, 1], margin)
        return body_td + rotate_cs(*cs_td, d)

    clamped = clamp(ref_xy)
    fam.add(clamped, "clamped")
    if maps is not None:
        # Off the no-step cells: each touchdown on one moves to the nearest allowed point of its footprint
        # (any direction, or only forward / backward along the heading: a longer or a shorter step).
        for name, moved in zip(
            ("avoid", "avoid_long", "avoid_short"), _avoid_all(clamped, yaw_td, maps), strict=True
        ):
            fam.add(moved, name)
    # Push counteraction.
    v_err = state.v_world_com[:2] - body.velocity_world(t0)
    decay = 0.5**rank
    lat = _heading_to_world(np.asarray(body.yaw0), np.array([0.0, 1.0]))
    v_lat = lat * float(v_err @ lat)
    if float(np.linalg.norm(v_err)) > p.push_min_error_mps:
        for g in p.push_gains:
            fam.add(neutral_mid + g * decay[:, None] * v_err / omega, "push")
        for g in p.push_gains[:2]:
            fam.add(neutral_mid + g * decay[:, None] * v_lat / omega, "push_lateral")
    # Timing variants.
    shifts = [-p.timing_shift_s, p.timing_shift_s] + (
        [-2 * p.timing_shift_s, 2 * p.timing_shift_s] if n >= 50 else []
    )
    for s in shifts:
        fam.add(ref_xy + body.neutral_points(t_mid + s, oct_.neutral, leg) - neutral_mid, "timing", shift=s)
    if n >= 50:
        for sc in (0.9, 1.1):
            t_mid_sc = t0 + sc * (t_mid - t0)
            fam.add(
                ref_xy + body.neutral_points(t_mid_sc, oct_.neutral, leg) - neutral_mid, "cadence", scale=sc
            )
    # Templates.
    fam.add(neutral_mid, "template")
    in_place = body.position(t0) + _heading_to_world(np.asarray(body.yaw0), oct_.neutral[leg])
    fam.add(in_place if k else ref_xy, "in_place")
    out = side[:, None] * np.array([0.0, 1.0])
    for dw, name in ((p.width_delta_m, "wide"), (-p.width_delta_m, "narrow")):
        fam.add(neutral_mid + rotate_cs(*cs_td, dw * out), name)
    # Offsets of each leg's next touchdown, then footprint samples, to fill up to n (all of a kind at once).
    rest = max(n - len(fam.kind), 0)
    n_off = (rest * 3 + 4) // 5
    if n_off:
        i = np.arange(n_off)
        off = (1 + i // 8)[:, None] * p.offset_step_m * _OFFSET_DIRS[i % 8]  # (n_off,2) heading frame
        d = rotate_cs(*cs_td, np.broadcast_to(off[:, None, :], (n_off, k, 2)))
        for xy in ref_xy + first * d:
            fam.add(xy, "offset")
    n_fp = rest - n_off
    if n_fp > 0:
        d = _footprint_offsets(oct_, n_fp)
        fp = neutral_td + rotate_cs(*cs_td, np.broadcast_to(d[:, None, :], (n_fp, k, 2)))
        for xy in np.where(first, fp, ref_xy):
            fam.add(xy, "footprint")
    if len(fam.kind) > n:
        for name in ("xy", "shift", "scale", "kind"):
            setattr(fam, name, getattr(fam, name)[:n])
    return fam


_OFFSET_DIRS = np.array([[math.cos(a), math.sin(a)] for a in np.arange(8) * math.pi / 4])
_FOOTPRINT_CACHE: dict[tuple[float, float, float, int], F64] = {}


def _footprint_offsets(oct_: Octagon, n_fp: int) -> F64:
    """Returns the footprint samples' heading-frame offsets (n_fp,2) m from the neutral point: rings at 0.6, 0.3
    and 0.9 of the octagon, 12 directions each, turned by 15° every third ring (cached per octagon)."""
    key = (oct_.rx, oct_.ry, oct_.corner, n_fp)
    d = _FOOTPRINT_CACHE.get(key)
    if d is None:
        angles = np.arange(12) * math.pi / 6
        fracs = (0.6, 0.3, 0.9)
        d = np.empty((n_fp, 2))
        for j in range(n_fp):
            f = fracs[(j // 12) % 3]
            a = angles[j % 12] + (j // 36) * math.pi / 12
            d[j] = f * oct_.clamp(np.array([math.cos(a), math.sin(a)]) * max(oct_.rx, oct_.ry))
        if len(_FOOTPRINT_CACHE) > 64:
            _FOOTPRINT_CACHE.clear()
        _FOOTPRINT_CACHE[key] = d
    return d


_AVOID_RINGS_M = np.array([0.03, 0.06, 0.09, 0.12, 0.16, 0.20])
_AVOID_DIRS = np.array([[math.cos(a), math.sin(a)] for a in np.arange(16) * math.pi / 8])
_AVOID_OFFSETS = (_AVOID_RINGS_M[:, None, None] * _AVOID_DIRS[None]).reshape(-1, 2)  # (S,2), nearest first


def _avoid(xy: F64, yaw: F64, maps: StepMaps, forward: float | None) -> F64:
    """Returns touchdowns (K,2) moved off no-step cells to the nearest allowed sample (heading-frame offsets,
    only those with sign(dx) == forward when given); touchdowns with no allowed sample stay."""
    bad = eval_map(maps.no_step, xy[:, 0], xy[:, 1]) > 0.5
    if not bad.any():
        return xy
    offs = _AVOID_OFFSETS if forward is None else _AVOID_OFFSETS[forward * _AVOID_OFFSETS[:, 0] > 0.0]
    cand = xy[bad][:, None, :] + _heading_to_world(
        yaw[bad][:, None], np.broadcast_to(offs, (int(bad.sum()), *offs.shape))
    )
    ok = ~(eval_map(maps.no_step, cand[..., 0], cand[..., 1]) > 0.5)
    first = np.argmax(ok, axis=1)
    out = xy.copy()
    found = ok.any(axis=1)
    idx = np.flatnonzero(bad)
    out[idx[found]] = cand[found, first[found]]
    return out


_AVOID_FORWARD = (None, 1.0, -1.0)  # _avoid_all's variants: any direction, forward only, backward only
# each variant's offsets as a mask of _AVOID_OFFSETS (the same samples, in the same order, as _avoid selects)
_AVOID_MASKS = [None if f is None else f * _AVOID_OFFSETS[:, 0] > 0.0 for f in _AVOID_FORWARD]


def _avoid_all(xy: F64, yaw: F64, maps: StepMaps) -> list[F64]:
    """Gives [_avoid(xy, yaw, maps, f) for f in _AVOID_FORWARD] from one evaluation of the no-step map at the
    touchdowns and one at every sample (a variant's samples are columns of the whole set's, turned the same way
    point by point: the same values, the same answers)."""
    bad = eval_map(maps.no_step, xy[:, 0], xy[:, 1]) > 0.5
    if not bad.any():
        return [xy, xy, xy]
    nb = int(bad.sum())
    cand_all = xy[bad][:, None, :] + _heading_to_world(
        yaw[bad][:, None], np.broadcast_to(_AVOID_OFFSETS, (nb, *_AVOID_OFFSETS.shape))
    )
    ok_all = ~(eval_map(maps.no_step, cand_all[..., 0], cand_all[..., 1]) > 0.5)
    idx = np.flatnonzero(bad)
    outs = []
    for mask in _AVOID_MASKS:
        cand = cand_all if mask is None else cand_all[:, mask]
        ok = ok_all if mask is None else ok_all[:, mask]
        first = np.argmax(ok, axis=1)
        out = xy.copy()
        found = ok.any(axis=1)
        out[idx[found]] = cand[found, first[found]]
        outs.append(out)
    return outs


def _liftoff_or_nominal(path: StepPath) -> F64:
    return np.where(np.isfinite(path.t_liftoff), path.t_liftoff, path.t_touchdown + _nominal_stance(path))


def _nominal_stance(path: StepPath) -> F64:
    fin = np.isfinite(path.t_liftoff)
    if fin.any():
        return np.full(path.leg.shape[0], _median(path.t_liftoff[fin] - path.t_touchdown[fin]))
    return np.full(path.leg.shape[0], 0.3)


def _median(x: F64) -> float:
    """np.median of a non-empty finite 1-D array (the middle value, or the mean of the two middle ones), without
    its generic-axis overhead."""
    s = np.sort(x)
    h = s.shape[0] // 2
    return float(s[h]) if s.shape[0] % 2 else float((s[h - 1] + s[h]) / 2)


# ---- screening ------------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Screening:
    """Per-candidate constraint violations (N,) in m (timing in s): reach, collision, no_step, timing; total."""

    reach: F64
    collision: F64
    no_step: F64
    timing: F64

    @property
    def total(self) -> F64:
        return self.reach + self.collision + self.no_step + self.timing

    @property
    def feasible(self) -> np.ndarray:
        return self.total <= 0.0


def screen_paths(
    batch: PathBatch,
    reference: StepPath,
    state: WalkState,
    robot: StepRobot,
    maps: StepMaps | None = None,
    constraints: Constraints | None = None,
) -> Screening:
    """Returns the constraint violations of every candidate in the batch (0 where satisfied)."""
    c = constraints or Constraints()
    oct_ = Octagon.of(robot, c)
    n, k = batch.t_td.shape
    body = reference.body
    leg = batch.leg
    xy = batch.p_td[..., :2]
    zeros = np.zeros(n)
    if k == 0:
        return Screening(zeros, zeros.copy(), zeros.copy(), zeros.copy())
    t_lo = np.where(np.isfinite(batch.t_lo), batch.t_lo, batch.t_td + _nominal_stance(reference))
    # Reach at touchdown and at liftoff.
    reach = zeros.copy()
    for t in (batch.t_td, t_lo):
        d = _heading_to_world(-body.yaw(t), xy - body.neutral_points(t, oct_.neutral, leg))
        reach += oct_.violation(d).sum(axis=1)
    # Midline and keep-out from the other feet.
    side = np.sign(oct_.neutral[leg, 1])
    lateral = _heading_to_world(-body.yaw(batch.t_td), xy - body.position(batch.t_td))[..., 1]
    collision = np.maximum(c.midline_margin_m - side * lateral, 0.0).sum(axis=1)
    ev = sort_events(batch, state)
    others = gather_xy(ev.p_all, ev.slot_td)  # (N,K,4,2)
    dd = others - xy[:, :, None, :]
    dist = np.sqrt(np.add.reduce(dd * dd, axis=-1))  # np.linalg.norm(dd, axis=-1)
    dist = np.where(np.arange(N_LEGS)[None, None, :] == leg[None, :, None], np.inf, dist)
    collision += np.maximum(c.keep_out_m - dist, 0.0).sum(axis=(1, 2))
    # No-step map.
    no_step = zeros.copy()
    if maps is not None:
        bad = eval_map(maps.no_step, xy[..., 0], xy[..., 1]) > 0.5
        no_step = bad.sum(axis=1) * c.no_step_violation_m
    # Timing: previous liftoff and place of each touchdown's leg.
    # the same leg's previous touchdown in the path, else its stance now (lifting off at t_lo_now), else its
    # swing now (lifted off already: the state's time)
    last = [-1] * N_LEGS
    prev_j = []
    for i, lg in enumerate(leg.tolist()):
        prev_j.append(last[lg])
        last[lg] = i
    j_prev = np.array(prev_j)
    has = j_prev >= 0
    jj = np.maximum(j_prev, 0)
    down = state.contact[leg]
    first_of_swing = ~has & ~down
    prev_lo = np.where(has, batch.t_lo[:, jj], np.where(down, batch.t_lo_now[:, leg], state.t))
    prev_xy = np.where(has[:, None], xy[:, jj], state.p_world_feet[leg, :2])
    t0 = state.t
    swing = batch.t_td - prev_lo
    min_swing = np.where(first_of_swing, c.min_time_to_touchdown_s, c.min_swing_s)
    timing = np.maximum(min_swing - swing, 0.0).sum(axis=1)
    timing += np.maximum(t0 + c.min_time_to_touchdown_s - batch.t_td, 0.0).sum(axis=1)
    timing += np.maximum(c.min_stance_s - (batch.t_lo - batch.t_td), 0.0).sum(axis=1)
    lo_now = np.where(np.isfinite(batch.t_lo_now), batch.t_lo_now, np.inf)
    timing += np.maximum(t0 - lo_now, 0.0).sum(axis=1)
    speed = np.linalg.norm(xy - prev_xy, axis=-1) / np.maximum(swing, 1e-3)
    timing += (np.maximum(speed - c.max_swing_speed_mps, 0.0) * 0.01).sum(axis=1)
    tau = np.diff(ev.bounds, axis=1)
    short = (ev.stance_seg.sum(axis=2) < c.min_support_legs) & (tau > 1e-6)
    timing += np.where(short, tau, 0.0).sum(axis=1)
    return Screening(reach, collision, no_step, timing)


def potential_step_paths(
    reference: StepPath,
    state: WalkState,
    robot: StepRobot,
    maps: StepMaps | None = None,
    n: int = 25,
    params: PotentialParams | None = None,
) -> list[StepPath]:
    """Returns up to n potential step paths (reference first), infeasible ones dropped (see the module docstring).

    If no candidate is feasible, all n are returned with ``violation`` > 0 so that selection can rank them.
    A reference without touchdowns (standing) is returned alone.
    """
    if n < 2:
        raise ValueError(f"n: need at least 2 potential step paths, got {n}")
    p = params or PotentialParams()
    if reference.n_touchdowns == 0:
        return [reference]  # standing: nothing to vary
    oct_ = Octagon.of(robot, p.constraints)
    omega = state_omega(state, robot.standing_height_m)
    fam = _generate(reference, state, oct_, n, p, omega, maps)
    batch = build_batch(reference, fam, maps)
    scr = screen_paths(batch, reference, state, robot, maps, p.constraints)
    total = np.where(np.isnan(scr.total), np.inf, scr.total)
    keep = np.flatnonzero(total <= 0.0)
    if keep.size == 0:
        keep = np.arange(batch.n)
    kept = (
        batch
        if keep.size == batch.n
        else PathBatch(
            batch.leg, batch.t_td[keep], batch.t_lo[keep], batch.t_lo_now[keep], batch.p_td[keep], batch.body
        )
    )
    paths = [
        reference.sibling(
            kept.t_td[j], kept.t_lo[j], kept.p_td[j], kept.t_lo_now[j], fam.kind[i], float(total[i])
        )
        for j, i in enumerate(keep.tolist())
    ]
    return StepPaths(paths, kept)


def build_batch(reference: StepPath, fam: _Family, maps: StepMaps | None) -> PathBatch:
    """Returns the candidates of a family as a PathBatch (timing applied, heights from the maps or reference)."""
    m = len(fam.kind)
    k = reference.leg.shape[0]
    t0 = reference.body.t0
    shift = np.asarray(fam.shift)[:, None]
    scale = np.asarray(fam.scale)[:, None]

    def retime(t: F64) -> F64:
        return t0 + scale * (t[None, :] - t0) + shift

    lo_now = reference.t_liftoff_now[None, :]
    t_lo_now = np.where(np.isfinite(lo_now), t0 + scale * (lo_now - t0) + shift, lo_now)
    xy = np.stack(fam.xy) if m else np.zeros((0, k, 2))
    height = map_height(maps)
    if height is not None and k:
        z = eval_map(height, xy[..., 0], xy[..., 1])
    else:
        z = np.broadcast_to(reference.p_world_touchdown[:, 2], (m, k))
    return PathBatch(
        leg=reference.leg,
        t_td=retime(reference.t_touchdown),
        t_lo=retime(reference.t_liftoff),
        t_lo_now=np.broadcast_to(t_lo_now, (m, N_LEGS)).copy(),
        p_td=np.concatenate([xy, z[..., None]], axis=-1),
        body=reference.body,
    )
