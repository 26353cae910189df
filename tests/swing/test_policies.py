"""Horizontal policies on their own: start state, arrival, limits, and the detours around keep-out areas."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from planning.swing.policies import (
    HORIZONTAL_POLICIES,
    LegCtx,
    blocked_keepouts,
    swing_around,
    wiggle,
)

V, A = 3.0, 40.0
BOX = (0.25, 0.35, -0.05, 0.05)  # a keep-out area in the heading frame, m


def _ctx(p0, p1, T=0.5, v0=(0.0, 0.0), keepouts=(BOX,)):
    kos = list(keepouts)
    return LegCtx(
        0.0, T, tuple(p0), tuple(v0), tuple(p1), V, A, kos, 0.03, 0.1, blocked_keepouts(p0, p1, kos)
    )


def _xy(hp, ts):
    return np.column_stack((hp.x.sample_many(ts), hp.y.sample_many(ts)))


def _inside(pts, box, shrink=1e-6):
    return (
        (pts[:, 0] > box[0] + shrink)
        & (pts[:, 0] < box[1] - shrink)
        & (pts[:, 1] > box[2] + shrink)
        & (pts[:, 1] < box[3] - shrink)
    )


@settings(max_examples=80, deadline=None)
@given(
    st.floats(-0.2, 0.2),
    st.floats(-0.2, 0.2),
    st.floats(-1.0, 1.0),
    st.floats(-1.0, 1.0),
    st.floats(-0.2, 0.2),
    st.floats(-0.2, 0.2),
    st.floats(0.1, 0.6),
)
def test_every_policy_starts_at_the_state_and_rests_on_arrival(x0, y0, vx, vy, x1, y1, T):
    c = _ctx((x0, y0), (x1, y1), T, (vx, vy), keepouts=[])
    for name, fn in HORIZONTAL_POLICIES:
        hp = fn(c)
        if hp is None:
            continue
        assert hp.x.state(0.0)[:2] == pytest.approx((x0, vx)), name
        assert hp.y.state(0.0)[:2] == pytest.approx((y0, vy)), name
        if np.isfinite(hp.t_arrive):
            t = hp.t_arrive + 1e-9
            assert hp.x.state(t)[:2] == pytest.approx((x1, 0.0), abs=1e-6), name
            assert hp.y.state(t)[:2] == pytest.approx((y1, 0.0), abs=1e-6), name


def test_combinations_by_axis_and_by_time():
    c = _ctx((0.0, 0.0), (0.3, 0.1), 0.4, keepouts=[])
    by_name = {n: fn(c) for n, fn in HORIZONTAL_POLICIES}
    ts = np.linspace(0.0, 0.4, 100)
    # By axis: x follows BangBangWait, y follows Cubic.
    np.testing.assert_allclose(
        by_name["BBW-x+Cubic-y"].x.sample_many(ts), by_name["BangBangWait"].x.sample_many(ts)
    )
    np.testing.assert_allclose(by_name["BBW-x+Cubic-y"].y.sample_many(ts), by_name["Cubic"].y.sample_many(ts))
    # By time: BangBangWait for the first tenth, then a cubic that lands at the touchdown time.
    early = ts[ts <= 0.04]
    np.testing.assert_allclose(
        by_name["BBW→Cubic"].x.sample_many(early), by_name["BangBangWait"].x.sample_many(early)
    )
    assert by_name["BBW→Cubic"].t_arrive == pytest.approx(0.4)
    assert by_name["BBW→Cubic"].x.state(0.4)[:2] == pytest.approx((0.3, 0.0))


@pytest.mark.parametrize("start", [(0.05, 0.0), (0.05, 0.03), (0.05, -0.04), (0.15, 0.02), (0.2, -0.01)])
@pytest.mark.parametrize("clear_axis, side", [(1, 1.0), (1, -1.0)])
def test_swing_around_from_various_starts_avoids_the_keepout(start, clear_axis, side):
    # Seed FIG. 14: several starting locations, one touchdown beyond the keep-out area.
    c = _ctx(start, (0.5, 0.0), 0.5)
    assert c.blocked == [0]
    hp = swing_around(c, clear_axis, side)
    ts = np.linspace(0.0, 0.5, 2000)
    pts = _xy(hp, ts)
    assert not _inside(pts, BOX).any()
    assert hp.t_arrive <= 0.5 + 1e-9
    np.testing.assert_allclose(pts[-1], (0.5, 0.0), atol=1e-9)
    assert np.sign(pts[:, 1].max() if side > 0 else pts[:, 1].min()) == side  # went round the chosen side


def test_swing_around_from_the_far_side_goes_out_then_across_then_back():
    # FIG. 13: the foot starts beside the keep-out area and must leave it sideways before crossing.
    c = _ctx((0.30, 0.12), (0.30, -0.12), 0.5, keepouts=[(0.25, 0.35, -0.05, 0.05)])
    hp = swing_around(c, 0, 1.0)  # clear along x (out past the box's far x edge), pass along y
    pts = _xy(hp, np.linspace(0.0, 0.5, 2000))
    assert not _inside(pts, BOX).any()
    assert pts[:, 0].max() >= 0.35 + 0.03 - 1e-9
    np.testing.assert_allclose(pts[-1], (0.30, -0.12), atol=1e-9)


def test_wiggle_weaves_between_several_keepouts():
    boxes = [(0.20, 0.28, -0.10, 0.06), (0.40, 0.48, -0.06, 0.10)]
    c = _ctx((0.05, 0.0), (0.65, 0.0), 0.6, keepouts=boxes)
    assert c.blocked == [0, 1]
    hp = wiggle(c)
    assert hp is not None
    pts = _xy(hp, np.linspace(0.0, 0.6, 3000))
    for b in boxes:
        assert not _inside(pts, b).any()
    np.testing.assert_allclose(pts[-1], (0.65, 0.0), atol=1e-9)
    assert hp.x.state(0.6)[1] == pytest.approx(0.0) and hp.y.state(0.6)[1] == pytest.approx(0.0)


def test_detours_are_not_offered_when_nothing_is_in_the_way():
    c = _ctx((0.0, 0.2), (0.5, 0.2), keepouts=[BOX])
    assert c.blocked == []
    assert swing_around(c, 1, 1.0) is None
    assert wiggle(c) is None
