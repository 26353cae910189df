"""Closed loop in MuJoCo: the balance controller stands, survives a 15 N·s push, and a knock-over is a fall."""

from __future__ import annotations

import pytest

from planning.maneuver import find_maneuver, load_maneuver
from planning.sim.run import RunOptions, run_maneuver
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


def test_runs_are_deterministic() -> None:
    a = _run("look-around", duration_s=2.0)
    b = _run("look-around", duration_s=2.0)
    assert a["final_pose_error"] == b["final_pose_error"]
    assert a["max_horizontal_drift_m"] == b["max_horizontal_drift_m"]
