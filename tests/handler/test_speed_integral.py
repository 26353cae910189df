"""The forward speed integral of steering mode (WalkParams.speed_integral_*): it integrates a steady lag along the
command, stays bounded, leaks, and drops when the stride-averaged velocity error says a push is being rejected.
Fed synthetic states (no simulation)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from planning.robot import load_robot
from planning.sim.world import RobotState
from planning.steps.gait import GaitClock
from planning.walk import WalkController, WalkParams

DT = 0.004  # the balance stage's tick, s
V = np.array([2.5, 0.0, 0.0])  # the target's velocity, world (heading along x)
V_CMD = V[:2].copy()


def _controller(**kw: object) -> WalkController:
    params = replace(
        WalkParams(),
        speed_integral_gaits=("gallop",),
        speed_integral_filter_s=0.3,
        speed_integral_disturbed_any_axis=True,
        speed_integral_disturbed_mps=0.25,
        **kw,  # type: ignore[arg-type]
    )
    ctl = WalkController(load_robot("spot"), params, gait="gallop")
    ctl.planner.clock = GaitClock("gallop")
    return ctl


def _run(ctl: WalkController, s: RobotState, v_body: tuple[float, float], t0: float, t1: float) -> float:
    s.v_world_body[:] = (*v_body, 0.0)
    t = t0
    while t < t1:
        t += DT
        s.t = t
        ctl._speed_integral(s, V, V_CMD, DT)
    return t


def test_integrates_a_steady_lag_and_stays_bounded() -> None:
    ctl = _controller(speed_integral_ki=4.0, speed_integral_max_mps2=2.0)
    s = RobotState()
    _run(ctl, s, (2.4, 0.0), 0.0, 1.0)  # 0.1 m/s slow
    a1 = ctl._a_ff_along
    assert 0.1 < a1 < 0.4  # ~ki · 0.1 · (1 s − the hold and the filter's rise)
    _run(ctl, s, (2.0, 0.0), 1.0, 3.0)  # 0.5 m/s slow: above the disturbance threshold, so it drops
    assert ctl._a_ff_along < 0.1 * a1
    _run(ctl, s, (2.3, 0.0), 3.0, 10.0)  # a long steady lag: bounded
    assert ctl._a_ff_along <= 2.0 + 1e-9
    assert np.allclose(ctl._a_ff, [ctl._a_ff_along, 0.0])  # along the command


def test_drops_while_pushed_sideways() -> None:
    ctl = _controller()
    s = RobotState()
    t = _run(ctl, s, (2.4, 0.0), 0.0, 1.5)
    a1 = ctl._a_ff_along
    assert a1 > 0.1
    # a push: 0.5 m/s sideways for 0.4 s; the stride-averaged error crosses 0.25 m/s within ~0.2 s
    t = _run(ctl, s, (2.4, 0.5), t, t + 0.4)
    assert ctl._a_ff_along < 0.2 * a1
    # the in-stride swing of a gallop (±0.15 m/s sideways at the stride's rate) does not count as a push
    ctl2 = _controller()
    s2 = RobotState()
    t2 = 0.0
    for k in range(40):  # 40 half strides of 0.15 s
        t2 = _run(ctl2, s2, (2.4, 0.15 if k % 2 else -0.15), t2, t2 + 0.15)
    assert ctl2._a_ff_along > 0.5


def test_leaks_when_the_lag_is_gone() -> None:
    ctl = _controller(speed_integral_leak_s=1.0)
    s = RobotState()
    t = _run(ctl, s, (2.4, 0.0), 0.0, 2.0)
    a1 = ctl._a_ff_along
    assert a1 > 0.1
    _run(ctl, s, (2.5, 0.0), t, t + 3.0)  # on speed: nothing to integrate, the leak takes it down
    assert ctl._a_ff_along < 0.1 * a1
