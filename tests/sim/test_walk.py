"""Steering mode in MuJoCo: velocity tracking, a square by steering, and capture-point selection under pushes."""

from __future__ import annotations

import numpy as np
import pytest

from planning.sim.run import RunOptions, WalkCommand, WalkSession, run_walk
from planning.sim.world import Push

pytestmark = pytest.mark.sim


@pytest.mark.parametrize(
    ("vx", "vy", "yaw_rate"),
    [(0.5, 0.0, 0.0), (1.0, 0.0, 0.0), (0.0, 0.4, 0.0), (0.0, 0.0, 1.0)],
)
def test_trot_tracks_the_command(vx: float, vy: float, yaw_rate: float) -> None:
    rep = run_walk(WalkCommand(vx, vy, yaw_rate), RunOptions(duration_s=6.0))
    assert rep["success"] and not rep["fell"]
    mean, rms = rep["mean_velocity"], rep["velocity_tracking_rms"]
    # within 5% (or 0.03 m/s, 0.05 rad/s absolute for zero commands) on average, and steady
    assert abs(mean["vx"] - vx) <= max(0.05 * abs(vx), 0.03)
    assert abs(mean["vy"] - vy) <= max(0.05 * abs(vy), 0.03)
    assert abs(mean["yaw_rate"] - yaw_rate) <= max(0.05 * abs(yaw_rate), 0.05)
    assert rms["vx"] < 0.1 and rms["vy"] < 0.1 and rms["yaw_rate"] < 0.15


def test_walks_a_square_by_steering_and_comes_back() -> None:
    sess = WalkSession(WalkCommand(), RunOptions(duration_s=14.0))
    legs = [(0.4, 0.0), (0.0, 0.4), (-0.4, 0.0), (0.0, -0.4)]
    for vx, vy in legs:
        sess.controller.steer(vx, vy, 0.0)
        for _ in range(int(2.5 / sess.world.dt)):
            sess.loop.step()
    sess.controller.steer(0.0, 0.0, 0.0)
    for _ in range(int(2.0 / sess.world.dt)):
        sess.loop.step()
    assert not sess.loop.fell
    p = sess.loop.state.p_world_body
    assert np.hypot(p[0], p[1]) < 0.2
    far = max(np.hypot(*q[:2]) for q in sess.recorder.p_body)
    assert far > 0.9  # it really went round: the square's far corner is ~1.4 m away


def test_walks_to_a_goal() -> None:
    rep = run_walk(WalkCommand(goal=(2.0, 0.5)), RunOptions(duration_s=12.0))
    assert rep["success"], rep["failure_reason"]
    assert rep["final_pose_error"]["position_m"] <= 0.15


def test_capture_point_selection_survives_a_push_the_reference_path_does_not() -> None:
    push = [Push(2.0, (0.0, 400.0, 0.0), 0.1)]  # 40 N·s sideways while trotting at 0.5 m/s
    with_cp = run_walk(WalkCommand(vx=0.5), RunOptions(duration_s=5.0, pushes=push))
    reference = run_walk(
        WalkCommand(vx=0.5, capture_point_selection=False), RunOptions(duration_s=5.0, pushes=push)
    )
    assert with_cp["success"] and not with_cp["fell"]
    assert reference["fell"]


def test_stop_means_a_stable_stand() -> None:
    sess = WalkSession(WalkCommand(vx=0.5), RunOptions(duration_s=6.0))
    for _ in range(int(3.0 / sess.world.dt)):
        sess.loop.step()
    sess.controller.planner.stop()
    for _ in range(int(3.0 / sess.world.dt)):
        sess.loop.step()
    s = sess.loop.state
    assert not sess.loop.fell and s.contact.all()
    assert np.linalg.norm(s.v_world_body[:2]) < 0.05


GAITS = ("trot", "walk", "pace", "bound")


@pytest.mark.parametrize(("first", "then"), [(a, b) for a in GAITS for b in GAITS if a != b])
def test_gaits_walk_and_switch_while_walking(first: str, then: str) -> None:
    sess = WalkSession(WalkCommand(vx=0.3, gait=first), RunOptions(duration_s=8.0))
    x0 = sess.loop.state.p_world_body[0]
    for gait, seconds in ((first, 2.5), (then, 4.0)):
        sess.controller.set_gait(gait)
        for _ in range(int(seconds / sess.world.dt)):
            sess.loop.step()
        assert not sess.loop.fell, f"fell in {gait}: {sess.loop.failure_reason}"
    assert sess.controller.planner.clock.gait.name == then
    assert sess.loop.state.p_world_body[0] - x0 > 1.2  # it kept walking forward through the switch
