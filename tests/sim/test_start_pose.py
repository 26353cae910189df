"""Closed loop in MuJoCo: a maneuver started away from the origin (a start position and yaw) runs in its start
frame: its keyframes and footholds move and turn with the start pose."""

from __future__ import annotations

import numpy as np
import pytest

from planning.geometry import rpy_to_R
from planning.maneuver import find_maneuver, load_maneuver
from planning.maneuver.frame import PlanFrame
from planning.sim.run import ManeuverSession, RunOptions

pytestmark = pytest.mark.sim

# (x m, y m, yaw rad): both signs, a quarter turn and nearly a half turn
START_POSES = [(0.3, -0.2, 0.5), (-0.5, 0.1, -0.9), (0.1, 0.4, 1.6), (0.0, -0.3, 3.0)]


def test_plan_frame_maps_points_vectors_and_rotations() -> None:
    f = PlanFrame(1.0, 2.0, 0.1, np.pi / 2)
    assert np.allclose(f.point(np.array([1.0, 0.0, 0.5])), [1.0, 3.0, 0.6])
    assert np.allclose(f.vector(np.array([1.0, 0.0, 0.0])), [0.0, 1.0, 0.0])
    assert np.allclose(f.xy(np.array([[0.0, 1.0]])), [[0.0, 2.0]])
    assert np.allclose(f.rotation(np.eye(3)) @ [1.0, 0.0, 0.0], [0.0, 1.0, 0.0])


def _session(name: str, start: tuple[float, float, float], duration_s: float) -> ManeuverSession:
    return ManeuverSession(
        load_maneuver(find_maneuver(name)), RunOptions(start_offset=start, duration_s=duration_s)
    )


def test_stand_and_jump_from_start_poses_off_the_origin() -> None:
    ok = 0
    for k, start in enumerate(START_POSES):
        name, dur = ("jump", 3.5) if k % 2 else ("stand", 1.5)
        rep = _session(name, start, dur).run()
        x, y, yaw = start
        good = rep["success"] and not rep["fell"] and rep["final_pose_error"]["position_m"] < 0.03
        if name == "jump":
            # the four touchdowns matched the footholds turned and moved with the start pose
            good = good and len(rep["touchdowns"]) == 4 and rep["foot_placement_error_m"]["max"] < 0.05
        ok += bool(good)
    assert ok >= 3, f"{ok} of {len(START_POSES)} runs from off-origin start poses succeeded"


def test_bow_pitches_about_the_start_heading() -> None:
    # at 2.5 s the bow holds 18° nose-down: about the body's own y axis, whatever the start yaw (untransformed,
    # a quarter turn would make it a roll)
    ok = 0
    for start in START_POSES[1:3]:
        sess = _session("bow", start, 2.5)
        rep = sess.run()
        R_want = rpy_to_R(np.array([0.0, 0.0, start[2]])) @ rpy_to_R(np.radians([0.0, 18.0, 0.0]))
        R_err = R_want.T @ sess.loop.state.R_world_body
        angle = float(np.arccos(np.clip((np.trace(R_err) - 1.0) / 2.0, -1.0, 1.0)))
        ok += bool(rep["success"] and angle < np.radians(4.0))
    assert ok == 2
