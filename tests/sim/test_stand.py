"""Closed loop in MuJoCo: the balance controller stands, survives a 15 N·s push, and a knock-over is a fall."""

from __future__ import annotations

import numpy as np
import pytest

from planning.maneuver import find_maneuver, load_maneuver
from planning.sim.run import ManeuverSession, RunOptions, run_maneuver
from planning.sim.world import Push

pytestmark = pytest.mark.sim


def _run(name: str, **kw):
    return run_maneuver(load_maneuver(find_maneuver(name)), RunOptions(**kw))


def test_stands_ten_seconds_without_drifting() -> None:
    rep = _run("stand", duration_s=10.0)
    assert rep["success"] and not rep["fell"]
    assert rep["max_horizontal_drift_m"] <= 0.02
    assert rep["final_pose_error"]["position_m"] <= 0.02


def test_survives_a_15_ns_lateral_push_without_stepping() -> None:
    rep = _run("stand", pushes=[Push(1.0, (0.0, 150.0, 0.0), 0.1)], duration_s=4.0)
    assert not rep["fell"] and rep["success"]
    assert rep["touchdowns"] == []  # no foot left the ground: no step was taken
    assert rep["max_foot_slip_m"] < 0.02
    assert rep["final_pose_error"]["position_m"] < 0.02  # back where it stood


def test_a_huge_push_is_detected_as_a_fall() -> None:
    rep = _run("stand", pushes=[Push(0.5, (0.0, 3000.0, 0.0), 0.1)], duration_s=3.0)
    assert rep["fell"] and not rep["success"]
    assert 0.5 < rep["fall_time_s"] < 3.0
    assert rep["failure_reason"].startswith("fell:")


@pytest.mark.parametrize(
    ("name", "t", "check"),
    [
        ("bow", 3.0, lambda rpy, p: rpy[1] > np.radians(14) and p[2] < 0.48),  # nose down and lower
        ("crouch", None, lambda rpy, p: p[2] < 0.44),  # lowered at some point
        ("look-around", None, lambda rpy, p: abs(rpy[2]) > np.radians(12)),  # looked sideways
    ],
)
def test_body_keyframe_maneuvers_track_their_keyframes(name, t, check) -> None:
    sess = ManeuverSession(load_maneuver(find_maneuver(name)), RunOptions())
    rep = sess.run()
    assert rep["success"], rep["failure_reason"]
    rec = sess.recorder
    times = np.array(rec.t)
    idx = [int(np.argmin(np.abs(times - t)))] if t is not None else range(len(times))
    assert any(check(rec.rpy_body[i], rec.p_body[i]) for i in idx)
    # tracking: the body follows its reference within a few centimeters throughout
    errs = [np.linalg.norm(rec.p_body[i] - sess.body_ref.sample(rec.t[i])[0]) for i in range(len(times))]
    assert max(errs) < 0.03


def test_runs_are_deterministic() -> None:
    a = _run("look-around", duration_s=2.0)
    b = _run("look-around", duration_s=2.0)
    assert a["final_pose_error"] == b["final_pose_error"]
    assert a["max_horizontal_drift_m"] == b["max_horizontal_drift_m"]
