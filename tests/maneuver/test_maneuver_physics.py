"""Validation's physics check: the maneuver run closed-loop in MuJoCo, judged against its events.

The shipped library passing it is checked where every shipped maneuver is run anyway (tests/sim/test_library.py,
through the same PhysicsRun). Here: the geometry and the judging on their own, and a family of deliberately broken
edits that pass the rules and the dry solve but fall or are carried by the backup controller in MuJoCo.
"""

from __future__ import annotations

import copy
from typing import Any

import numpy as np
import pytest

from planning.maneuver import find_maneuver, parse_maneuver
from planning.maneuver.load import read_yaml
from planning.maneuver.physics import check_with_physics, judge_physics, signed_distance_to_hull


def test_signed_distance_to_the_support_polygon() -> None:
    square = np.array([[0.3, 0.2], [0.3, -0.2], [-0.3, -0.2], [-0.3, 0.2]])
    assert signed_distance_to_hull(np.array([0.0, 0.0]), square) == pytest.approx(0.2)
    assert signed_distance_to_hull(np.array([0.0, 0.25]), square) == pytest.approx(-0.05)
    assert signed_distance_to_hull(np.array([0.4, 0.3]), square) == pytest.approx(-np.hypot(0.1, 0.1))
    # a diagonal pair (trot) has no inside: on the line is 0, off it negative
    pair = square[[0, 2]]
    assert signed_distance_to_hull(np.array([0.0, 0.0]), pair) == pytest.approx(0.0, abs=1e-12)
    assert signed_distance_to_hull(np.array([0.0, 0.1]), pair) < 0.0
    assert signed_distance_to_hull(np.array([0.1, 0.0]), square[:1]) == pytest.approx(-np.hypot(0.2, 0.2))


def _event(t: float, leg: str, kind: str, path: str, **kw: Any) -> dict[str, Any]:
    row = {"t": t, "leg": leg, "type": kind, "path": path, "explicit": True, "reached": True, "phase": 0,
           "peak_torque_use": 0.5, "peak_torque_joint": f"{leg} knee", "friction_use": 0.3,
           "stability_margin_m": 0.05, "backup_ticks": 0}  # fmt: skip
    if kind == "touchdown":
        row.update(time_window_s=0.05, place_window_m=0.03, timing_error_s=0.01, place_error_m=0.01,
                   within_window=True)  # fmt: skip
    row.update(kw)
    return row


def _report(events: list[dict[str, Any]], **kw: Any) -> dict[str, Any]:
    rep = {"success": True, "fell": False, "fall_time_s": None, "failure_reason": None, "duration_s": 4.0,
           "timing": {"wall_s": 1.0, "rtf": 4.0}, "events": events}  # fmt: skip
    rep.update(kw)
    return rep


def test_a_fall_is_blamed_on_the_last_event_before_it() -> None:
    events = [
        _event(1.0, "FL", "liftoff", "events[0]"),
        _event(1.4, "FL", "touchdown", "events[1]", timing_error_s=0.04),
        _event(1.4, "RR", "touchdown", "events[3]", timing_error_s=0.12),  # same time, worse timing
        _event(3.0, "FR", "liftoff", "events[4]", reached=False),
    ]
    rep = _report(events, success=False, fell=True, fall_time_s=2.2, failure_reason="fell: body dropped")
    failures, _, section = judge_physics(rep)
    assert [p.path for p in failures] == ["events[3]"]
    assert "touchdown of RR at 1.4 s" in failures[0].message and "fell" in failures[0].message
    assert "+120 ms" in failures[0].message  # the numbers measured at that event come with it
    assert section["responsible"]["path"] == "events[3]"
    status = {e["path"]: e["status"] for e in section["events"]}
    assert status == {
        "events[0]": "ok",
        "events[1]": "ok",
        "events[3]": "failure",
        "events[4]": "not reached",
    }


def test_a_missed_window_and_a_carried_run_name_their_event() -> None:
    events = [_event(1.0, "FL", "liftoff", "events[0]"),
              _event(1.4, "FL", "touchdown", "events[1]", within_window=False, timing_error_s=None,
                     place_error_m=None)]  # fmt: skip
    failures, _, _ = judge_physics(_report(events, success=False, failure_reason="touchdown of FL missed"))
    assert [p.path for p in failures] == ["events[1]"]
    events = [_event(1.0, "FL", "liftoff", "gaits[0]", backup_ticks=3),
              _event(1.4, "FL", "touchdown", "gaits[0]", backup_ticks=80, explicit=False)]  # fmt: skip
    reason = "the backup controller drove 9% of the ticks"
    failures, _, section = judge_physics(_report(events, success=False, failure_reason=reason))
    assert len(failures) == 1 and "touchdown of FL at 1.4 s" in failures[0].message
    assert section["responsible"]["t"] == 1.4


def test_margins_grade_the_marks_and_warn_on_explicit_events_only() -> None:
    events = [
        _event(1.0, "FL", "liftoff", "events[0]", peak_torque_use=0.97, phase=0),
        _event(1.0, "FR", "liftoff", "events[1]", peak_torque_use=0.97, phase=0),  # same phase: one warning
        _event(2.0, "RL", "liftoff", "gaits[0]", friction_use=1.2, explicit=False, phase=1),
        _event(2.4, "RL", "touchdown", "events[2]", timing_error_s=0.02, phase=2),
    ]
    failures, warnings, section = judge_physics(_report(events))
    assert failures == [] and section["success"] and section["ran"]
    margins = {e["path"]: e["margin"] for e in section["events"]}
    assert margins["events[0]"] == pytest.approx(0.03) and margins["gaits[0]"] == pytest.approx(-0.2)
    assert margins["events[2]"] == pytest.approx(min(0.5, 1 - 0.02 / 0.15, 1 - 0.01 / 0.11), abs=1e-3)
    assert [w.path for w in warnings] == ["events[0]"] and "97%" in warnings[0].message


def test_a_report_without_margins_is_judged_by_its_verdict() -> None:
    """A run report from another runner (no "events"): its success or its reason, with no event named."""
    assert judge_physics({"success": True})[0] == []
    failures, _, section = judge_physics({"success": False, "failure_reason": "final pose off by 0.3 m"})
    assert [p.path for p in failures] == ["body"] and section["events"] == []


def _doc(name: str) -> dict[str, Any]:
    return dict(read_yaml(find_maneuver(name).read_text())[0])


def _broken_edits() -> list[tuple[str, dict[str, Any], str]]:
    """(what, document, the path the failure must name): each passes the rules and the dry solve."""
    out = []
    for k, leg in ((4, "FL"), (5, "FR")):  # the edit: one front touchdown 1.42 → 1.55 s
        d = _doc("jump")
        d["events"][k]["t"] = 1.55
        out.append((f"jump, {leg} touchdown at 1.55 s", d, f"events[{k}]"))
    d = _doc("walk-forward")
    d["gaits"][0]["step"] = [0.5, 0.0, 0.0]  # 50 cm per trot cycle
    out.append(("walk-forward with 50 cm steps", d, "gaits[0]"))
    d = _doc("walk-forward")
    d["gaits"][0]["step"] = [0.1, 0.0, 60.0]  # a 60° turn per cycle
    out.append(("walk-forward turning 60° a cycle", d, "gaits[0]"))
    return out


@pytest.mark.sim
def test_broken_edits_fail_validation_on_the_event_responsible(robot) -> None:
    """Measured: all 4 fail (the jumps carried by the backup controller after the late touchdown, the long steps
    too, the fast turn falls), each run 2-5 s of CPU (stopped once the failure is certain). At least 3 of 4."""
    caught, why = 0, []
    for what, doc, path in _broken_edits():
        result = check_with_physics(parse_maneuver(copy.deepcopy(doc)), robot)
        physics = result.physics or {}
        assert physics.get("ran"), (what, physics)
        named = [p.path for p in result.failures]
        if not result.ok and named == [path] and physics["responsible"]["path"] == path:
            caught += 1
            marks = [e for e in physics["events"] if e["status"] == "failure"]
            assert len(marks) == 1 and marks[0]["path"] == path
        why.append((what, result.ok, named, physics.get("failure_reason")))
    assert caught >= 3, why
