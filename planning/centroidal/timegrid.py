"""Time steps of the centroidal problem: fine near now, coarser further out, a boundary at every event.

A grid is the array of knot times t_0 = t_now < t_1 < ... < t_N (seconds, same clock as the events). Step sizes
follow a pattern of integer multiples of a base step (default four of 1×, four of 2×, four of 3× 50 ms, the last
multiple repeating to the horizon's end); a movement event inside the horizon always falls on a knot, so a coarse
step that would straddle an event ends at the event instead (FIG. 2A of the dynamic-planning-controller seed).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence

import numpy as np

DEFAULT_PATTERN: tuple[tuple[int, int], ...] = ((4, 1), (4, 2), (4, 3))
_TOL = 1e-9


def derive_base_dt(event_times: Iterable[float], max_dt: float = 0.05, min_dt: float = 0.01) -> float:
    """Returns a base step (s) that divides the shortest gap between distinct events, at most ``max_dt``.

    The shortest gap g becomes the base step when g <= max_dt, else g / ceil(g / max_dt), so that the shortest
    gap is an integer multiple of it; never below ``min_dt``. With fewer than two distinct events: ``max_dt``.
    """
    if not (0.0 < min_dt <= max_dt):
        raise ValueError(f"derive_base_dt: need 0 < min_dt <= max_dt, got min_dt={min_dt}, max_dt={max_dt}")
    ts = np.unique(np.round(np.asarray(list(event_times), dtype=float), 9))
    if ts.size < 2:
        return max_dt
    gap = float(np.min(np.diff(ts)))
    base = gap if gap <= max_dt else gap / math.ceil(gap / max_dt - 1e-9)
    return max(min_dt, base)


def _check_pattern(pattern: Sequence[tuple[int, int]]) -> list[int]:
    mults: list[int] = []
    for i, entry in enumerate(pattern):
        if len(entry) != 2:
            raise ValueError(f"pattern[{i}]: expected (count, multiple), got {entry!r}")
        count, mult = int(entry[0]), int(entry[1])
        if count < 0 or mult < 1:
            raise ValueError(f"pattern[{i}]: count must be >= 0 and multiple >= 1, got ({count}, {mult})")
        mults.extend([mult] * count)
    if not mults:
        raise ValueError("pattern: needs at least one step")
    return mults


def make_time_grid(
    t_now: float,
    event_times: Iterable[float],
    horizon_end: float,
    base_dt: float | None = 0.05,
    pattern: Sequence[tuple[int, int]] = DEFAULT_PATTERN,
    max_knots: int = 24,
    min_step_fraction: float = 0.5,
    min_event_gap_s: float = 0.0,
) -> np.ndarray:
    """Returns knot times (n,) from t_now to at most horizon_end, with every event in between on a knot.

    t_now, horizon_end: seconds. event_times: event times in seconds (any order; those outside
    (t_now, horizon_end) are ignored). base_dt: base step in seconds, or None to derive it from the events
    (``derive_base_dt``). pattern: (count, multiple) pairs, the step sizes in order; the last multiple repeats.
    max_knots: cap on the number of knot times returned (including t_now), so at most max_knots - 1 steps; the
    far end is dropped when the cap binds. min_step_fraction: a regular step is stretched to the next event
    rather than leave a sliver shorter than this fraction of base_dt before it. min_event_gap_s: an event less
    than this (s) after the knot before it gets no knot of its own: it falls inside the next step, whose contact
    (taken at the step's midpoint) moves it onto one of the step's ends. A step of a millisecond or two
    (a touchdown just due, a liftoff in 1 ms) makes the QP badly conditioned: on the trot at 0.5 m/s such ticks
    took 1000–4000 ADMM iterations where the others take 15.
    """
    t_now = float(t_now)
    horizon_end = float(horizon_end)
    events = np.asarray(list(event_times), dtype=float)
    if not (math.isfinite(t_now) and math.isfinite(horizon_end)):
        raise ValueError(f"make_time_grid: t_now ({t_now}) and horizon_end ({horizon_end}) must be finite")
    if horizon_end <= t_now + _TOL:
        raise ValueError(f"make_time_grid: horizon_end ({horizon_end}) must be after t_now ({t_now})")
    if events.size and not np.all(np.isfinite(events)):
        raise ValueError("make_time_grid: event_times must be finite")
    if max_knots < 2:
        raise ValueError(f"make_time_grid: max_knots must be >= 2, got {max_knots}")
    if base_dt is None:
        base_dt = derive_base_dt(np.concatenate([[t_now], events[(events > t_now) & (events < horizon_end)]]))
    if not (base_dt > 0.0 and math.isfinite(base_dt)):
        raise ValueError(f"make_time_grid: base_dt must be a positive number of seconds, got {base_dt}")
    mults = _check_pattern(pattern)

    inside = np.unique(events[(events > t_now + _TOL) & (events < horizon_end - _TOL)])
    stops = list(inside) + [horizon_end]
    min_gap = min_step_fraction * base_dt
    knots = [t_now]
    t = t_now
    e_idx = 0
    step = 0
    while len(knots) < max_knots and t < horizon_end - _TOL:
        while stops[e_idx] <= t + _TOL or (e_idx < len(stops) - 1 and stops[e_idx] < t + min_event_gap_s):
            e_idx += 1
        h = mults[min(step, len(mults) - 1)] * base_dt
        nxt = stops[e_idx]
        t = nxt if nxt - t < h + min_gap - _TOL else t + h
        knots.append(t)
        step += 1
    return np.asarray(knots)
