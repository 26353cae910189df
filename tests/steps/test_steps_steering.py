"""Steering input: limits, rate limits and smoothing."""

from __future__ import annotations

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from planning.steps import GAITS, SteeringCommand, SteeringFilter, SteeringParams

speed = st.floats(-10, 10, allow_nan=False)


@given(vx=speed, vy=speed, r=speed)
def test_limits_hold_for_any_command(vx: float, vy: float, r: float) -> None:
    f = SteeringFilter()
    p = f.params
    for _ in range(50):
        c = f.update(SteeringCommand(vx, vy, r), 0.01, GAITS["walk"])
        assert -p.max_vx_back_mps <= c.vx <= GAITS["walk"].max_speed_mps + 1e-12
        assert abs(c.vy) <= p.max_vy_mps + 1e-12 and abs(c.yaw_rate) <= p.max_yaw_rate_rps + 1e-12


def test_acceleration_is_limited_and_the_target_is_reached() -> None:
    f = SteeringFilter(SteeringParams(tau_s=0.1, max_accel_x_mps2=1.0))
    prev = 0.0
    for _ in range(100):
        c = f.update(SteeringCommand(1.0, 0.0, 0.0), 0.01)
        assert c.vx - prev <= 1.0 * 0.01 + 1e-12
        prev = c.vx
    assert f.command.vx < 1.0  # after 1 s at ≤1 m/s² with smoothing it is not there yet
    for _ in range(300):
        f.update(SteeringCommand(1.0, 0.0, 0.0), 0.01)
    assert f.command.vx == pytest.approx(1.0)


def test_a_stand_allows_no_motion() -> None:
    f = SteeringFilter(
        SteeringParams(tau_s=0.0, max_accel_x_mps2=100, max_accel_y_mps2=100, max_yaw_accel_rps2=100)
    )
    c = f.update(SteeringCommand(1.0, 0.5, 0.5), 0.1, GAITS["stand"])
    assert c.is_zero


def test_bad_input_names_the_field() -> None:
    with pytest.raises(ValueError, match="vx"):
        SteeringCommand(math.nan, 0.0, 0.0)
    with pytest.raises(ValueError, match="dt"):
        SteeringFilter().update(SteeringCommand(), -1.0)
    with pytest.raises(ValueError, match="tau_s"):
        SteeringParams(tau_s=-1.0)


def test_gait_limits_can_be_lifted_but_a_stand_stays_still() -> None:
    cmd = SteeringCommand(3.0, 1.0, 2.0)
    capped = SteeringFilter().limit(cmd, GAITS["walk"])
    assert capped.vx == GAITS["walk"].max_speed_mps
    lifted = SteeringFilter(
        SteeringParams(max_vx_mps=4.0, max_vy_mps=2.0, max_yaw_rate_rps=3.0, gait_limits=False)
    )
    assert lifted.limit(cmd, GAITS["walk"]) == SteeringCommand(3.0, 1.0, 2.0)
    assert lifted.limit(cmd, GAITS["stand"]) == SteeringCommand(0.0, 0.0, 0.0)
