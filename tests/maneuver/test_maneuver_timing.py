"""Timing adjustment on a maneuver: a touchdown planned too early for the body to get within reach succeeds when
the solver may land it later (and costs clearly more, or fails, when it may not); the dry solve of `footfall validate`
names the events it moved and fails what no adjustment can save."""

from __future__ import annotations

import math

from planning.centroidal.problem import BodyState
from planning.centroidal.solver import CentroidalParams, CentroidalSolver
from planning.geometry import rpy_to_R
from planning.maneuver import BodyReference, build_schedule, parse_maneuver, validate_maneuver
from planning.maneuver.generator import ProblemGenerator
from planning.robot import load_robot

ROBOT = load_robot("spot")


def _long_reach(adjust_s: float) -> dict:
    """FL reaches 0.70 m ahead of where it stood, planned to land at 0.75 s: the body cannot get close enough by
    then (the leg would have to be longer than it is); a later touchdown makes it work. (At 0.65 m the body just
    makes it at 0.75 s, and with the generator's timing weight landing 0.1 s later costs more than that.)"""
    return {
        "format": "footfall/maneuver@1",
        "name": "long-reach",
        "duration": 3.0,
        "events": [
            {"t": 0.3, "leg": "FL", "type": "liftoff"},
            {
                "t": 0.75,
                "leg": "FL",
                "type": "touchdown",
                "at": [1.0, 0.165, 0.0],
                "adjust": {"time": adjust_s},
            },
        ],
        "body": [{"t": 2.0, "position": [0.25, 0.0, 0.5], "rpy": [0, 0, 0], "weight": 5.0}],
    }


def _solve(m_dict: dict, timing: bool):
    m = parse_maneuver(m_dict)
    sch = build_schedule(m, ROBOT)
    body = BodyReference.from_maneuver(m, ROBOT, sch)
    gen = ProblemGenerator(m, sch, body, ROBOT)
    p, v, rpy, w = body.sample(0.5)
    R = rpy_to_R(rpy)
    state = BodyState(0.5, p + R @ gen.model.p_body_com, v, R, w)
    solver = CentroidalSolver(
        CentroidalParams(timing_adjustment=timing, time_budget_ms=math.inf), robot=ROBOT
    )
    sol = solver.solve(gen.problem_at(state))
    for _ in range(3):  # real-time iterations on the same state converge the linearization
        sol = solver.solve(gen.problem_at(state))
    return sol


def test_timing_adjustment_rescues_an_early_touchdown() -> None:
    m = _long_reach(0.4)
    on = _solve(m, timing=True)
    off = _solve(m, timing=False)
    assert on.ok
    moved = [td for td in on.touchdowns if not td.planted]
    assert moved and all(td.t > td.t_nominal + 0.05 for td in moved)  # the solver lands later
    assert (not off.ok) or off.cost > 2.0 * on.cost


def test_dry_solve_names_the_moved_touchdowns() -> None:
    # lifted at once and planned to land soon: from a stand the body cannot get there in time, so the first dry
    # tick already moves the touchdown later
    m = _long_reach(0.24)
    m["events"][0]["t"] = 0.05
    m["events"][1]["t"] = 0.3
    res = validate_maneuver(m, ROBOT, dry_solve=True)
    assert res.ok, res.failures
    moved = [w for w in res.warnings if "the solver moves the touchdown" in w.message]
    assert [w.path for w in moved] == ["events[1]"]


def test_dry_solve_fails_what_no_adjustment_can_save() -> None:
    res = validate_maneuver(_long_reach(0.0), ROBOT, dry_solve=True)
    assert not res.ok
    assert any(f.path == "events[1]" and "out of reach" in f.message for f in res.failures)


def test_dry_solve_keeps_an_ordinary_maneuver_quiet() -> None:
    from planning.maneuver import find_maneuver, load_maneuver

    res = validate_maneuver(load_maneuver(find_maneuver("walk-forward")), ROBOT, dry_solve=True)
    assert res.ok and not [w for w in res.warnings if "solver" in w.message]
