"""The recorder tells a foot's landing (it rose off the ground first) from a scuff or a chatter (it did not)."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from planning.sim.metrics import LANDING_RISE_M, Recorder

R = 0.035  # foot radius, m


def _state(t: float, feet_z: list[float], contact: list[bool], x0: float = 0.0) -> SimpleNamespace:
    feet = np.array([[0.3 + x0, 0.15, 0.0], [0.3, -0.15, 0.0], [-0.3, 0.15, 0.0], [-0.3, -0.15, 0.0]])
    feet[:, 2] = np.asarray(feet_z) + R
    return SimpleNamespace(
        t=t,
        p_world_foot=feet,
        contact=np.array(contact),
        loaded=np.array(contact),  # the feet the ground pushes (hard feet: the ones in contact)
        p_world_body=np.array([0.0, 0.0, 0.5]),
        R_world_body=np.eye(3),
        v_world_body=np.zeros(3),
        omega_world=np.zeros(3),
    )


def _walk(heights: list[float], contacts: list[bool]) -> Recorder:
    """Leg 0 follows heights (m) and contacts over ticks of 2 ms; the other feet stay down."""
    rec = Recorder(foot_radius_m=R)
    for k, (z, c) in enumerate(zip(heights, contacts, strict=True)):
        rec(_state(0.002 * k, [z, 0.0, 0.0, 0.0], [c, True, True, True], x0=0.001 * k))
    return rec


def test_a_swing_that_rises_ends_in_a_landing() -> None:
    up = [0.0, 0.0] + [0.01 * i for i in range(1, 9)] + [0.08 - 0.01 * i for i in range(1, 9)] + [0.0, 0.0]
    rec = _walk(up, [True, True] + [False] * 16 + [True, True])
    assert len(rec.touchdowns) == 1
    td = rec.touchdowns[0]
    assert td.leg == 0 and td.landing
    assert abs(td.rise_m - 0.08) < 1e-9


def test_a_foot_chattering_along_the_ground_is_no_landing() -> None:
    # off and on again every few ticks while it slides, never higher than 2 mm: three contacts, no landing
    z = [0.0, 0.001, 0.002, 0.0, 0.0, 0.001, 0.0, 0.0, 0.002, 0.001, 0.0]
    c = [True, False, False, True, True, False, True, True, False, False, True]
    rec = _walk(z, c)
    assert len(rec.touchdowns) == 3
    assert not any(td.landing for td in rec.touchdowns)
    assert all(td.rise_m < LANDING_RISE_M for td in rec.touchdowns)
    # the rise is measured from where the foot last left the ground, not from the run's start
    assert abs(max(td.rise_m for td in rec.touchdowns) - 0.002) < 1e-9


def test_flight_fraction_counts_the_time_with_no_foot_down_after_a_given_time() -> None:
    # 0.4 s of 2 ms ticks: all four feet down until 0.2 s, then a cycle of 30 ms down and 10 ms with all off
    rec = Recorder(foot_radius_m=R, sample_period_s=0.01)
    for k in range(200):
        t = 0.002 * k
        down = t < 0.2 or (t - 0.2) % 0.04 < 0.03 - 1e-9
        rec(_state(t, [0.0 if down else 0.02] * 4, [down] * 4))
    assert rec.flight_fraction(0.0) is not None and rec.flight_fraction(0.0) < rec.flight_fraction(0.2)
    assert abs(rec.flight_fraction(0.2) - 0.25) < 0.03
    assert rec.flight_fraction(0.5) is None  # nothing recorded after it
