"""Time grid: events on knots, fine near now and coarser later, the cap on knots, the derived base step."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from planning.centroidal.timegrid import derive_base_dt, make_time_grid


def test_pattern_without_events_is_four_of_each_multiple():
    t = make_time_grid(0.0, [], 1.2, base_dt=0.05, max_knots=100)
    steps = np.round(np.diff(t) / 0.05, 6)
    assert steps.tolist() == [1] * 4 + [2] * 4 + [3] * 4
    assert t[0] == 0.0 and t[-1] == pytest.approx(1.2)


def test_last_multiple_repeats_to_the_horizon_end():
    t = make_time_grid(0.0, [], 2.0, base_dt=0.05, max_knots=100)
    steps = np.diff(t)
    assert t[-1] == pytest.approx(2.0)
    assert np.all(steps[12:-1] == pytest.approx(0.15))


def test_every_event_is_a_knot_and_splits_a_coarse_step():
    events = [0.33, 0.47, 0.71, 5.0]  # the last is beyond the horizon
    t = make_time_grid(0.0, events, 1.2, base_dt=0.05, max_knots=100)
    for e in events[:3]:
        assert np.min(np.abs(t - e)) < 1e-12
    assert t[-1] == pytest.approx(1.2)
    # Near the start the steps are still the base step.
    assert np.diff(t)[:4] == pytest.approx([0.05] * 4)


def test_cap_drops_the_far_end():
    t = make_time_grid(0.0, np.arange(0.03, 1.2, 0.07), 1.2, base_dt=0.05, max_knots=10)
    assert t.size == 10
    assert t[-1] < 1.2


def test_slivers_before_an_event_are_merged():
    # A regular step would end 1 ms before the event: the step stretches to the event instead.
    t = make_time_grid(0.0, [0.101], 0.5, base_dt=0.05, max_knots=100)
    assert np.min(np.diff(t)) > 0.02
    assert np.min(np.abs(t - 0.101)) < 1e-12


def test_base_dt_derived_from_the_shortest_gap():
    assert derive_base_dt([0.0, 0.12, 0.36]) == pytest.approx(0.04)  # 0.12 = 3 × 0.04
    assert derive_base_dt([0.0, 0.03, 0.5]) == pytest.approx(0.03)
    assert derive_base_dt([0.0]) == pytest.approx(0.05)
    t = make_time_grid(0.0, [0.12, 0.36], 1.0, base_dt=None, max_knots=100)
    assert np.diff(t)[0] == pytest.approx(0.04)


@pytest.mark.parametrize(
    "kwargs",
    [
        dict(t_now=0.0, event_times=[], horizon_end=0.0),
        dict(t_now=0.0, event_times=[np.nan], horizon_end=1.0),
        dict(t_now=0.0, event_times=[], horizon_end=1.0, base_dt=0.0),
        dict(t_now=0.0, event_times=[], horizon_end=1.0, max_knots=1),
        dict(t_now=0.0, event_times=[], horizon_end=1.0, pattern=((4, 0),)),
    ],
)
def test_bad_input_is_refused_with_a_reason(kwargs):
    with pytest.raises(ValueError, match=r"\w"):
        make_time_grid(**kwargs)


@settings(max_examples=60, deadline=None)
@given(
    t_now=st.floats(0.0, 10.0),
    events=st.lists(st.floats(0.0, 12.0), max_size=12),
    horizon=st.floats(0.2, 2.0),
    base=st.sampled_from([0.02, 0.05, 0.1]),
)
def test_grid_properties(t_now, events, horizon, base):
    t = make_time_grid(t_now, events, t_now + horizon, base_dt=base, max_knots=64)
    d = np.diff(t)
    assert t[0] == t_now
    assert np.all(d > 0)
    assert t[-1] <= t_now + horizon + 1e-9
    # Steps never exceed the largest multiple plus the sliver allowance.
    assert np.all(d <= 3.5 * base + 1e-9)
    # Every event inside the horizon that the grid reaches is a knot.
    for e in events:
        if t_now + 1e-6 < e < t[-1] - 1e-6:
            assert np.min(np.abs(t - e)) < 1e-9


def test_an_event_just_after_a_knot_gets_no_millisecond_step():
    # a liftoff 1 ms from now and a touchdown 9 ms later: without the gap, steps of 1 and 9 ms
    events = [0.001, 0.010, 0.26]
    plain = make_time_grid(0.0, events, 0.8, base_dt=0.05, max_knots=100)
    assert np.diff(plain)[:2] == pytest.approx([0.001, 0.009])
    t = make_time_grid(0.0, events, 0.8, base_dt=0.05, max_knots=100, min_event_gap_s=0.012)
    assert np.diff(t).min() >= 0.012 - 1e-12
    assert np.min(np.abs(t - 0.26)) < 1e-12  # events further out keep their knots
    assert t[1] == pytest.approx(0.05) and t[-1] == pytest.approx(0.8)
