"""Reference step path: timing from the clock, Raibert-style footholds, capture-point feedback, heights."""

from __future__ import annotations

import numpy as np
import pytest
from _steps_common import StripMaps, robot, walking_reference

from planning.steps import (
    GAITS,
    GaitClock,
    SteeringCommand,
    WalkState,
    lip_omega,
    reference_step_path,
    standing_state,
)


@pytest.mark.parametrize("gait", ["trot", "walk", "pace", "bound"])
def test_covers_two_cycles_every_leg(gait: str) -> None:
    ref, state, _ = walking_reference(gait, (0.4, 0.0, 0.0))
    assert np.bincount(ref.leg, minlength=4).tolist() == [2, 2, 2, 2]
    assert ref.t_touchdown.max() >= state.t + GAITS[gait].cycle_s
    assert np.all(np.diff(ref.t_touchdown) >= 0)
    t, p = ref.next_touchdowns()
    assert np.all(np.isfinite(t)) and np.all(t > state.t) and p.shape == (4, 3)


def test_straight_walking_footholds_are_raibert() -> None:
    v = 0.6
    ref, state, _ = walking_reference("trot", (v, 0.0, 0.0))
    r = robot()
    g = GAITS["trot"]
    for k in range(ref.n_touchdowns):
        leg = ref.leg[k]
        body_td = np.array([v * ref.t_touchdown[k], 0.0])
        expect = body_td + r.nominal_foot_body[leg, :2] + np.array([v * g.stance_s / 2, 0.0])
        assert np.allclose(ref.p_world_touchdown[k, :2], expect, atol=1e-9)
        assert ref.p_world_touchdown[k, 2] == 0.0


def test_turning_rotates_the_footholds_with_the_body() -> None:
    ref, _, _ = walking_reference("trot", (0.0, 0.0, 0.8))
    r = robot()
    for k in range(ref.n_touchdowns):
        t_mid = ref.t_touchdown[k] + 0.5 * (ref.t_liftoff[k] - ref.t_touchdown[k])
        yaw = 0.8 * t_mid
        R = np.array([[np.cos(yaw), -np.sin(yaw)], [np.sin(yaw), np.cos(yaw)]])
        assert np.allclose(ref.p_world_touchdown[k, :2], R @ r.nominal_foot_body[ref.leg[k], :2], atol=1e-9)


def test_a_velocity_error_steps_the_feet_by_v_over_omega() -> None:
    base, _, _ = walking_reference("trot", (0.0, 0.0, 0.0), v_state=(0.0, 0.0))
    pushed, _, _ = walking_reference("trot", (0.0, 0.0, 0.0), v_state=(0.0, 0.4))
    shift = pushed.p_world_touchdown[:, :2] - base.p_world_touchdown[:, :2]
    w = lip_omega(robot().standing_height_m)
    first = np.array([list(pushed.leg[:k]).count(pushed.leg[k]) == 0 for k in range(pushed.n_touchdowns)])
    assert np.allclose(shift[first], [0.0, 0.4 / w])
    assert np.allclose(shift[~first], [0.0, 0.5 * 0.4 / w])


def test_heights_come_from_the_terrain_when_known() -> None:
    r = robot()
    state = standing_state(r)
    maps = StripMaps(x0=9.0, half_width_m=0.1, z_m=0.07)
    ref = reference_step_path(
        SteeringCommand(0.3, 0, 0),
        state,
        r,
        GAITS["trot"],
        GaitClock("trot"),
        0.0,
        ground_height=maps.ground_height,
    )
    assert np.allclose(ref.p_world_touchdown[:, 2], 0.07)


def test_standing_has_no_touchdowns() -> None:
    r = robot()
    ref = reference_step_path(
        SteeringCommand(), standing_state(r), r, GAITS["stand"], GaitClock("stand"), 0.0
    )
    assert ref.n_touchdowns == 0


def test_bad_state_names_the_field() -> None:
    with pytest.raises(ValueError, match="p_world_feet"):
        WalkState(np.zeros(3), np.zeros(3), 0.0, 0.0, np.zeros((3, 3)), np.ones(4, bool), 0.0)
    with pytest.raises(ValueError, match="v_world_com"):
        WalkState(np.zeros(3), [0, np.nan, 0], 0.0, 0.0, np.zeros((4, 3)), np.ones(4, bool), 0.0)
