"""The body waits for its feet (SupportShiftParams.hold_body): while the walk controller holds the gait clock for a
crawl liftoff that waits for static balance (hold_clock), the body target does not advance along the command; with
the option off, or when no liftoff waits, it advances as before. Fed synthetic states (no simulation)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from planning.robot import load_robot
from planning.sim.world import RobotState
from planning.steps.gait import GaitClock
from planning.steps.steering import SteeringCommand
from planning.steps.support import SupportShiftParams
from planning.walk import WalkController, WalkParams

DT = 0.004  # the balance stage's tick, s
CMD = SteeringCommand(vx=0.2, vy=0.05, yaw_rate=0.1)


def _controller(hold_body: bool, for_com: bool = False) -> WalkController:
    sp = SupportShiftParams(hold=True, hold_clock=True, hold_body=hold_body, hold_body_for_com=for_com)
    ctl = WalkController(load_robot("spot"), replace(WalkParams(), support=sp), gait="crawl")
    ctl.planner.clock = GaitClock("crawl")
    ctl.planner.steering.reset(CMD)
    ctl.handler.support_hold = sp
    return ctl


def _ticks(
    ctl: WalkController, s: RobotState, n: int, held: bool, for_load: bool = True
) -> list[tuple[np.ndarray, float]]:
    """n balance ticks with a liftoff waiting for balance (held; for a foot's load, or only for the centre of
    mass) or not; the body target's (position, yaw) after each."""
    out = []
    for _ in range(n):
        s.t += DT
        ctl.handler.support_held = held
        ctl.handler.support_held_for_load = held and for_load
        ctl._hold_clock_for_support(s)
        ctl._update_target(s)
        out.append((ctl.target.p_world_body.copy(), ctl._yaw_des))
    return out


def _state() -> RobotState:
    s = RobotState()
    s.t = 0.0
    return s


def test_the_body_target_stands_while_the_clock_is_held_for_a_foots_load() -> None:
    ctl = _controller(hold_body=True)
    s = _state()
    before = _ticks(ctl, s, 5, held=False)
    assert before[-1][0][0] > before[0][0][0]  # walking: the target advances along the command
    held = _ticks(ctl, s, 10, held=True)
    for p, yaw in held:
        assert np.allclose(p, before[-1][0]) and yaw == before[-1][1]
    assert np.allclose(ctl.target.v_world_body, 0.0) and ctl.target.omega_world[2] == 0.0
    # the clock's hold is spent after max_hold_s: the body goes on with it, even if the liftoff still waits
    n_more = int(np.ceil(ctl.params.support.max_hold_s / DT))
    after = _ticks(ctl, s, n_more, held=True)
    assert after[-1][0][0] > before[-1][0][0]
    assert ctl.target.v_world_body[0] > 0.0


def test_off_the_body_target_goes_on_while_the_clock_is_held() -> None:
    on, off = _controller(hold_body=True), _controller(hold_body=False)
    s_on, s_off = _state(), _state()
    _ticks(on, s_on, 5, held=False)
    _ticks(off, s_off, 5, held=False)
    assert np.allclose(on.target.p_world_body, off.target.p_world_body)  # the same while nothing waits
    p0 = off.target.p_world_body.copy()
    phase_before = off.planner.clock.phase(s_off.t)
    held = _ticks(off, s_off, 10, held=True)
    assert held[-1][0][0] > p0[0]  # off: the target goes on
    assert off.target.v_world_body[0] > 0.0
    # ... while the clock is held all the same (its phase stands)
    assert abs(off.planner.clock.phase(s_off.t) - phase_before) < 1e-9


def test_a_hold_for_the_centre_of_mass_only_lets_the_body_go_on_unless_asked() -> None:
    """The body's motion is what carries the centre of mass into the support triangle: it goes on (by default)."""
    for for_com, stands in ((False, False), (True, True)):
        ctl = _controller(hold_body=True, for_com=for_com)
        s = _state()
        before = _ticks(ctl, s, 5, held=False)
        held = _ticks(ctl, s, 10, held=True, for_load=False)
        assert np.allclose(held[-1][0], before[-1][0]) == stands


def test_the_terrain_asks_the_crawls_liftoff_hold_for_the_tick() -> None:
    """TerrainDecision.support_hold (DecisionParams.hold_region_m2): with the controller's own hold off, the crawl's
    liftoffs get the hold while the terrain asks it and lose it when it does not; the walk gait never."""
    ctl = WalkController(load_robot("spot"), WalkParams(), gait="crawl")
    ctl.planner.clock = GaitClock("crawl")
    s = _state()
    p = np.zeros(3)
    ctl._support_shift(s, p)
    assert ctl.handler.support_hold is not None and not ctl.handler.support_hold.hold
    ctl._terrain_hold = True
    ctl._support_shift(s, p)
    first = ctl.handler.support_hold
    assert first is not None and first.hold and not ctl.params.support.hold
    ctl._support_shift(s, p)
    assert ctl.handler.support_hold is first  # made once, not every tick
    ctl._terrain_hold = False
    ctl._support_shift(s, p)
    assert ctl.handler.support_hold is not None and not ctl.handler.support_hold.hold
    ctl.planner.clock = GaitClock("walk")
    ctl._terrain_hold = True
    ctl._support_shift(s, p)
    assert ctl.handler.support_hold is None
