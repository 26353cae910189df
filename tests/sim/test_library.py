"""Every shipped maneuver runs in MuJoCo to success, and does what its name says."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
import pytest

from planning.maneuver import SHIPPED_LIBRARY, find_maneuver, load_maneuver
from planning.maneuver.physics import PhysicsRun, judge_physics
from planning.sim.run import ManeuverSession, RunOptions

pytestmark = pytest.mark.sim

Check = Callable[[dict[str, Any], ManeuverSession], None]


def _unwrapped_yaw(sess: ManeuverSession) -> np.ndarray:
    return np.unwrap(np.array([r[2] for r in sess.recorder.rpy_body]))


def _tracks_reference(rep: dict[str, Any], sess: ManeuverSession, tol_m: float = 0.04) -> None:
    rec = sess.recorder
    err = [np.linalg.norm(rec.p_body[i] - sess.body_ref.sample(t)[0]) for i, t in enumerate(rec.t)]
    assert max(err) < tol_m


def _bow(rep: dict[str, Any], sess: ManeuverSession) -> None:
    i = int(np.argmin(np.abs(np.array(sess.recorder.t) - 3.0)))
    assert sess.recorder.rpy_body[i][1] > np.radians(14) and sess.recorder.p_body[i][2] < 0.48
    _tracks_reference(rep, sess)


def _crouch(rep: dict[str, Any], sess: ManeuverSession) -> None:
    assert min(p[2] for p in sess.recorder.p_body) < 0.44
    _tracks_reference(rep, sess)


def _look_around(rep: dict[str, Any], sess: ManeuverSession) -> None:
    assert max(abs(r[2]) for r in sess.recorder.rpy_body) > np.radians(12)
    _tracks_reference(rep, sess)


def _feet_down(rep: dict[str, Any], sess: ManeuverSession) -> None:
    assert rep["touchdowns"] == [] and rep["max_foot_slip_m"] < 0.02
    _tracks_reference(rep, sess)


def _steps(n: int) -> Check:
    def check(rep: dict[str, Any], sess: ManeuverSession) -> None:
        assert len(rep["touchdowns"]) >= n
        assert rep["foot_placement_error_m"]["max"] < 0.06

    return check


def _walked(dx: float, dy: float) -> Check:
    def check(rep: dict[str, Any], sess: ManeuverSession) -> None:
        p = sess.loop.state.p_world_body
        assert abs(p[0] - dx) < 0.05 and abs(p[1] - dy) < 0.05

    return check


def _turned(angle_deg: float) -> Check:
    def check(rep: dict[str, Any], sess: ManeuverSession) -> None:
        yaw = _unwrapped_yaw(sess)
        assert abs(np.degrees(yaw[-1] - yaw[0]) - angle_deg) < 8.0

    return check


def _airborne(seconds: float) -> Check:
    def check(rep: dict[str, Any], sess: ManeuverSession) -> None:
        assert rep["airborne_s"] >= seconds  # all four feet off the ground at once, for this long in all

    return check


def _all(*checks: Check) -> Check:
    def check(rep: dict[str, Any], sess: ManeuverSession) -> None:
        for c in checks:
            c(rep, sess)

    return check


def _waved(rep: dict[str, Any], sess: ManeuverSession) -> None:
    assert len(rep["waypoints"]) >= 4 and max(w["error_m"] for w in rep["waypoints"]) < 0.02


def _rear_lifted(rep: dict[str, Any], sess: ManeuverSession) -> None:
    legs = {t["leg"] for t in rep["touchdowns"]}
    assert legs == {"RL", "RR"}  # only the rear pair left the ground, and it came back


def _danced(rep: dict[str, Any], sess: ManeuverSession) -> None:
    assert rep["duration_s"] >= 20.0 and sess.maneuver.hints
    assert rep["airborne_s"] > 0.2 and len(rep["touchdowns"]) > 60 and len(rep["waypoints"]) == 4


CHECKS: dict[str, Check] = {
    "stand": _feet_down,
    "bow": _bow,
    "crouch": _crouch,
    "look-around": _look_around,
    "sit-and-stand": _feet_down,
    "head-bob": _feet_down,
    "step-in-place": _steps(4),
    "trot-in-place": _steps(30),
    "walk-forward": _walked(1.0, 0.0),
    "side-step": _walked(0.0, 0.30),
    "turn-in-place": _turned(90.0),
    "spin": _turned(360.0),
    "jump": _airborne(0.12),
    "pronk": _airborne(0.5),
    "pronk-forward": _all(_airborne(0.5), _walked(1.5, 0.0)),
    "bound": _walked(0.6, 0.0),
    "leg-wave": _waved,
    "front-stand": _rear_lifted,
    "dance": _danced,
}

SHIPPED = sorted(p.stem for p in SHIPPED_LIBRARY.glob("*.yaml"))


def test_every_shipped_maneuver_has_a_check() -> None:
    assert sorted(CHECKS) == SHIPPED


@pytest.mark.parametrize("name", SHIPPED)
def test_shipped_maneuver_succeeds_in_mujoco(name: str) -> None:
    """Run through validation's physics check (the same run, measured per event): it passes, and so does the run."""
    check = PhysicsRun(load_maneuver(find_maneuver(name)), RunOptions())
    sess, rep = check.session, check.run()
    failures, _, physics = judge_physics(rep)
    assert failures == [] and physics["success"] and not physics["stopped_early"], failures
    assert len(physics["events"]) == 2 * len(rep["touchdowns"])  # every event measured
    assert rep["success"], rep["failure_reason"]
    assert not rep["fell"]
    assert rep["solver"]["fallback_ticks"] <= 0.1 * rep["solver"]["balance_ticks"]
    CHECKS[name](rep, sess)


def test_the_smaller_robot_runs_the_same_stack() -> None:
    """Nothing is tied to one robot: the Go1-sized description trots in place through the same code."""
    sess = ManeuverSession(load_maneuver(find_maneuver("trot-in-place")), RunOptions(robot="go1"))
    rep = sess.run()
    assert rep["success"] and rep["robot"] == "go1"
    assert (
        len(rep["touchdowns"]) >= 30
        and rep["solver"]["fallback_ticks"] <= 0.1 * rep["solver"]["balance_ticks"]
    )
