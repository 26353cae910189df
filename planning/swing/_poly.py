"""Piecewise-cubic 1-D trajectories and the bang-coast-bang profiles every swing policy is built from.

Everything here is scalar Python on purpose: a profile has at most a handful of pieces, and plain float arithmetic
is several times faster than NumPy on arrays that small. Sampling many times at once (``Poly1D.sample_many``) is
vectorized.

Units: seconds, meters (or whatever length the caller uses), m/s, m/s².
"""

from __future__ import annotations

import bisect
import math

import numpy as np

_EPS_T = 1e-12  # s; pieces shorter than this are dropped


class Poly1D:
    """p(t) = c0 + c1·τ + c2·τ² + c3·τ³ with τ = t − t_k on piece k; the last piece runs on forever.

    Before the first break the start state is held (sampling before a plan starts only happens by rounding).
    ``peak_v`` and ``peak_a`` are the largest |velocity| and |acceleration| over all pieces but the last (which
    is a constant-velocity tail).
    """

    __slots__ = ("breaks", "coeffs", "peak_v", "peak_a", "_cols")

    def __init__(
        self,
        breaks: list[float],
        coeffs: list[tuple[float, float, float, float]],
        peak_v: float,
        peak_a: float,
    ) -> None:
        self.breaks = breaks
        self.coeffs = coeffs
        self.peak_v = peak_v
        self.peak_a = peak_a
        self._cols: np.ndarray | None = None  # (5,P) breaks and coefficients by power, for sample_many

    @property
    def t_start(self) -> float:
        return self.breaks[0]

    @property
    def t_end(self) -> float:
        """Start time of the final constant-velocity tail."""
        return self.breaks[-1]

    def state(self, t: float) -> tuple[float, float, float]:
        """Returns (p, v, a) at time t (s)."""
        k = bisect.bisect_right(self.breaks, t) - 1
        if k < 0:
            k, tau = 0, 0.0
        else:
            tau = t - self.breaks[k]
        c0, c1, c2, c3 = self.coeffs[k]
        return (
            c0 + tau * (c1 + tau * (c2 + tau * c3)),
            c1 + tau * (2.0 * c2 + 3.0 * tau * c3),
            2.0 * c2 + 6.0 * tau * c3,
        )

    def position(self, t: float) -> float:
        k = bisect.bisect_right(self.breaks, t) - 1
        if k < 0:
            k, tau = 0, 0.0
        else:
            tau = t - self.breaks[k]
        c0, c1, c2, c3 = self.coeffs[k]
        return c0 + tau * (c1 + tau * (c2 + tau * c3))

    def sample_many(self, ts: np.ndarray, order: int = 0) -> np.ndarray:
        """Returns p (order 0), v (1) or a (2) at the times ts (K,) as a (K,) array."""
        br = self.breaks
        if len(br) == 1:
            c0, c1, c2, c3 = self.coeffs[0]
            tau = np.maximum(ts - br[0], 0.0)
        else:
            cols = self._cols
            if cols is None:
                # (5,P): the breaks, then the coefficients by power, in one conversion; one gather then gives each
                # sample's piece start with its coefficients
                cols = self._cols = np.array([br, *zip(*self.coeffs, strict=True)])
            k = cols[0].searchsorted(ts, "right")
            k -= 1
            if k[0] < 0:  # before the start: hold the start state
                np.maximum(k, 0, out=k)
                t_k, c0, c1, c2, c3 = cols.take(k, axis=1)
                tau = np.maximum(ts - t_k, 0.0)
            else:
                t_k, c0, c1, c2, c3 = cols.take(k, axis=1)
                tau = ts - t_k
        if order == 0:
            return c0 + tau * (c1 + tau * (c2 + tau * c3))
        if order == 1:
            return c1 + tau * (2.0 * c2 + 3.0 * tau * c3)
        return 2.0 * c2 + 6.0 * tau * c3 + 0.0 * tau

    def crossing_time(self, level: float) -> float | None:
        """Returns the first time p(t) = level (s), or None when the trajectory never reaches it."""
        for k, (c0, c1, c2, c3) in enumerate(self.coeffs):
            last = k == len(self.coeffs) - 1
            dur = math.inf if last else self.breaks[k + 1] - self.breaks[k]
            tau = _first_root(c0 - level, c1, c2, c3, dur)
            if tau is not None:
                return self.breaks[k] + tau
        return None


def sample_pair(a: Poly1D, b: Poly1D, ts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Positions of two trajectories with the same breaks (a path's x and y) at the ascending times ts (K,): what
    a.sample_many(ts) and b.sample_many(ts) return, with one piece lookup and one evaluation for both."""
    br = a.breaks
    if len(br) == 1 or br != b.breaks:
        return a.sample_many(ts), b.sample_many(ts)
    if len(br) == 2:
        return _sample_pair_two(a, b, ts)
    tb = np.array(br)
    k = tb.searchsorted(ts, "right")
    k -= 1
    if ts[0] < br[0]:  # before the start: hold the start state
        np.maximum(k, 0, out=k)
        tau = np.maximum(ts - tb[k], 0.0)
    else:
        tau = ts - tb[k]
    c0, c1, c2, c3 = np.array([a.coeffs, b.coeffs]).take(k, axis=1).transpose(2, 0, 1)  # each (2,K)
    out = c0 + tau * (c1 + tau * (c2 + tau * c3))
    return out[0], out[1]


def _sample_pair_two(a: Poly1D, b: Poly1D, ts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """sample_pair of two-piece trajectories (one piece, then the tail: a Cubic path) at ascending ts: the first
    piece evaluated with its coefficients as scalars at every sample (no gathering), then the samples from the
    tail's start on (the last one or few) overwritten with the tail's, in floats. Per sample the same operations
    as the gathered evaluation, so the same values."""
    b0, b1 = a.breaks
    tau = ts - b0
    if ts[0] < b0:  # before the start: hold the start state
        np.maximum(tau, 0.0, out=tau)
    i = int(ts.searchsorted(b1, "left"))  # the first sample on the tail
    tail = ts[i:].tolist()
    out = []
    for p in (a, b):
        (c0, c1, c2, c3), (d0, d1, d2, d3) = p.coeffs
        v = c0 + tau * (c1 + tau * (c2 + tau * c3))
        for j, t in enumerate(tail, i):
            t -= b1
            v[j] = d0 + t * (d1 + t * (d2 + t * d3))
        out.append(v)
    return out[0], out[1]


def _first_root(c0: float, c1: float, c2: float, c3: float, dur: float) -> float | None:
    """Returns the smallest τ in [0, dur] with c0 + c1 τ + c2 τ² + c3 τ³ = 0 (c3 = 0 for every piece we search)."""
    if abs(c0) < 1e-12:
        return 0.0
    if c3 != 0.0:
        # Cubic pieces: a few bisection steps on a sign change over a fine grid are plenty here.
        n = 16
        end = dur if math.isfinite(dur) else 10.0
        prev_t, prev_v = 0.0, c0
        for i in range(1, n + 1):
            t = end * i / n
            v = c0 + t * (c1 + t * (c2 + t * c3))
            if (v > 0) != (prev_v > 0):
                lo, hi = prev_t, t
                for _ in range(40):
                    mid = 0.5 * (lo + hi)
                    vm = c0 + mid * (c1 + mid * (c2 + mid * c3))
                    if (vm > 0) == (prev_v > 0):
                        lo = mid
                    else:
                        hi = mid
                return 0.5 * (lo + hi)
            prev_t, prev_v = t, v
        return None
    roots: list[float] = []
    if abs(c2) < 1e-15:
        if abs(c1) > 1e-15:
            roots.append(-c0 / c1)
    else:
        disc = c1 * c1 - 4.0 * c2 * c0
        if disc >= 0.0:
            sq = math.sqrt(disc)
            roots += [(-c1 - sq) / (2.0 * c2), (-c1 + sq) / (2.0 * c2)]
    best = None
    for r in roots:
        if -1e-12 <= r <= dur + 1e-12 and (best is None or r < best):
            best = max(r, 0.0)
    return best


class Builder:
    """Appends constant-acceleration and cubic pieces to a 1-D trajectory starting at (t, p, v)."""

    __slots__ = ("t", "p", "v", "breaks", "coeffs", "peak_v", "peak_a")

    def __init__(self, t: float, p: float, v: float) -> None:
        self.t = t
        self.p = p
        self.v = v
        self.breaks: list[float] = []
        self.coeffs: list[tuple[float, float, float, float]] = []
        self.peak_v = abs(v)
        self.peak_a = 0.0

    def accel(self, dt: float, a: float) -> None:
        """Appends a piece of duration dt (s) at constant acceleration a."""
        if dt <= _EPS_T:
            return
        self.breaks.append(self.t)
        self.coeffs.append((self.p, self.v, 0.5 * a, 0.0))
        self.p += dt * (self.v + 0.5 * a * dt)
        self.v += a * dt
        self.t += dt
        if a != 0.0 and abs(a) > self.peak_a:
            self.peak_a = abs(a)
        if abs(self.v) > self.peak_v:
            self.peak_v = abs(self.v)

    def segments(self, segs: list[tuple[float, float]]) -> None:
        for dt, a in segs:
            self.accel(dt, a)

    def cubic(self, dt: float, p1: float, v1: float) -> None:
        """Appends the cubic (Hermite) piece that reaches (p1, v1) after dt (s)."""
        if dt <= _EPS_T:
            self.p, self.v = p1, v1
            return
        p0, v0 = self.p, self.v
        d = p1 - p0
        c2 = (3.0 * d - (2.0 * v0 + v1) * dt) / (dt * dt)
        c3 = (-2.0 * d + (v0 + v1) * dt) / (dt * dt * dt)
        self.breaks.append(self.t)
        self.coeffs.append((p0, v0, c2, c3))
        a0, a1 = abs(2.0 * c2), abs(2.0 * c2 + 6.0 * c3 * dt)
        # the builtin max written out (max(a, b) is `b if b > a else a`): the same values, fewer calls
        pa = self.peak_a
        if a0 > pa:
            pa = a0
        if a1 > pa:
            pa = a1
        self.peak_a = pa
        vmax, av1 = abs(v0), abs(v1)
        if av1 > vmax:
            vmax = av1
        if c3 != 0.0:
            tv = -c2 / (3.0 * c3)
            if 0.0 < tv < dt:
                av = abs(v0 + tv * (2.0 * c2 + 3.0 * tv * c3))
                if av > vmax:
                    vmax = av
        if vmax > self.peak_v:
            self.peak_v = vmax
        self.p, self.v, self.t = p1, v1, self.t + dt

    @classmethod
    def extend(cls, poly: Poly1D) -> Builder:
        """Returns a builder holding poly's pieces, positioned at the start of poly's tail."""
        p, v, _, _ = poly.coeffs[-1]
        b = cls(poly.t_end, p, v)
        b.breaks = poly.breaks[:-1]
        b.coeffs = poly.coeffs[:-1]
        b.peak_v = poly.peak_v
        b.peak_a = poly.peak_a
        return b

    def finish(self, p: float | None = None, v: float | None = None) -> Poly1D:
        """Closes the trajectory with a constant-velocity tail from the current (or the given exact) state."""
        if p is not None:
            self.p = p
        if v is not None:
            self.v = v
        self.breaks.append(self.t)
        self.coeffs.append((self.p, self.v, 0.0, 0.0))
        return Poly1D(self.breaks, self.coeffs, self.peak_v, self.peak_a)


# ---- bang-coast-bang primitives ------------------------------------------------------------------------------


def rest_segments(p: float, v: float, p1: float, v_max: float, a_max: float) -> list[tuple[float, float]]:
    """Returns the time-optimal (duration s, acceleration) pieces from (p, v) to rest at p1.

    Bang to the velocity limit, coast, bang to rest; overshoots and comes back when the stopping distance is
    longer than the way left. A start faster than v_max toward p1 is first slowed to v_max.
    """
    segs: list[tuple[float, float]] = []
    d = p1 - p
    s = 1.0 if d >= 0.0 else -1.0
    D, V = s * d, s * v
    if V > v_max:
        dt = (V - v_max) / a_max
        segs.append((dt, -s * a_max))
        D -= 0.5 * (V + v_max) * dt
        V = v_max
    if V > 0.0 and V * V >= 2.0 * a_max * D:
        dt = V / a_max
        segs.append((dt, -s * a_max))
        D -= 0.5 * V * dt
        V = 0.0
        s, D = -s, -D
    q = a_max * D + 0.5 * V * V
    vp = math.sqrt(0.0 if 0.0 > q else q)  # max(q, 0.0) without the builtin call
    if vp <= v_max:
        segs.append(((vp - V) / a_max, s * a_max))
        segs.append((vp / a_max, -s * a_max))
    else:
        cruise = (D - (2.0 * v_max * v_max - V * V) / (2.0 * a_max)) / v_max
        segs.append(((v_max - V) / a_max, s * a_max))
        segs.append((0.0 if 0.0 > cruise else cruise, 0.0))
        segs.append((v_max / a_max, -s * a_max))
    return segs


def rest_time(p: float, v: float, p1: float, v_max: float, a_max: float) -> float:
    """Returns the duration (s) of the time-optimal motion from (p, v) to rest at p1 (rest_segments, summed).

    Written out rather than summing rest_segments: the vertical search calls it dozens of times per plan.
    """
    d = p1 - p
    s = 1.0 if d >= 0.0 else -1.0
    D, V = s * d, s * v
    t = 0.0
    if V > v_max:
        dt = (V - v_max) / a_max
        t += dt
        D -= 0.5 * (V + v_max) * dt
        V = v_max
    if V > 0.0 and V * V >= 2.0 * a_max * D:
        t += V / a_max
        D = 0.5 * V * V / a_max - D
        V = 0.0
    q = a_max * D + 0.5 * V * V
    vp = math.sqrt(0.0 if 0.0 > q else q)  # max(q, 0.0) without the builtin call
    if vp <= v_max:
        return t + (2.0 * vp - V) / a_max
    cruise = (D - (2.0 * v_max * v_max - V * V) / (2.0 * a_max)) / v_max
    return t + (2.0 * v_max - V) / a_max + (0.0 if 0.0 > cruise else cruise)


def rest_time_still(p: float, p1: float, v_max: float, a_max: float) -> float:
    """rest_time(p, 0.0, p1, v_max, a_max): from rest, its branches for v = 0 folded (the same value, bit for bit:
    the fall from a swing's top, which the vertical search evaluates for every top it tries)."""
    d = p1 - p
    D = d if d >= 0.0 else -d  # s·d
    q = a_max * D + 0.0  # + 0.5·V·V, which is +0.0 for V = ±0.0
    vp = math.sqrt(0.0 if 0.0 > q else q)
    if vp <= v_max:
        return 2.0 * vp / a_max  # 0.0 + (2.0·vp − V) / a_max
    cruise = (D - 2.0 * v_max * v_max / (2.0 * a_max)) / v_max
    return 2.0 * v_max / a_max + (0.0 if 0.0 > cruise else cruise)


def to_rest(b: Builder, p1: float, v_max: float, a_max: float) -> float:
    """Appends the time-optimal motion to rest at p1; returns the arrival time (s)."""
    n = len(b.breaks)
    b.segments(rest_segments(b.p, b.v, p1, v_max, a_max))
    if len(b.breaks) > n:
        b.p, b.v = p1, 0.0  # remove rounding so the tail sits exactly on the target
    return b.t


def coast_time(p: float, v: float, p1: float, horizon: float, v_max: float, a_max: float) -> float:
    """Returns the longest coast w (s) at velocity v after which a time-optimal motion still rests at p1 by horizon.

    The coast never runs so far that the motion would overshoot p1. Returns −1 when even w = 0 arrives too late.
    """
    t_opt = rest_time(p, v, p1, v_max, a_max)
    if t_opt > horizon + 1e-7:
        return -1.0
    if t_opt >= horizon - 1e-9:
        return 0.0  # no time to spare (a replan from the plan's own state lands here, give or take rounding)
    if abs(v) < 1e-12:
        return horizon - rest_time_still(p, p1, v_max, a_max)
    # Closed forms for the usual case (moving toward the target, no overshoot), verified before use.
    d = p1 - p
    s = 1.0 if d >= 0.0 else -1.0
    D, V = s * d, s * v
    if 0.0 < V <= v_max:
        cands = []
        disc = 0.5 * V * V + a_max * (D - V * horizon)
        if disc >= 0.0:
            u = V + math.sqrt(disc)
            cands.append(horizon - (2.0 * u - V) / a_max)
        if V < v_max:
            rhs = (
                horizon
                - (2.0 * v_max - V) / a_max
                - D / v_max
                + (2.0 * v_max**2 - V * V) / (2.0 * a_max * v_max)
            )
            cands.append(rhs / (1.0 - V / v_max))
        for w in cands:
            if 0.0 <= w <= horizon:
                t = rest_time(p + v * w, v, p1, v_max, a_max)
                if abs(w + t - horizon) < 1e-9:
                    return w
    # Bisection: w + rest_time(after coasting w) grows with w. Coasting toward the target stops where braking
    # would just make it (beyond that the motion overshoots and comes back); then the motion arrives early.
    lo, hi = 0.0, horizon
    if V > 0.0:
        hi = min(hi, max((D - V * V / (2.0 * a_max)) / V, 0.0))
        if hi + rest_time(p + v * hi, v, p1, v_max, a_max) <= horizon:
            return hi
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        if mid + rest_time(p + v * mid, v, p1, v_max, a_max) <= horizon:
            lo = mid
        else:
            hi = mid
        if hi - lo < 1e-10:
            break
    return lo


def rise_hold_fall(
    b: Builder, z_top: float, z_end: float, t_end: float, v_up: float, v_down: float, a_max: float
) -> bool:
    """Appends rise to z_top, hold, fall to rest at z_end by t_end; returns whether it arrives on time.

    When time is short the top is lowered (down to where braking now would stop the foot); shorter still, the
    foot coasts at its current velocity and then bangs to rest on z_end exactly at t_end (a foot already on its
    way down just keeps descending — which makes replanning from the plan's own state reproduce the plan).
    When even the time-optimal motion arrives late, that motion is appended and False returned.
    """
    z0, v0 = b.p, b.v
    horizon = t_end - b.t
    z_lo = max(z0 + v0 * abs(v0) / (2.0 * a_max), z_end)
    z_top = max(z_top, z_lo)
    # the time to rise to a top h and fall from it is rest_time(z0, v0, h, ...) + rest_time_still(h, z_end, ...),
    # written out where it is needed (a nested function's calls cost a tenth of the search)
    t_fall = rest_time_still(z_top, z_end, v_down, a_max)  # the fall from the top (reused when the top stays)
    t_hi = rest_time(z0, v0, z_top, v_up, a_max) + t_fall
    if t_hi > horizon:
        t_lo = rest_time(z0, v0, z_lo, v_up, a_max) + rest_time_still(z_lo, z_end, v_down, a_max)
        if t_lo > horizon + 1e-9:
            v_lim = v_down if z_end < z0 else v_up
            w = coast_time(z0, v0, z_end, horizon, v_lim, a_max)
            if w > 0.0:
                b.accel(w, 0.0)
            to_rest(b, z_end, v_lim, a_max)
            return w >= 0.0
        # Illinois regula falsi on (the rise and fall's time to a top h) = horizon; that time grows with h.
        lo, hi, f_lo, f_hi = z_lo, z_top, t_lo - horizon, t_hi - horizon
        side = 0
        h = lo
        for _ in range(30):
            h = (lo * f_hi - hi * f_lo) / (f_hi - f_lo) if f_hi != f_lo else 0.5 * (lo + hi)
            f = rest_time(z0, v0, h, v_up, a_max) + rest_time_still(h, z_end, v_down, a_max) - horizon
            if abs(f) < 1e-6:  # s; the top found is then within a fraction of a millimeter of the highest
                break
            if f > 0.0:
                hi, f_hi = h, f
                if side == 1:
                    f_lo *= 0.5
                side = 1
            else:
                lo, f_lo = h, f
                if side == -1:
                    f_hi *= 0.5
                side = -1
        # f = (rise and fall time to h) − horizon of the last h tried, and a − b > 0 exactly when a > b
        z_top = lo if f > 0.0 else h
        t_fall = rest_time_still(z_top, z_end, v_down, a_max)
    n = len(b.breaks)
    b.segments(rest_segments(z0, v0, z_top, v_up, a_max))
    if len(b.breaks) > n:
        b.p, b.v = z_top, 0.0
    b.accel(t_end - t_fall - b.t, 0.0)
    to_rest(b, z_end, v_down, a_max)
    return True


def rise_hold_fall_outlook(
    z0: float, v0: float, z_top: float, z_end: float, horizon: float, v_up: float, v_down: float, a_max: float
) -> tuple[float, bool]:
    """What rise_hold_fall would append from (z0, v0) over horizon (s), without building it: an upper bound (m) on
    its height (inf where there is no cheap one) and whether it arrives on time (exactly rise_hold_fall's answer).
    A few float operations, its own branch tests repeated.

    Without the coast branch the foot rests on a top no higher than max(z_top, z_lo) (the time-optimal motion to
    rest there never overshoots it: the top is at least where braking now would stop the foot), after starting at
    z0; so the peak is the higher of the two, and it arrives on time. The coast branch arrives on time when
    coast_time finds a coast (w ≥ 0): when the time-optimal motion to rest on z_end fits the horizon.
    """
    z_lo = max(z0 + v0 * abs(v0) / (2.0 * a_max), z_end)
    top = max(z_top, z_lo)
    if (
        rest_time(z0, v0, top, v_up, a_max) + rest_time_still(top, z_end, v_down, a_max) > horizon
        and rest_time(z0, v0, z_lo, v_up, a_max) + rest_time_still(z_lo, z_end, v_down, a_max)
        > horizon + 1e-9
    ):
        v_lim = v_down if z_end < z0 else v_up
        return math.inf, rest_time(z0, v0, z_end, v_lim, a_max) <= horizon + 1e-7
    return max(z0, top), True
