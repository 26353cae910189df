"""Issue 24 for maneuvers: every problem in one pass, events in any order, sane ranges, and a run the backup
controller carried is no success."""

from __future__ import annotations

import pytest

from planning.maneuver import validate_maneuver

FOUR_PROBLEMS = """\
format: footfall/maneuver@1
name: four-problems
duration: 3.0
events:
  - {t: 0.5, leg: FX, type: liftoff}
  - {t: .nan, leg: FL, type: liftoff}
  - {t: 1.0, leg: FL, type: touchdown}
  - {t: 2.0, leg: RR, type: liftoff}
  - {t: 1.5, leg: RR, type: touchdown}
  - {t: 3.5, leg: RL, type: liftoff}
  - {t: 3.8, leg: RL, type: touchdown}
"""


def test_every_problem_in_one_pass(robot) -> None:
    r = validate_maneuver(FOUR_PROBLEMS, robot)
    got = {p.path: (p.line, p.message) for p in r.failures}
    assert got["events[0].leg"][1].startswith("unknown leg")
    assert got["events[1].t"][1].startswith("must be a finite number")
    assert got["events[4].t"] == (9, "touchdown of RR at 1.5 s comes before its liftoff at 2 s")
    assert got["events[5].t"][0] == 10 and "after the end of the maneuver" in got["events[5].t"][1]
    # the FL touchdown lost its liftoff to the NaN: no made-up "touchdown while on the ground" for it
    assert len(r.failures) == 5, [p.located() for p in r.failures]


def test_events_need_not_be_listed_in_time_order(robot, mk) -> None:
    steps = [
        {"t": 2.0, "leg": "RR", "type": "liftoff"},
        {"t": 2.5, "leg": "RR", "type": "touchdown", "offset": [0.05, 0.0]},
        {"t": 1.0, "leg": "FL", "type": "liftoff"},
        {"t": 1.5, "leg": "FL", "type": "touchdown", "offset": [0.05, 0.0]},
    ]
    shuffled = validate_maneuver(mk(events=steps), robot)
    listed = validate_maneuver(mk(events=steps[2:] + steps[:2]), robot)
    assert shuffled.ok and listed.ok, [str(p) for p in shuffled.failures]
    assert shuffled.schedule is not None and listed.schedule is not None
    assert [(e.t, e.leg) for e in shuffled.schedule.events()] == [
        (e.t, e.leg) for e in listed.schedule.events()
    ]


@pytest.mark.parametrize(
    ("fields", "path", "text"),
    [
        ({"weights": {"pose": 1e308}}, "weights.pose", "must be at most 1000"),
        ({"weights": {"force": 5000}}, "weights.force", "must be at most 1000"),
        ({"body": [{"t": 1.0, "position": [0, 0, 0.5], "weight": 1e9}]}, "body[0].weight", "at most 1000"),
        ({"body": [{"t": 1.0, "position": [1e300, 0, 0.5]}]}, "body[0].position[0]", "at most 1000"),
        (
            {
                "events": [
                    {"t": 1.0, "leg": "FL", "type": "liftoff"},
                    {"t": 1.5, "leg": "FL", "type": "touchdown", "normal": [0, 0.2, -1]},
                ]
            },  # fmt: skip
            "events[1].normal",
            "points downward",
        ),
    ],
)
def test_numbers_out_of_their_range_are_refused(robot, mk, fields: dict, path: str, text: str) -> None:
    r = validate_maneuver(mk(**fields), robot)
    assert not r.ok
    got = {p.path: p.message for p in r.failures}
    assert path in got and text in got[path], got


def test_a_run_the_backup_controller_carried_is_no_success(monkeypatch) -> None:
    """The solver's plans are never fresh (as when it fails every tick): the balance QP stands the robot up the
    whole time, the robot does not fall, and the report says the maneuver was not carried out."""
    from planning.centroidal.driver import SolverDriver
    from planning.maneuver import find_maneuver, load_maneuver
    from planning.sim.run import MAX_BACKUP_SHARE, RunOptions, backup_share, run_maneuver

    stand = load_maneuver(find_maneuver("stand"))
    ok = run_maneuver(stand, RunOptions(duration_s=0.6))
    assert ok["success"] and backup_share(ok["solver"]) <= MAX_BACKUP_SHARE, ok["failure_reason"]

    init = SolverDriver.__init__

    def never_fresh(self: SolverDriver, *a: object, **k: object) -> None:
        init(self, *a, **k)  # type: ignore[arg-type]
        self.max_age_s = -1.0

    monkeypatch.setattr(SolverDriver, "__init__", never_fresh)
    carried = run_maneuver(stand, RunOptions(duration_s=0.6))
    assert not carried["success"] and backup_share(carried["solver"]) == 1.0
    assert carried["failure_reason"].startswith("the backup controller drove 100% of the ticks")


def test_check_maneuver_solves_a_document_once_per_robot(robot, mk, monkeypatch) -> None:
    """The one validation caches by content (not by name) and per robot: validate, save, run solve once."""
    import planning.maneuver.drysolve as drysolve
    from planning.maneuver import check_maneuver, parse_maneuver
    from planning.robot import load_robot

    calls = []
    real = drysolve.dry_solve
    monkeypatch.setattr(drysolve, "dry_solve", lambda *a, **k: calls.append(1) or real(*a, **k))
    doc = mk(duration=1.3, body=[{"t": 1.2, "position": [0.01, 0, 0.52]}])
    first = check_maneuver(parse_maneuver(doc), robot)
    again = check_maneuver(parse_maneuver({**doc, "name": "other-name"}), robot)
    assert first.ok and again.ok and len(calls) == 1
    assert again.maneuver is not None and again.maneuver.name == "other-name"
    check_maneuver(parse_maneuver(doc), load_robot("spot"))  # another robot object: its own solve
    assert len(calls) == 2
