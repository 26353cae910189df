"""Gait table and clock: contact patterns, schedules, and safe switching while walking."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from planning.steps import GAIT_NAMES, GAITS, GaitClock, get_gait

WALKING = ("trot", "walk", "pace", "bound")
DT = 0.002  # s


def test_table_has_the_required_gaits_with_sane_values() -> None:
    assert set(WALKING) | {"stand"} <= set(GAIT_NAMES)
    for name in WALKING:
        g = GAITS[name]
        assert 0.5 <= g.duty < 1.0 and 0.2 <= g.cycle_s <= 2.0 and g.swing_height_m > 0
    assert GAITS["stand"].is_stand
    with pytest.raises(ValueError, match="gait"):
        get_gait("gallop-ish")


@pytest.mark.parametrize(
    ("name", "pairs"),
    [("trot", [(0, 3), (1, 2)]), ("pace", [(0, 2), (1, 3)]), ("bound", [(0, 1), (2, 3)])],
)
def test_paired_gaits_move_their_pairs_together(name: str, pairs: list[tuple[int, int]]) -> None:
    clock = GaitClock(name)
    for t in np.arange(0.0, 2.0, DT):
        c = clock.contact(float(t))
        for a, b in pairs:
            assert c[a] == c[b]


def test_walk_lifts_one_leg_at_a_time() -> None:
    clock = GaitClock("walk")
    for t in np.arange(0.0, 2.0, DT):
        assert clock.contact(float(t)).sum() >= 3


@pytest.mark.parametrize("name", WALKING)
def test_schedule_covers_two_cycles_with_gait_timing(name: str) -> None:
    g = GAITS[name]
    clock = GaitClock(name, t0=0.3)
    s = clock.schedule(0.37, n_cycles=2)
    assert np.bincount(s.leg, minlength=4).tolist() == [2, 2, 2, 2]
    assert np.all(np.diff(s.t_touchdown) >= 0) and np.all(s.t_touchdown > 0.37)
    assert np.allclose(s.t_liftoff - s.t_touchdown, g.stance_s)
    assert s.t_touchdown.max() >= 0.37 + g.cycle_s  # at least up to the second cycle
    for leg in range(4):
        td = s.t_touchdown[s.leg == leg]
        assert td[1] - td[0] == pytest.approx(g.cycle_s)
        assert clock.leg_contact(leg, float(td[0]) + 1e-6) and not clock.leg_contact(leg, float(td[0]) - 1e-6)


def _run(clock: GaitClock, t0: float, t1: float) -> tuple[np.ndarray, np.ndarray]:
    ts = np.arange(t0, t1, DT)
    contacts = []
    for t in ts:
        clock.advance(float(t))
        contacts.append(clock.contact(float(t)))
    return ts, np.array(contacts)


def _intervals(c: np.ndarray, value: bool) -> list[int]:
    """Lengths (samples) of the complete runs of ``value`` (the first and last runs are cut off, so skipped)."""
    runs = [(k, len(list(g))) for k, g in itertools.groupby(c)]
    return [n for k, n in runs[1:-1] if k == value]


@pytest.mark.parametrize(("a", "b"), [(a, b) for a in WALKING for b in WALKING if a != b])
def test_switching_while_walking_is_safe_and_quick(a: str, b: str) -> None:
    clock = GaitClock(a)
    _run(clock, 0.0, 1.13)
    clock.request(b)
    t_req = 1.13
    ts, c = _run(clock, t_req, t_req + 3.0)
    assert clock.gait.name == b
    assert clock.t_switch - t_req <= GAITS[a].cycle_s  # switched within one cycle of the old gait
    ga, gb = GAITS[a], GAITS[b]
    min_swing = (1 - clock.max_start_progress) * min(ga.swing_s, gb.swing_s) - 2 * DT
    for leg in range(4):
        swings = _intervals(c[:, leg], False)
        assert swings and min(swings) * DT >= min_swing, (leg, swings)
        stances = _intervals(c[:, leg], True)
        assert min(stances) * DT >= 0.5 * min(ga.stance_s, gb.stance_s)
    # Two new cycles after the switch, the pattern is the new gait's own.
    late = ts > clock.t_switch + 2.5 * GAITS[b].cycle_s
    ref = GaitClock(b, t0=clock._t_ref)
    assert np.array_equal(c[late], np.array([ref.contact(float(t)) for t in ts[late]]))


@pytest.mark.parametrize("a", WALKING)
def test_stop_finishes_swings_then_stands_and_restarts(a: str) -> None:
    clock = GaitClock(a)
    _run(clock, 0.0, 0.77)
    swinging = ~clock.contact(0.77)
    clock.request("stand")
    ts, c = _run(clock, 0.77, 2.0)
    assert clock.gait.is_stand
    t_all_down = ts[np.argmax(c.all(axis=1))]
    assert t_all_down - 0.77 <= GAITS[a].swing_s + DT
    assert c[ts >= t_all_down].all()  # no new liftoff
    for leg in np.flatnonzero(~swinging):
        assert c[:, leg].all()  # a foot on the ground stays there
    clock.request(a)
    ts, c = _run(clock, 2.0, 4.0)
    assert clock.gait.name == a and (~c).any(axis=0).all()  # every leg steps again
    assert c[0].sum() >= 2


def test_no_leg_lands_before_its_planned_touchdown_after_a_switch() -> None:
    clock = GaitClock("trot")
    _run(clock, 0.0, 0.61)
    before = clock.schedule(0.61, 1)
    planned = {int(leg): float(t) for leg, t in zip(before.leg, before.t_touchdown, strict=True)}
    air = np.flatnonzero(~before.contact_now)
    clock.request("walk")
    ts, c = _run(clock, 0.61, 1.5)
    for leg in air:
        first_down = ts[np.argmax(c[:, leg])]
        assert first_down >= planned[int(leg)] - DT


@pytest.mark.parametrize("b", ["climb", "stairs", "trot"])
def test_a_switch_from_the_walk_keeps_two_feet_down(b: str) -> None:
    # At a walk touchdown the diagonal leg lifts at the same instant; switching there to a trot-like gait must not
    # let that leg swing on while the new gait lifts the other pair (three feet up at once).
    worst = 4
    for t_req in np.arange(1.0, 2.0, 0.05):
        clock = GaitClock("walk")
        _run(clock, 0.0, float(t_req))
        clock.request(b)
        _, c = _run(clock, float(t_req), float(t_req) + 2.0)
        assert clock.gait.name == b
        worst = min(worst, int(c.sum(axis=1).min()))
    assert worst >= 2


@pytest.mark.parametrize("name", ["trot", "crawl", "walk"])
def test_a_held_clock_moves_every_later_event_by_the_hold(name: str) -> None:
    clock, ref = GaitClock(name), GaitClock(name)
    t, dt = 0.93, 0.137
    before = ref.schedule(t)
    clock.hold(dt)
    after = clock.schedule(t + dt)
    assert np.array_equal(after.leg, before.leg)
    assert np.allclose(after.t_touchdown, before.t_touchdown + dt)
    assert np.allclose(after.t_liftoff, before.t_liftoff + dt)
    for s in np.arange(t, t + 2.0, 0.01):
        assert np.array_equal(clock.contact(float(s) + dt), ref.contact(float(s)))


def test_a_hold_moves_a_switchs_per_leg_holds_with_the_gait() -> None:
    clock, ref = GaitClock("trot"), GaitClock("trot")
    for c in (clock, ref):
        _run(c, 0.0, 1.13)
        c.request("crawl")
        _run(c, 1.13, 1.6)
    assert any(clock._holds), "the switch left per-leg holds to move"
    clock.hold(0.05)
    for s in np.arange(1.6, 3.0, 0.01):
        assert np.array_equal(clock.contact(float(s) + 0.05), ref.contact(float(s)))


def test_a_stand_is_not_held() -> None:
    clock = GaitClock("stand")
    clock.hold(0.3)
    assert clock.contact(0.1).all() and clock.phase(0.5) == GaitClock("stand").phase(0.5)
