"""The 1-D primitives: time-optimal rest, longest coast, rise–hold–fall."""

import numpy as np
from hypothesis import example, given, settings
from hypothesis import strategies as st

from planning.swing._poly import (
    Builder,
    coast_time,
    rest_time,
    rest_time_still,
    rise_hold_fall,
    rise_hold_fall_outlook,
    to_rest,
)

V, A = 3.0, 40.0
pos = st.floats(-0.5, 0.5)
vel = st.floats(-V, V)


def _dense(poly, t0, t1, n=400):
    ts = np.linspace(t0, t1, n)
    return ts, poly.sample_many(ts), poly.sample_many(ts, 1), poly.sample_many(ts, 2)


@settings(max_examples=200, deadline=None)
@given(pos, vel, pos)
def test_to_rest_arrives_at_rest_within_limits(p, v, p1):
    b = Builder(0.0, p, v)
    t = to_rest(b, p1, V, A)
    poly = b.finish()
    assert abs(t - rest_time(p, v, p1, V, A)) < 1e-9
    assert poly.state(0.0)[:2] == (p, v)
    pe, ve, _ = poly.state(t - 1e-9)
    assert abs(pe - p1) < 1e-6 and abs(ve) < 1e-6
    _, P, Vs, As = _dense(poly, 0.0, t + 0.1)
    assert np.all(np.abs(Vs) <= V + 1e-9) and np.all(np.abs(As) <= A + 1e-9)
    # Continuity: positions never jump between samples more than the speed limit allows.
    assert np.all(np.abs(np.diff(P)) <= V * (t + 0.1) / 399 + 1e-9)


@settings(max_examples=200, deadline=None)
@given(pos, vel, pos, st.floats(0.0, 0.5))
def test_coast_then_bang_arrives_on_time_without_overshoot(p, v, p1, slack):
    horizon = rest_time(p, v, p1, V, A) + slack
    w = coast_time(p, v, p1, horizon, V, A)
    assert 0.0 <= w <= horizon
    b = Builder(0.0, p, v)
    b.accel(w, 0.0)
    t = to_rest(b, p1, V, A)
    # coast_time takes a speed under 1e-12 m/s for rest; the coast's drift (< 1e-12 m/s for up to the horizon) then
    # costs up to 2 sqrt(drift / A), ~0.3 µs here (found by Hypothesis: p = v = p1 = 2.2e-13, 0.1 µs late)
    tol = 1e-7 + 2.0 * np.sqrt(1e-12 * horizon / A)
    assert t <= horizon + tol
    if t < horizon - tol and v * v / (2 * A) <= abs(p1 - p):
        # Arriving early only happens when coasting longer would overshoot the target (unless it must anyway).
        assert v * (p1 - p) > 0.0
        P = b.finish().sample_many(np.linspace(w, t, 200))
        assert np.all((P - p1) * np.sign(p1 - p) <= 1e-9)


def test_coast_time_reports_too_late():
    assert coast_time(0.0, 0.0, 1.0, 0.1, V, A) == -1.0


@settings(max_examples=150, deadline=None)
@given(
    st.floats(0.0, 0.2), st.floats(-1.0, 1.5), st.floats(0.0, 0.2), st.floats(0.05, 0.8), st.floats(0.0, 0.3)
)
# a picometre to fall: the coast before it is found from a difference of picometres, and the fall ends 71 ns after
# T (the foot at 1e-13 m, 2.8e-6 m/s at T itself)
@example(1e-12, 1e-12, 0.0, 0.5, 0.0)
def test_rise_hold_fall(z0, vz0, z1, T, h):
    b = Builder(0.0, z0, vz0)
    top = max(z0, z1) + h
    ok = rise_hold_fall(b, top, z1, T, 2.0, 1.5, 40.0)
    poly = b.finish()
    _, Z, Vz, Az = _dense(poly, 0.0, T + 0.2)
    assert np.all(np.abs(Az) <= 40.0 + 1e-9)
    assert np.all(Vz <= max(2.0, vz0) + 1e-9) and np.all(Vz >= -max(1.5, 2.0, -vz0) - 1e-9)
    if ok:
        # at rest on z1 by T, to the rounding of its break times (within a microsecond: the controller ticks every 2 ms)
        z, v, _ = poly.state(T + 1e-6)
        assert abs(z - z1) < 1e-6 and abs(v) < 1e-6
        assert Z.max() <= max(top, z0 + max(vz0, 0.0) ** 2 / 80.0) + 1e-9
    else:
        # Too late even for the lowest top: it still comes to rest on z1, after T.
        assert rest_time(z0, vz0, z1, 2.0, 40.0) > T - 1e-9 or T < 0.3


@settings(max_examples=300, deadline=None)
@given(
    st.floats(-0.1, 0.3),
    st.floats(-1.5, 2.0),
    st.floats(-0.1, 0.3),
    st.floats(0.01, 0.6),
    st.floats(-0.1, 0.4),
    st.floats(0.3, 1.0),
)
def test_rise_hold_fall_outlook_bounds_the_height_and_says_when_it_arrives(z0, vz0, z1, T, top, frac):
    """The vertical selection rejects policies on this outlook without building them: its on-time answer must be
    rise_hold_fall's, and its height a true upper bound of every sample (or inf)."""
    v_up, v_down, a = 2.0 * frac, 1.5 * frac, 60.0 * frac
    b = Builder(0.0, z0, vz0)
    ok = rise_hold_fall(b, top, z1, T, v_up, v_down, a)
    poly = b.finish()
    peak, on_time = rise_hold_fall_outlook(z0, vz0, top, z1, T, v_up, v_down, a)
    assert on_time == ok
    _, Z, _, _ = _dense(poly, 0.0, T)
    assert Z.max() <= peak + 1e-9


def test_rest_time_still_is_rest_time_from_rest_bit_for_bit() -> None:
    """rest_time_still (the fall from a swing's top) folds rest_time's branches for v = 0: the same value, bit for
    bit, on random ends, zero-length moves and both signs of zero."""
    import random
    import struct

    rng = random.Random(3)
    special = [0.0, -0.0, 1e-300, -1e-300, 0.1, -0.1, 0.3]
    for _ in range(20000):
        p = rng.choice([rng.uniform(-1.0, 1.0), rng.choice(special)])
        p1 = rng.choice([rng.uniform(-1.0, 1.0), rng.choice(special), p, -p, p + rng.uniform(-1e-12, 1e-12)])
        v_max = rng.choice([rng.uniform(0.01, 5.0), 2.0, 1.5])
        a_max = rng.choice([rng.uniform(0.5, 100.0), 60.0, 14.0])
        want, got = rest_time(p, 0.0, p1, v_max, a_max), rest_time_still(p, p1, v_max, a_max)
        assert struct.pack("d", want) == struct.pack("d", got), (p, p1, v_max, a_max)
