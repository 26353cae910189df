"""Trotting fast in MuJoCo: above fast_trot_above_mps the planner switches to trot_fast (a longer swing, the swing
feet's limits raised) and back when slowed down; 2.0 m/s forward (from a stand, then stopped at speed), 1.0 m/s
sideways from a stand (trot_fast above 0.6 m/s sideways: the 0.5 s trot fell at 0.7-1.0) and 2 rad/s turning are
tracked."""

from __future__ import annotations

import numpy as np
import pytest

from planning.sim.run import RunOptions, WalkCommand, WalkSession, run_walk

pytestmark = pytest.mark.sim


def test_trots_at_2_mps_forward_from_a_stand_and_stops_at_speed() -> None:
    # from a stand at the joystick's acceleration limit, within 5 % of 2.0 m/s; then a stop asked at speed steps on
    # while the command ramps down (a stop that lifts no foot again at 2 m/s fell)
    sess = WalkSession(WalkCommand(vx=2.0), RunOptions(duration_s=8.0))
    dt = sess.world.dt
    vx = []
    for _ in range(int(5.0 / dt)):
        sess.loop.step()
        s = sess.loop.state
        if s.t >= 2.5:
            vx.append(float((s.R_world_body.T @ s.v_world_body)[0]))
    assert not sess.loop.fell, sess.loop.failure_reason
    assert sess.controller.planner.clock.gait.name == "trot_fast"
    assert abs(np.mean(vx) - 2.0) <= 0.05 * 2.0
    # a stance foot rolling on its sphere at 2 m/s on the default floor is not a slip (planning.handler)
    assert sess.controller.handler.slip_log == [] and sess.controller.handler.friction_scale == 1.0
    sess.controller.planner.stop()
    for _ in range(int(2.5 / dt)):
        sess.loop.step()
    assert not sess.loop.fell, sess.loop.failure_reason
    assert np.linalg.norm(sess.loop.state.v_world_body[:2]) < 0.1
    assert sess.controller.planner.clock.gait.is_stand


def test_slows_from_fast_back_to_the_trot_and_stops() -> None:
    sess = WalkSession(WalkCommand(vx=1.6), RunOptions(duration_s=9.0))
    clock = sess.controller.planner.clock
    swing = sess.controller.handler.swing_planner
    v_slow = swing.params.v_max_xy_mps
    for _ in range(int(3.0 / sess.world.dt)):
        sess.loop.step()
    assert clock.gait.name == "trot_fast" and swing.params.v_max_xy_mps > v_slow
    sess.controller.steer(0.4, 0.0, 0.0)
    for _ in range(int(3.0 / sess.world.dt)):
        sess.loop.step()
    assert clock.gait.name == "trot" and swing.params.v_max_xy_mps == v_slow
    sess.controller.planner.stop()
    for _ in range(int(2.0 / sess.world.dt)):
        sess.loop.step()
    assert not sess.loop.fell, sess.loop.failure_reason
    assert np.linalg.norm(sess.loop.state.v_world_body[:2]) < 0.1


def test_turns_at_2_rad_s() -> None:
    rep = run_walk(WalkCommand(0.0, 0.0, 2.0, settle_s=2.5), RunOptions(duration_s=5.5))
    assert rep["success"] and not rep["fell"], rep["failure_reason"]
    mean = rep["mean_velocity"]
    assert abs(mean["vy"]) <= 0.05
    assert abs(mean["yaw_rate"] - 2.0) <= 0.1 * 2.0


# 1.0 m/s sideways from a stand, left and right, from turned starts, with a little forward speed and yaw rate
# (vx, vy, yaw rate, start x, y, yaw). Measured over 14 such starts: 14 of 14 held, each within 1 % (the 0.5 s trot,
# before trot_fast took the sideways speeds: 3 of 14 at 1.0 m/s, 11 of 14 at 0.9)
_SIDEWAYS_STARTS = (
    (0.0, 1.0, 0.0, (0.0, 0.0, 0.3)),
    (0.0, -1.0, 0.0, (0.5, -0.4, -0.5)),
    (0.2, 1.0, 0.15, (0.0, 0.0, 0.0)),
    (-0.1, -1.0, -0.2, (0.2, 0.3, 1.0)),
)


def test_trots_1_mps_sideways_from_a_stand_in_3_of_4_starts() -> None:
    held = []
    for vx, vy, wz, start in _SIDEWAYS_STARTS:
        rep = run_walk(WalkCommand(vx, vy, wz, settle_s=2.5), RunOptions(duration_s=5.0, start_offset=start))
        mean = rep["mean_velocity"]
        ok = rep["success"] and not rep["fell"] and abs(mean["vy"] - vy) <= 0.1 * abs(vy)
        held.append(ok and abs(mean["vx"] - vx) <= 0.1 and abs(mean["yaw_rate"] - wz) <= 0.1)
    assert sum(held) >= 3, held


def test_sideways_at_1_mps_walks_trot_fast_then_the_trot_and_stops() -> None:
    sess = WalkSession(WalkCommand(0.0, -1.0), RunOptions(duration_s=8.0))
    clock = sess.controller.planner.clock
    for _ in range(int(2.5 / sess.world.dt)):
        sess.loop.step()
    assert clock.gait.name == "trot_fast"
    sess.controller.steer(0.0, 0.2, 0.0)  # slowed below fast_trot_lateral_below_mps: the trot again
    for _ in range(int(2.0 / sess.world.dt)):
        sess.loop.step()
    assert clock.gait.name == "trot"
    sess.controller.planner.stop()
    for _ in range(int(2.0 / sess.world.dt)):
        sess.loop.step()
    assert not sess.loop.fell, sess.loop.failure_reason
    assert clock.gait.is_stand and np.linalg.norm(sess.loop.state.v_world_body[:2]) < 0.1


def test_trots_a_1_m_radius_circle_at_1_5_mps() -> None:
    # turning while moving: the footholds outward of the arc by a/ω² and the centripetal feed-forward keep the body
    # from sliding out of the circle (it fell without them, and with trot_fast's 0.5 s cycle)
    rep = run_walk(WalkCommand(1.5, 0.0, 1.5, settle_s=2.5), RunOptions(duration_s=6.0))
    assert rep["success"] and not rep["fell"], rep["failure_reason"]
    mean = rep["mean_velocity"]
    assert abs(np.hypot(mean["vx"], mean["vy"]) - 1.5) <= 0.05 * 1.5
    assert abs(mean["yaw_rate"] - 1.5) <= 0.05 * 1.5


def test_takes_a_25_ns_sideways_push_while_trotting_at_1_5_mps() -> None:
    from planning.sim.world import Push

    push = Push(3.5, (0.0, 250.0, 0.0), 0.1)  # 25 N·s to the left, mid-run
    rep = run_walk(WalkCommand(1.5, settle_s=2.0), RunOptions(duration_s=5.5, pushes=[push]))
    assert rep["success"] and not rep["fell"], rep["failure_reason"]
    assert abs(rep["mean_velocity"]["vx"] - 1.5) <= 0.1 * 1.5


@pytest.mark.parametrize("gait", ["bound", "gallop"])
def test_bounds_and_gallops_at_1_2_mps(gait: str) -> None:
    # with the fast trot's swing limits (their swings last 0.16 s): both held 0.8 m/s at most before
    rep = run_walk(WalkCommand(1.2, gait=gait, settle_s=2.5), RunOptions(duration_s=5.0))
    assert rep["success"] and not rep["fell"], rep["failure_reason"]
    assert abs(rep["mean_velocity"]["vx"] - 1.2) <= 0.05 * 1.2


def test_switches_trot_bound_gallop_trot_at_1_3_mps() -> None:
    # gait switches at speed, 2.5 s in each gait at 1.3 m/s: the trot at speed is trot_fast; trot_fast -> bound goes
    # through one gallop cycle (straight, it fell at 1.3-1.4 m/s) and a trot asked at speed goes straight to trot_fast
    # (through the slow trot, from a gallop at 1.2 m/s, it fell)
    sess = WalkSession(WalkCommand(vx=1.3), RunOptions(duration_s=12.0))
    steps = int(2.5 / sess.world.dt)
    for gait, clock_gait in (
        ("trot", "trot_fast"),
        ("bound", "bound"),
        ("gallop", "gallop"),
        ("trot", "trot_fast"),
    ):
        sess.controller.set_gait(gait)
        vx = []
        for k in range(steps):
            sess.loop.step()
            if k >= steps - int(1.0 / sess.world.dt):
                s = sess.loop.state
                vx.append(float((s.R_world_body.T @ s.v_world_body)[0]))
        assert not sess.loop.fell, f"fell in {gait}: {sess.loop.failure_reason}"
        assert sess.controller.planner.clock.gait.name == clock_gait
        assert abs(np.mean(vx) - 1.3) <= 0.2 * 1.3, (gait, np.mean(vx))


def test_bounds_at_2_5_mps_from_a_stand() -> None:
    # the bound's 0.32 s cycle, the pair gaits' balance gains (pitch softened, horizontal damping raised) and its
    # footholds behind the neutral points (ReferenceParams.thrust_lead_s): at 0.40 s it fell at 2.5 m/s, and with
    # the default gains it tracked 20 % slow (measured 2.39 m/s)
    rep = run_walk(WalkCommand(2.5, gait="bound", settle_s=3.5), RunOptions(duration_s=5.5))
    assert rep["success"] and not rep["fell"], rep["failure_reason"]
    assert abs(rep["mean_velocity"]["vx"] - 2.5) <= 0.1 * 2.5
    # at this speed all four feet leave the ground for part of the cycle, though the schedule's duty is 0.6
    # (measured: 9.4 % of the time at 2.5 m/s; 1.8-8.9 % at 2.4-2.6 m/s and with 0.1 m/s sideways; 0 at 2.0)
    assert rep["flight_fraction"] > 0.01


def test_gallops_at_2_5_mps_steered_from_a_stand() -> None:
    # the gallop's swing feet allowed 7 m/s across the ground (WalkParams.gait_swing_limits; the fast trot's 6 m/s
    # left them short and late: the gallop ran 2.2-2.3 m/s asked 2.5), steered with a small yaw rate
    # (measured 2.33-2.36 m/s over straight, ±0.2 and 0.4 rad/s and a turned start: 5 of 5 within 7 %)
    rep = run_walk(WalkCommand(2.5, 0.0, 0.2, gait="gallop", settle_s=3.5), RunOptions(duration_s=6.0))
    assert rep["success"] and not rep["fell"], rep["failure_reason"]
    assert abs(rep["mean_velocity"]["vx"] - 2.5) <= 0.1 * 2.5
    assert abs(rep["mean_velocity"]["yaw_rate"] - 0.2) <= 0.1
