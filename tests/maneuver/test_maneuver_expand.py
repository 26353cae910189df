"""Gait expansion and the contact schedule: event counts, alternation, leg pairs, positions, queries."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from planning.maneuver import (
    GAIT_PHASES,
    MAX_EVENTS,
    Gait,
    ManeuverError,
    build_schedule,
    expand_gait,
    parse_maneuver,
    start_feet,
    support_frame,
)
from planning.maneuver.expand import gait_event_count
from planning.robot import load_robot

ROBOT = load_robot("spot")
P_START = start_feet(ROBOT)
NOMINAL_XY = P_START[:, :2]


def gait(**kw) -> Gait:
    fields = {"gait": "trot", "from": 0.0, "to": 2.0, "cycle": 0.5, "duty": 0.6, "step": [0.0, 0.0, 0.0]}
    fields.update(kw)
    return Gait.model_validate(fields)


gaits = st.builds(
    lambda name, t0, n, cycle, duty, dx, dy, dyaw, extra: gait(
        gait=name,
        **{"from": t0},
        to=t0 + n * cycle + extra * cycle,
        cycle=cycle,
        duty=duty,
        step=[dx, dy, dyaw],
    ),
    name=st.sampled_from(sorted(GAIT_PHASES)),
    t0=st.floats(0.0, 5.0),
    n=st.integers(1, 12),
    cycle=st.floats(0.2, 1.5),
    duty=st.floats(0.3, 0.95),
    dx=st.floats(-0.3, 0.3),
    dy=st.floats(-0.2, 0.2),
    dyaw=st.floats(-30.0, 30.0),
    extra=st.floats(0.0, 0.99),
)


@settings(max_examples=150, deadline=None)
@given(gaits)
def test_gait_swings_alternate_and_stay_inside_the_segment(g: Gait) -> None:
    plan = expand_gait(g, P_START, NOMINAL_XY)
    assert 2 * len(plan.swings) == gait_event_count(g)
    for leg in range(4):
        mine = sorted((lo, td) for lg, lo, td, _ in plan.swings if lg == leg)
        for lo, td in mine:
            assert g.from_ - 1e-9 <= lo < td <= g.to + 1e-9
            assert td - lo == pytest.approx((1 - g.duty) * g.cycle)
        for (_, td), (lo_next, _) in zip(mine, mine[1:], strict=False):
            assert td < lo_next  # lands before it lifts again: liftoff, touchdown, liftoff, ...


@settings(max_examples=100, deadline=None)
@given(gaits)
def test_every_leg_steps_once_per_cycle_when_the_swings_fit(g: Gait) -> None:
    n = int(math.floor((g.to - g.from_) / g.cycle + 1e-9))
    spare = g.to - (g.from_ + n * g.cycle)  # time after the last whole cycle
    fits = [ph * g.cycle + (1 - g.duty) * g.cycle <= g.cycle + spare + 1e-9 for ph in GAIT_PHASES[g.gait]]
    plan = expand_gait(g, P_START, NOMINAL_XY)
    assert len(plan.swings) == 4 * (n - 1) + sum(fits)
    assert gait_event_count(g) == 2 * len(plan.swings)
    for leg in range(4):
        assert sum(1 for lg, *_ in plan.swings if lg == leg) == n - 1 + fits[leg]


@pytest.mark.parametrize(
    ("name", "together"),
    [
        ("trot", [("FL", "RR"), ("FR", "RL")]),
        ("pace", [("FL", "RL"), ("FR", "RR")]),
        ("bound", [("FL", "FR"), ("RL", "RR")]),
        ("pronk", [("FL", "FR", "RL", "RR")]),
    ],
)
def test_leg_pairs_move_together_and_pairs_alternate(name: str, together: list[tuple[str, ...]]) -> None:
    legs = ("FL", "FR", "RL", "RR")
    plan = expand_gait(gait(gait=name, duty=0.5), P_START, NOMINAL_XY)
    lift = {leg: [lo for lg, lo, _, _ in plan.swings if lg == legs.index(leg)] for leg in legs}
    for group in together:
        for leg in group[1:]:
            assert lift[leg] == pytest.approx(lift[group[0]])
    if len(together) == 2:
        a, b = lift[together[0][0]], lift[together[1][0]]
        assert np.allclose(np.array(b) - np.array(a), 0.25)  # half a 0.5 s cycle apart


def test_walk_is_a_four_beat_crawl_rl_fl_rr_fr(mk) -> None:
    plan = expand_gait(gait(gait="walk", cycle=1.0, duty=0.75, to=3.0), P_START, NOMINAL_XY)
    first_cycle = sorted((lo, lg) for lg, lo, _, _ in plan.swings if lo < 1.0)
    assert [lg for _, lg in first_cycle] == [2, 0, 3, 1]  # RL, FL, RR, FR
    assert [lo for lo, _ in first_cycle] == pytest.approx([0.0, 0.25, 0.5, 0.75])
    sched = build_schedule(
        parse_maneuver(mk(gaits=[{"gait": "walk", "from": 0, "to": 3, "cycle": 1.0, "duty": 0.75}])),
        ROBOT,
    )
    for t in np.arange(0.01, 3.0, 0.05):
        assert sched.stance_mask(float(t)).sum() >= 3  # one foot up at a time


def test_touchdowns_advance_by_the_step_each_cycle() -> None:
    g = gait(to=2.0, step=[0.1, 0.02, 0.0])
    plan = expand_gait(g, P_START, NOMINAL_XY)
    for leg, lo, _, p_xy in plan.swings:
        k = int(math.floor((lo - g.from_) / g.cycle + 1e-9))
        np.testing.assert_allclose(p_xy, NOMINAL_XY[leg] + (k + 1) * np.array([0.1, 0.02]), atol=1e-12)
    np.testing.assert_allclose(plan.pose_cycle[-1], [0.4, 0.08, 0.0], atol=1e-12)


@settings(max_examples=60, deadline=None)
@given(dx=st.floats(-0.2, 0.2), dy=st.floats(-0.1, 0.1), dyaw=st.floats(-25, 25), n=st.integers(1, 8))
def test_yaw_accumulates_and_the_feet_end_around_the_last_pose(
    dx: float, dy: float, dyaw: float, n: int
) -> None:
    g = gait(to=0.5 * n, step=[dx, dy, dyaw])
    plan = expand_gait(g, P_START, NOMINAL_XY)
    assert plan.pose_cycle[-1, 2] == pytest.approx(math.radians(dyaw) * n)
    last = {lg: p for lg, _, _, p in plan.swings}  # the last touchdown of each leg
    feet = np.column_stack([np.array([last[i] for i in range(4)]), np.zeros(4)])
    x, y, yaw = support_frame(feet, NOMINAL_XY)
    np.testing.assert_allclose([x, y], plan.pose_cycle[-1, :2], atol=1e-9)
    assert math.remainder(yaw - plan.pose_cycle[-1, 2], 2 * math.pi) == pytest.approx(0.0, abs=1e-9)
    # each step is (dx, dy) in the body frame: its length does not depend on the heading
    steps = np.diff(plan.pose_cycle[:, :2], axis=0)
    np.testing.assert_allclose(np.linalg.norm(steps, axis=1), math.hypot(dx, dy), atol=1e-9)


def test_support_frame_of_the_nominal_stance_is_the_origin() -> None:
    assert support_frame(P_START, NOMINAL_XY) == pytest.approx((0.0, 0.0, 0.0))
    yaw = math.radians(30)
    R = np.array([[math.cos(yaw), -math.sin(yaw)], [math.sin(yaw), math.cos(yaw)]])
    moved = P_START.copy()
    moved[:, :2] = NOMINAL_XY @ R.T + [1.0, -0.5]
    assert support_frame(moved, NOMINAL_XY) == pytest.approx((1.0, -0.5, yaw))


def test_schedule_resolves_offsets_from_where_the_foot_lifted_off(mk) -> None:
    m = parse_maneuver(
        mk(
            events=[
                {"t": 0.5, "leg": "RL", "type": "liftoff"},
                {"t": 1.0, "leg": "RL", "type": "touchdown", "offset": [-0.1, 0.02]},
                {"t": 1.5, "leg": "RL", "type": "liftoff"},
                {"t": 2.0, "leg": "RL", "type": "touchdown", "offset": [0.0, 0.0, 0.15]},
                {"t": 2.5, "leg": "FR", "type": "liftoff"},
                {"t": 3.0, "leg": "FR", "type": "touchdown", "at": [0.5, -0.2, 0.1], "normal": [0, -2, 0]},
            ]
        )
    )
    s = build_schedule(m, ROBOT)
    rl, fr = s.swings[2], s.swings[1]
    np.testing.assert_allclose(rl[0].p_touchdown, P_START[2] + [-0.1, 0.02, 0.0])
    np.testing.assert_allclose(rl[1].p_liftoff, rl[0].p_touchdown)
    np.testing.assert_allclose(rl[1].p_touchdown, P_START[2] + [-0.1, 0.02, 0.15])
    np.testing.assert_allclose(fr[0].p_touchdown, [0.5, -0.2, 0.1])
    np.testing.assert_allclose(fr[0].normal, [0.0, -1.0, 0.0])  # normalized
    assert s.n_events == 6 and [e.path for e in s.events()][:2] == ["events[0]", "events[1]"]


def test_schedule_queries(mk) -> None:
    m = parse_maneuver(
        mk(
            events=[
                {"t": 1.0, "leg": "FL", "type": "liftoff"},
                {"t": 1.5, "leg": "FL", "type": "touchdown", "at": [0.45, 0.165, 0.0]},
            ]
        )
    )
    s = build_schedule(m, ROBOT)
    assert s.in_stance("FL", 0.99) and not s.in_stance("FL", 1.0) and not s.in_stance(0, 1.49)
    assert s.in_stance("FL", 1.5) and all(s.in_stance(leg, 1.2) for leg in ("FR", "RL", "RR"))
    nxt = s.next_touchdown("FL", 0.0)
    assert nxt is not None and nxt.t_touchdown == 1.5
    assert s.next_touchdown("FL", 1.5) is None and s.next_touchdown("RR", 0.0) is None
    np.testing.assert_allclose(s.foot_target("FL", 0.5), P_START[0])
    np.testing.assert_allclose(s.foot_target("FL", 1.2), [0.45, 0.165, 0.0])  # where it will land
    np.testing.assert_allclose(s.foot_position("FL", 1.2), P_START[0])  # where it lifted off
    np.testing.assert_allclose(s.foot_position("FL", 2.0), [0.45, 0.165, 0.0])
    assert s.stance_mask(1.2).tolist() == [False, True, True, True]


def test_gait_after_an_explicit_step_starts_from_where_the_feet_are(mk) -> None:
    m = parse_maneuver(
        mk(
            duration=4.0,
            events=[
                {"t": 0.2, "leg": "FL", "type": "liftoff"},
                {"t": 0.6, "leg": "FL", "type": "touchdown", "offset": [0.1, 0.0]},
            ],
            gaits=[{"gait": "trot", "from": 1.0, "to": 3.0, "cycle": 0.5, "duty": 0.6, "step": [0.1, 0, 0]}],
        )
    )
    s = build_schedule(m, ROBOT)
    fl = s.swings[0]
    assert len(fl) == 5 and fl[0].touchdown_path == "events[1]" and fl[1].liftoff_path == "gaits[0]"
    np.testing.assert_allclose(fl[1].p_liftoff, fl[0].p_touchdown)
    final = np.array([s.foot_position(i, 4.0) for i in range(4)])
    x, y, _ = support_frame(final, NOMINAL_XY)
    assert x == pytest.approx(0.025 + 0.4, abs=0.01)  # the explicit step moved the support 2.5 cm first


def test_too_many_events_are_refused_before_they_are_built(mk) -> None:
    m = parse_maneuver(
        mk(duration=60.0, gaits=[{"gait": "pronk", "from": 0, "to": 60, "cycle": 0.1, "duty": 0.5}])
    )
    with pytest.raises(ManeuverError, match=f"at most {MAX_EVENTS}"):
        build_schedule(m, ROBOT)
