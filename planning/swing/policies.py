"""Horizontal and vertical swing policies: each maps (position, velocity, touchdown, time, limits) to a trajectory.

Horizontal policies work in the heading frame (world turned by the body's yaw at planning time) and return one
piecewise polynomial per axis; vertical policies return one for z. Every policy is analytic, so sampling is cheap
and derivatives are exact.

Horizontal set (seed FIGS. 4, 11–15): Cubic, BangBangWait, WaitBangBang, combinations by axis and by time, Swing
Around (four sides of the first keep-out area on the way) and Wiggle (around several). Trip responses (FIG. 16)
are special horizontal policies outside the normal set.
"""

from __future__ import annotations

import functools
import heapq
import math
from collections.abc import Callable
from dataclasses import dataclass

from planning.swing._poly import Builder, Poly1D, coast_time, rise_hold_fall, rise_hold_fall_outlook, to_rest
from planning.swing.params import SwingParams, VerticalLevel

AABB = tuple[float, float, float, float]  # x_min, x_max, y_min, y_max in the heading frame, m


@dataclass(slots=True)
class LegCtx:
    """One leg's planning problem in the heading frame (positions m, velocities m/s, times s)."""

    t0: float
    t_end: float
    p0: tuple[float, float]
    v0: tuple[float, float]
    p1: tuple[float, float]
    v_max: float
    a_max: float
    keepouts: list[AABB]  # other legs' keep-out areas (already inflated by the keep-out radius)
    margin: float  # swing-around waypoints sit this far beyond a keep-out area's corners
    time_split_frac: float
    blocked: list[int]  # keep-outs the straight route crosses, nearest first


@dataclass(slots=True)
class HPath:
    """A horizontal candidate in the heading frame."""

    name: str
    x: Poly1D
    y: Poly1D
    peak_v: float  # largest |velocity| over both axes, m/s
    peak_a: float  # largest |acceleration| over both axes, m/s²
    t_arrive: float  # when both axes rest on the target, s (inf when they never do)


def _path(name: str, x: Poly1D, y: Poly1D, tx: float, ty: float) -> HPath:
    # max(a, b) written out as `b if b > a else a` (its exact value): called for every candidate
    pv, pa = x.peak_v, x.peak_a
    return HPath(
        name,
        x,
        y,
        y.peak_v if y.peak_v > pv else pv,
        y.peak_a if y.peak_a > pa else pa,
        ty if ty > tx else tx,
    )


# ---- per-axis policies ---------------------------------------------------------------------------------------


def cubic_axis(t0: float, p: float, v: float, p1: float, t_end: float) -> tuple[Poly1D, float]:
    """Returns the cubic from (p, v) to rest at p1 at t_end, and its arrival time."""
    b = Builder(t0, p, v)
    dt = t_end - t0
    b.cubic(0.0 if 0.0 > dt else dt, p1, 0.0)  # max(dt, 0.0), max(t_end, t0) without the builtin calls
    return b.finish(p1, 0.0), t0 if t0 > t_end else t_end


def bbw_axis(t0: float, p: float, v: float, p1: float, v_max: float, a_max: float) -> tuple[Poly1D, float]:
    """Returns BangBangWait: time-optimal to rest at p1, then wait; and its arrival time."""
    b = Builder(t0, p, v)
    t = to_rest(b, p1, v_max, a_max)
    return b.finish(), t


def wbb_axis(
    t0: float, p: float, v: float, p1: float, t_end: float, v_max: float, a_max: float
) -> tuple[Poly1D, float]:
    """Returns WaitBangBang: coast at the current velocity as long as possible, then bang to rest at p1 by t_end."""
    w = coast_time(p, v, p1, t_end - t0, v_max, a_max)
    b = Builder(t0, p, v)
    if w > 0.0:
        b.accel(w, 0.0)
    t = to_rest(b, p1, v_max, a_max)
    return b.finish(), t


def _then(first: Poly1D, t_switch: float, rest: Callable[[Builder], float]) -> tuple[Poly1D, float]:
    """Combination by time: ``first`` until t_switch, then whatever ``rest`` appends from that state."""
    b = Builder.extend(_truncate(first, t_switch))
    t = rest(b)
    return b.finish(), t


def _truncate(poly: Poly1D, t_switch: float) -> Poly1D:
    """Returns poly up to t_switch, closed there by a constant-velocity tail."""
    breaks, coeffs = [], []
    for tb, c in zip(poly.breaks, poly.coeffs, strict=True):
        if tb >= t_switch:
            break
        breaks.append(tb)
        coeffs.append(c)
    if not breaks:
        breaks, coeffs = [poly.breaks[0]], [poly.coeffs[0]]
    p, v, _ = poly.state(t_switch)
    breaks.append(t_switch)
    coeffs.append((p, v, 0.0, 0.0))
    return Poly1D(breaks, coeffs, poly.peak_v, poly.peak_a)


# ---- horizontal policies -------------------------------------------------------------------------------------


def cubic(c: LegCtx) -> HPath | None:
    x, tx = cubic_axis(c.t0, c.p0[0], c.v0[0], c.p1[0], c.t_end)
    y, ty = cubic_axis(c.t0, c.p0[1], c.v0[1], c.p1[1], c.t_end)
    return _path("Cubic", x, y, tx, ty)


def bang_bang_wait(c: LegCtx) -> HPath | None:
    x, tx = bbw_axis(c.t0, c.p0[0], c.v0[0], c.p1[0], c.v_max, c.a_max)
    y, ty = bbw_axis(c.t0, c.p0[1], c.v0[1], c.p1[1], c.v_max, c.a_max)
    return _path("BangBangWait", x, y, tx, ty)


def wait_bang_bang(c: LegCtx) -> HPath | None:
    x, tx = wbb_axis(c.t0, c.p0[0], c.v0[0], c.p1[0], c.t_end, c.v_max, c.a_max)
    y, ty = wbb_axis(c.t0, c.p0[1], c.v0[1], c.p1[1], c.t_end, c.v_max, c.a_max)
    return _path("WaitBangBang", x, y, tx, ty)


def bbw_x_cubic_y(c: LegCtx) -> HPath | None:
    """Combination by axis: BangBangWait in x, Cubic in y."""
    x, tx = bbw_axis(c.t0, c.p0[0], c.v0[0], c.p1[0], c.v_max, c.a_max)
    y, ty = cubic_axis(c.t0, c.p0[1], c.v0[1], c.p1[1], c.t_end)
    return _path("BBW-x+Cubic-y", x, y, tx, ty)


def cubic_x_bbw_y(c: LegCtx) -> HPath | None:
    """Combination by axis: Cubic in x, BangBangWait in y."""
    x, tx = cubic_axis(c.t0, c.p0[0], c.v0[0], c.p1[0], c.t_end)
    y, ty = bbw_axis(c.t0, c.p0[1], c.v0[1], c.p1[1], c.v_max, c.a_max)
    return _path("Cubic-x+BBW-y", x, y, tx, ty)


def bbw_then_cubic(c: LegCtx) -> HPath | None:
    """Combination by time: BangBangWait for the first part of the swing, then Cubic to the touchdown."""
    t_s = c.t0 + c.time_split_frac * (c.t_end - c.t0)
    axes = []
    for i in (0, 1):
        first, _ = bbw_axis(c.t0, c.p0[i], c.v0[i], c.p1[i], c.v_max, c.a_max)
        p1 = c.p1[i]

        def rest(b: Builder, p1: float = p1) -> float:
            b.cubic(c.t_end - b.t, p1, 0.0)
            return c.t_end

        axes.append(_then(first, t_s, rest))
    (x, tx), (y, ty) = axes
    return _path("BBW→Cubic", x, y, tx, ty)


def _segment_hits_box(
    a: tuple[float, float], b: tuple[float, float], box: AABB, shrink: float = 1e-6
) -> bool:
    """True when the segment a→b passes through the open box (Liang–Barsky slab test, the two axes written out;
    max and min as the builtins pick them: the first of equal values)."""
    t_lo, t_hi = 0.0, 1.0
    for p, d, lo, hi in ((a[0], b[0] - a[0], box[0] + shrink, box[1] - shrink),
                         (a[1], b[1] - a[1], box[2] + shrink, box[3] - shrink)):  # fmt: skip
        if abs(d) < 1e-15:
            if p <= lo or p >= hi:
                return False
            continue
        ta, tb = (lo - p) / d, (hi - p) / d
        if ta > tb:
            ta, tb = tb, ta
        if ta > t_lo:  # max(t_lo, ta)
            t_lo = ta
        if tb < t_hi:  # min(t_hi, tb)
            t_hi = tb
        if t_lo >= t_hi:
            return False
    return True


def blocked_keepouts(p0: tuple[float, float], p1: tuple[float, float], keepouts: list[AABB]) -> list[int]:
    """Returns the indices of keep-outs the straight route p0→p1 crosses, nearest to p0 first."""
    hits = []
    for i, box in enumerate(keepouts):
        if _segment_hits_box(p0, p1, box):
            cx, cy = 0.5 * (box[0] + box[1]), 0.5 * (box[2] + box[3])
            hits.append(((cx - p0[0]) ** 2 + (cy - p0[1]) ** 2, i))
    hits.sort()
    return [i for _, i in hits]


def swing_around(c: LegCtx, clear_axis: int, side: float) -> HPath | None:
    """Swing Around the first blocking keep-out (seed FIGS. 11–13): clear it along one axis, then pass along the
    other, then come back; the passing axis coasts so that it just clips the corner when the clearing axis is out.

    clear_axis: 0 (x) or 1 (y) — the axis moved first; side: +1 passes on the box's high side, −1 on its low side.
    """
    if not c.blocked:
        return None
    box = c.keepouts[c.blocked[0]]
    q_axis = 1 - clear_axis
    lo_c, hi_c = box[2 * clear_axis], box[2 * clear_axis + 1]
    lo_q, hi_q = box[2 * q_axis], box[2 * q_axis + 1]
    w_c = hi_c + c.margin if side > 0 else lo_c - c.margin
    pc0, vc0, pc1 = c.p0[clear_axis], c.v0[clear_axis], c.p1[clear_axis]
    pq0, vq0, pq1 = c.p0[q_axis], c.v0[q_axis], c.p1[q_axis]
    s_q = 1.0 if pq1 >= pq0 else -1.0
    near, far = (lo_q, hi_q) if s_q > 0 else (hi_q, lo_q)
    near -= s_q * c.margin
    far += s_q * c.margin
    vm, am = c.v_max, c.a_max

    # Clearing axis, phase A: out to the waypoint line (or straight to a target that lies beyond it).
    target_beyond = side * (pc1 - w_c) >= 0.0
    bc = Builder(c.t0, pc0, vc0)
    if target_beyond:
        t_arr_c = to_rest(bc, pc1, vm, am)
        c_poly_a = bc.finish()
        t_c = c_poly_a.crossing_time(w_c) if side * (pc0 - w_c) < 0.0 else c.t0
        if t_c is None:
            t_c = t_arr_c
    else:
        stop = pc0 + vc0 * abs(vc0) / (2.0 * am)
        t_a_end = to_rest(bc, stop if side * (stop - w_c) >= 0.0 else w_c, vm, am)
        c_poly_a = bc.finish()
        t_c = c_poly_a.crossing_time(w_c) if side * (pc0 - w_c) < 0.0 else c.t0
        if t_c is None:
            t_c = t_a_end

    # Passing axis: approach the near edge so that coasting clips it exactly when the clearing axis is out.
    bq = Builder(c.t0, pq0, vq0)
    dt_c = t_c - c.t0
    gap = s_q * (near - pq0)
    if dt_c > 1e-9 and gap > 0.0:
        V = s_q * vq0
        D = gap - V * dt_c
        a = am if D >= 0.0 else -am
        need = abs(D) / am
        t_a = dt_c if need >= 0.5 * dt_c * dt_c else dt_c - math.sqrt(dt_c * dt_c - 2.0 * need)
        if a > 0.0:
            t_a = min(t_a, max((vm - V) / am, 0.0))
        bq.accel(t_a, s_q * a)
        bq.accel(dt_c - t_a, 0.0)
    t_arr_q = to_rest(bq, pq1, vm, am)
    q_poly = bq.finish()

    # Clearing axis, phase B: back to the target once the passing axis is beyond the far edge.
    if target_beyond:
        c_poly, t_arr_c = c_poly_a, c_poly_a.t_end
    else:
        t_far = q_poly.crossing_time(far) if s_q * (pq1 - far) >= 0.0 else None
        t_back = max(t_far if t_far is not None else t_arr_q, c_poly_a.t_end)
        b2 = Builder.extend(c_poly_a)
        b2.accel(t_back - b2.t, 0.0)
        t_arr_c = to_rest(b2, pc1, vm, am)
        c_poly = b2.finish()
    name = f"SwingAround{'+' if side > 0 else '-'}{'xy'[clear_axis]}"
    if clear_axis == 0:
        return _path(name, c_poly, q_poly, t_arr_c, t_arr_q)
    return _path(name, q_poly, c_poly, t_arr_q, t_arr_c)


def _corner_waypoints(c: LegCtx) -> list[tuple[float, float]]:
    pts = []
    m = c.margin
    for x0, x1, y0, y1 in c.keepouts:
        pts += [(x0 - m, y0 - m), (x1 + m, y0 - m), (x1 + m, y1 + m), (x0 - m, y1 + m)]
    return pts


def _visible(a: tuple[float, float], b: tuple[float, float], keepouts: list[AABB]) -> bool:
    return not any(_segment_hits_box(a, b, box) for box in keepouts)


def wiggle(c: LegCtx) -> HPath | None:
    """Wiggle around several keep-outs (seed FIG. 15): the shortest route through waypoints at a margin from their
    corners, flown as a C¹ chain of cubics with times in proportion to the route's lengths."""
    if not c.blocked:
        return None
    nodes = [c.p0, c.p1, *_corner_waypoints(c)]
    n = len(nodes)
    dist = [math.inf] * n
    prev = [-1] * n
    dist[0] = 0.0
    heap = [(0.0, 0)]
    while heap:
        d, i = heapq.heappop(heap)
        if d > dist[i]:
            continue
        if i == 1:
            break
        for j in range(1, n):
            if j == i:
                continue
            a, b = nodes[i], nodes[j]
            nd = d + math.hypot(b[0] - a[0], b[1] - a[1])
            if nd < dist[j] and _visible(a, b, c.keepouts):
                dist[j] = nd
                prev[j] = i
                heapq.heappush(heap, (nd, j))
    if prev[1] < 0:
        return None
    route = [1]
    while route[-1] != 0:
        route.append(prev[route[-1]])
    pts = [nodes[i] for i in reversed(route)]
    seg = [math.hypot(pts[k + 1][0] - pts[k][0], pts[k + 1][1] - pts[k][1]) for k in range(len(pts) - 1)]
    total_len = sum(seg)
    T = c.t_end - c.t0
    if total_len < 1e-9 or T <= 1e-6:
        return None
    times = [c.t0]
    for s in seg:
        times.append(times[-1] + T * s / total_len)
    # Waypoint velocities: finite differences of the neighbors (Catmull–Rom); rest at the touchdown.
    vel = [c.v0]
    for k in range(1, len(pts) - 1):
        dt = times[k + 1] - times[k - 1]
        vel.append(((pts[k + 1][0] - pts[k - 1][0]) / dt, (pts[k + 1][1] - pts[k - 1][1]) / dt))
    vel.append((0.0, 0.0))
    axes = []
    for i in (0, 1):
        bld = Builder(c.t0, pts[0][i], c.v0[i])
        for k in range(1, len(pts)):
            bld.cubic(times[k] - times[k - 1], pts[k][i], vel[k][i])
        axes.append(bld.finish(pts[-1][i], 0.0))
    return _path("Wiggle", axes[0], axes[1], c.t_end, c.t_end)


def _swing_around_py(c: LegCtx) -> HPath | None:
    return swing_around(c, 1, +1.0)


def _swing_around_my(c: LegCtx) -> HPath | None:
    return swing_around(c, 1, -1.0)


def _swing_around_px(c: LegCtx) -> HPath | None:
    return swing_around(c, 0, +1.0)


def _swing_around_mx(c: LegCtx) -> HPath | None:
    return swing_around(c, 0, -1.0)


HorizontalPolicy = Callable[[LegCtx], HPath | None]

#: The normal horizontal set, in the order tried when nothing is in the way (likeliest winners first).
HORIZONTAL_POLICIES: tuple[tuple[str, HorizontalPolicy], ...] = (
    ("Cubic", cubic),
    ("BangBangWait", bang_bang_wait),
    ("WaitBangBang", wait_bang_bang),
    ("BBW→Cubic", bbw_then_cubic),
    ("BBW-x+Cubic-y", bbw_x_cubic_y),
    ("Cubic-x+BBW-y", cubic_x_bbw_y),
    ("SwingAround+y", _swing_around_py),
    ("SwingAround-y", _swing_around_my),
    ("SwingAround+x", _swing_around_px),
    ("SwingAround-x", _swing_around_mx),
    ("Wiggle", wiggle),
)
HORIZONTAL_NAMES: tuple[str, ...] = tuple(n for n, _ in HORIZONTAL_POLICIES)
DEFAULT_POLICY = "BangBangWait"
_DETOURS = frozenset(n for n in HORIZONTAL_NAMES if n.startswith(("SwingAround", "Wiggle")))


@functools.cache
def policy_order(blocked: bool, previous: str | None) -> tuple[int, ...]:
    """Returns indices into HORIZONTAL_POLICIES in the order to try: last tick's choice first, detours first
    when the straight route is blocked, and detours not at all when it is not."""
    names = list(HORIZONTAL_NAMES)
    if blocked:
        order = [n for n in names if n in _DETOURS] + [n for n in names if n not in _DETOURS]
    else:
        order = [n for n in names if n not in _DETOURS]
    if previous in order:
        order.remove(previous)
        order.insert(0, previous)
    return tuple(HORIZONTAL_NAMES.index(n) for n in order)


# ---- rise first (a riser or a box between lift-off and touchdown) ---------------------------------------------


RISE_FIRST = "+RiseFirst"  # suffix of a horizontal policy's name when it follows a rise-first hold


@dataclass(frozen=True, slots=True)
class Hold:
    """The start of a rise-first swing: both axes brake to rest and wait until t_go (the foot clears the
    terrain ahead), then a horizontal policy starts from ``ctx`` (the leg's problem moved to t_go, at rest)."""

    x: Poly1D
    y: Poly1D
    ctx: LegCtx


def rise_first_hold(c: LegCtx, t_clear: float, p_wait: tuple[float, float] | None = None) -> Hold | None:
    """Returns the hold that brings the foot's x and y to rest (at p_wait, the heading-frame point short of the
    terrain to rise over, when given; where it brakes otherwise) and keeps them there until t_clear (s); None when
    there is nothing to wait for or no time left after it."""
    polys: list[Poly1D] = []
    stops: list[float] = []
    arrive = c.t0
    builders = []
    for i, (p, v) in enumerate(zip(c.p0, c.v0, strict=True)):
        b = Builder(c.t0, p, v)
        if p_wait is None:
            b.accel(abs(v) / c.a_max, -math.copysign(c.a_max, v) if v != 0.0 else 0.0)
        else:
            to_rest(b, p_wait[i], c.v_max, c.a_max)
        arrive = max(arrive, b.t)
        builders.append(b)
    t_go = max(t_clear, arrive)
    if (p_wait is None and t_clear <= arrive + 1e-4) or t_go >= c.t_end:
        return None
    for b in builders:
        b.accel(t_go - b.t, 0.0)
        stops.append(b.p)
        polys.append(b.finish(v=0.0))
    held = LegCtx(
        t0=t_go,
        t_end=c.t_end,
        p0=(stops[0], stops[1]),
        v0=(0.0, 0.0),
        p1=c.p1,
        v_max=c.v_max,
        a_max=c.a_max,
        keepouts=c.keepouts,
        margin=c.margin,
        time_split_frac=c.time_split_frac,
        blocked=blocked_keepouts((stops[0], stops[1]), c.p1, c.keepouts),
    )
    return Hold(polys[0], polys[1], held)


def _join(head: Poly1D, tail: Poly1D) -> Poly1D:
    """head's pieces up to tail's start, then tail's pieces (tail starts where and when head ends)."""
    breaks = [b for b in head.breaks if b < tail.t_start - 1e-12]
    coeffs = head.coeffs[: len(breaks)]
    return Poly1D(
        [*breaks, *tail.breaks],
        [*coeffs, *tail.coeffs],
        max(head.peak_v, tail.peak_v),
        max(head.peak_a, tail.peak_a),
    )


def after_hold(hold: Hold, hp: HPath) -> HPath:
    """Returns hp (planned from hold.ctx) preceded by the hold."""
    return HPath(
        hp.name + RISE_FIRST,
        _join(hold.x, hp.x),
        _join(hold.y, hp.y),
        max(hold.x.peak_v, hold.y.peak_v, hp.peak_v),
        max(hold.x.peak_a, hold.y.peak_a, hp.peak_a),
        hp.t_arrive,
    )


# ---- trip responses (seed FIG. 16) ---------------------------------------------------------------------------


def stop_forward(c: LegCtx) -> HPath:
    """Normal trip: stop the motion along the main direction of travel; the other axis goes on to the target."""
    long_axis = 0 if abs(c.p1[0] - c.p0[0]) >= abs(c.p1[1] - c.p0[1]) else 1
    polys: list[tuple[Poly1D, float]] = []
    for i in (0, 1):
        p, v = c.p0[i], c.v0[i]
        if i == long_axis:
            stop = p + v * abs(v) / (2.0 * c.a_max)
            polys.append(bbw_axis(c.t0, p, v, stop, c.v_max, c.a_max))
        else:
            polys.append(bbw_axis(c.t0, p, v, c.p1[i], c.v_max, c.a_max))
    (x, tx), (y, ty) = polys
    return _path("Trip:StopForward", x, y, math.inf, ty if long_axis == 0 else tx)


def knee_trip(c: LegCtx, speed_frac: float) -> HPath:
    """Knee trip: move on to the target slowly, which brings the knee forward gently."""
    vm, am = c.v_max * speed_frac, c.a_max * speed_frac
    x, tx = bbw_axis(c.t0, c.p0[0], c.v0[0], c.p1[0], vm, am)
    y, ty = bbw_axis(c.t0, c.p0[1], c.v0[1], c.p1[1], vm, am)
    return _path("Trip:Knee", x, y, tx, ty)


def disentangle(c: LegCtx, y_clear: float) -> HPath:
    """Crossed self-collision: stop in x, move laterally back to the leg's own side (y_clear), then to the target."""
    bx = Builder(c.t0, c.p0[0], c.v0[0])
    by = Builder(c.t0, c.p0[1], c.v0[1])
    t_c = to_rest(by, y_clear, c.v_max, c.a_max)
    stop = c.p0[0] + c.v0[0] * abs(c.v0[0]) / (2.0 * c.a_max)
    t_x = to_rest(bx, stop, c.v_max, c.a_max)
    bx.accel(max(t_c - t_x, 0.0), 0.0)
    tx = to_rest(bx, c.p1[0], c.v_max, c.a_max)
    ty = to_rest(by, c.p1[1], c.v_max, c.a_max)
    return _path("Trip:Disentangle", bx.finish(), by.finish(), tx, ty)


def side_step(c: LegCtx, y_away: float) -> HPath:
    """Uncrossed self-collision: move laterally away from the other leg (to y_away), then on to the target; x
    carries on to the target meanwhile."""
    x, tx = bbw_axis(c.t0, c.p0[0], c.v0[0], c.p1[0], c.v_max, c.a_max)
    by = Builder(c.t0, c.p0[1], c.v0[1])
    to_rest(by, y_away, c.v_max, c.a_max)
    ty = to_rest(by, c.p1[1], c.v_max, c.a_max)
    return _path("Trip:SideStep", x, by.finish(), tx, ty)


# ---- vertical policies ---------------------------------------------------------------------------------------


@dataclass(frozen=True, slots=True)
class VerticalSpec:
    """A vertical policy: its name, limits and top height (absolute z, m)."""

    name: str
    v_up: float
    v_down: float
    a_max: float
    height_m: float  # above max(lift-off, touchdown) height


def vertical_family(params: SwingParams) -> tuple[VerticalSpec, ...]:
    """Returns the vertical policies, gentlest first; the last is the most aggressive one."""
    levels = [*params.vertical_family, VerticalLevel(params.max_swing_height_m, 1.0, 1.0)]
    specs = []
    for i, lv in enumerate(levels):
        name = "Aggressive" if i == len(levels) - 1 else f"Gentle{i}"
        specs.append(
            VerticalSpec(
                name,
                params.v_max_up_mps * lv.velocity_frac,
                params.v_max_down_mps * lv.velocity_frac,
                params.a_max_z_mps2 * lv.accel_frac,
                min(lv.height_m, params.max_swing_height_m),
            )
        )
    return tuple(specs)


def vertical(
    spec: VerticalSpec,
    t0: float,
    z0: float,
    vz0: float,
    z1: float,
    t_end: float,
    z_ceiling: float,
    z_ref: float,
) -> tuple[Poly1D, bool]:
    """Returns the rise–hold–fall trajectory of spec and whether it rests on z1 at t_end.

    The top is max(z_ref, z1) + spec.height_m, z_ref being the lift-off height (so that replanning mid-swing
    keeps the same top), capped at z_ceiling (kinematic reach) and lowered when time is short.
    """
    b = Builder(t0, z0, vz0)
    top = min(max(z_ref, z1) + spec.height_m, max(z_ceiling, z1))
    ok = rise_hold_fall(b, top, z1, t_end, spec.v_up, spec.v_down, spec.a_max)
    return b.finish(), ok


def vertical_outlook(
    spec: VerticalSpec,
    t0: float,
    z0: float,
    vz0: float,
    z1: float,
    t_end: float,
    z_ceiling: float,
    z_ref: float,
) -> tuple[float, bool]:
    """vertical(spec, ...) without building the trajectory: an upper bound (m) on its height from t0 on (inf when
    there is no cheap one) and whether it arrives on time (vertical's own answer). A policy that arrives late or
    cannot clear the terrain is rejected for a few float operations."""
    top = min(max(z_ref, z1) + spec.height_m, max(z_ceiling, z1))
    return rise_hold_fall_outlook(z0, vz0, top, z1, t_end - t0, spec.v_up, spec.v_down, spec.a_max)


def late_touchdown(t0: float, z0: float, vz0: float, descent_mps: float, a_max: float) -> Poly1D:
    """Late touchdown: accelerate or decelerate to descend at descent_mps, and keep descending until contact."""
    b = Builder(t0, z0, vz0)
    b.accel(abs(vz0 + descent_mps) / a_max, -a_max if vz0 > -descent_mps else a_max)
    return b.finish(v=-descent_mps)


def elevate(t0: float, z0: float, vz0: float, z_top: float, v_up: float, a_max: float) -> Poly1D:
    """Trip response: rise as fast as allowed to z_top and hold there."""
    b = Builder(t0, z0, vz0)
    to_rest(b, max(z_top, z0 + (vz0 * vz0 / (2.0 * a_max) if vz0 > 0.0 else 0.0)), v_up, a_max)
    return b.finish()
