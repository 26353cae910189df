"""Loading: YAML text, files and dicts; every shape problem at once, as plain field paths and reasons."""

from __future__ import annotations

from pathlib import Path

import pytest

from planning.maneuver import Liftoff, ManeuverError, Touchdown, load_maneuver, parse_maneuver


def _problems(source) -> dict[str, str]:
    with pytest.raises(ManeuverError) as e:
        load_maneuver(source)
    assert all(p.severity == "failure" for p in e.value.problems)
    return {p.path: p.message for p in e.value.problems}


def test_contract_example_parses() -> None:
    text = """
format: footfall/maneuver@1
name: reach-and-lean
title: Reach and lean
duration: 4.0
start: stand
tracks: [legs, body]
friction: 0.6
events:
  - {t: 0.8, leg: RL, type: liftoff}
  - {t: 1.4, leg: RL, type: touchdown, at: [-0.40, 0.17, 0.0], normal: [0, 0, 1], adjust: {time: 0.10, radius: 0.06}}
  - {t: 2.0, leg: FL, type: liftoff}
  - {t: 2.4, leg: FL, type: touchdown, offset: [0.15, 0.0]}
gaits:
  - {gait: trot, from: 1.0, to: 3.0, cycle: 0.5, duty: 0.6, step: [0.10, 0.0, 0.0]}
body:
  - {t: 2.0, position: [0.10, 0.0, 0.55], rpy: [0, -15, 0], weight: 1.0}
  - {t: 4.0, position: [0.00, 0.0, 0.50], rpy: [0, 0, 0], weight: 5.0}
weights: {force: 1e-4, pose: 1.0, touchdown_time: 1.0, touchdown_position: 10.0, hip_over_foot: 0.1}
objectives:
  - {type: maximize_height, t: [1.0, 1.2], weight: 2.0}
"""
    m = load_maneuver(text)
    assert isinstance(m.events[0], Liftoff) and isinstance(m.events[1], Touchdown)
    assert m.events[1].adjust is not None and m.events[1].adjust.radius == 0.06
    td = m.events[3]
    assert isinstance(td, Touchdown) and td.offset == (0.15, 0.0, 0.0)  # a 2-vector offset gets dz = 0
    assert m.gaits[0].from_ == 1.0 and m.gaits[0].step == (0.1, 0.0, 0.0)
    assert m.weights.force == pytest.approx(1e-4)  # `1e-4` is a number, not YAML 1.1's string
    assert m.objectives[0].t == (1.0, 1.2)


def test_defaults(mk) -> None:
    m = parse_maneuver(mk())
    assert m.start == "stand" and m.tracks == ("legs", "body") and m.friction == 0.6
    assert (m.weights.force, m.weights.pose, m.weights.touchdown_time) == (1e-4, 1.0, 1.0)
    assert (m.weights.touchdown_position, m.weights.hip_over_foot) == (10.0, 0.1)


def test_every_problem_at_once_with_field_paths(mk) -> None:
    bad = mk(
        name="Bad",
        duration=-1,
        tracks=["legs", "arms"],
        events=[
            {"t": 1, "leg": "FX", "type": "liftoff"},
            {"t": "soon", "leg": "FL", "type": "touchdown", "at": [1, 2]},
            {"t": 1, "leg": "FL", "type": "jump"},
            {"t": 1, "leg": "FL"},
            7,
        ],
        gaits=[{"gait": "trot", "from": 0, "to": 1, "cycle": 0, "duty": 1.5, "step": [0.1, 0]}],
        body=[{"t": 1, "position": [0, 0, 0.5], "rpy": [0, True, 0], "wieght": 1}],
        objectives=[{"type": "lean", "t": 1.0, "direction": [1]}],
    )
    got = _problems(bad)
    assert set(got) >= {
        "name",
        "duration",
        "tracks[1]",
        "events[0].leg",
        "events[1].t",
        "events[1].at",
        "events[2].type",
        "events[3].type",
        "events[4]",
        "gaits[0].cycle",
        "gaits[0].duty",
        "gaits[0].step",
        "body[0].rpy[1]",
        "body[0].wieght",
        "objectives[0].direction",
    }, got
    assert got["events[1].t"] == 'must be a number, got "soon"'
    assert got["events[1].at"] == "must be a list of 3 numbers [x, y, z], got 2 items"
    assert got["duration"] == "must be greater than 0 s, got -1"
    assert "did you mean 'weight'" in got["body[0].wieght"]
    assert got["events[2].type"].startswith('unknown type "jump"')
    assert got["body[0].rpy[1]"] == "must be a number, got true"  # booleans are not numbers


def test_plain_messages_have_no_pydantic_jargon(mk) -> None:
    got = _problems(mk(duration=90, friction="high", events=[{"t": -1, "leg": "FL", "type": "liftoff"}]))
    assert got == {
        "duration": "must be at most 60 s, got 90",
        "friction": 'must be a number, got "high"',
        "events[0].t": "must be at least 0 s, got -1",
    }
    for message in got.values():
        assert "Input should" not in message and "pydantic" not in message


@pytest.mark.parametrize(
    ("text", "line", "column"),
    [
        ("format: footfall/maneuver@1\nname: x\nduration: [1, 2\n", 4, 1),
        ("format: footfall/maneuver@1\nname: x\n  duration: 3\n", 3, 11),
        ("format: footfall/maneuver@1\nevents:\n  - {t: 1, leg: FL type: liftoff}\n", 3, 24),
    ],
)
def test_yaml_syntax_errors_give_line_and_column(text: str, line: int, column: int) -> None:
    with pytest.raises(ManeuverError) as e:
        load_maneuver(text)
    (p,) = e.value.problems
    assert p.message.startswith(f"YAML syntax error at line {line}, column {column}:"), p.message
    assert p.line == line


def test_duplicate_keys_are_an_error_not_a_silent_override() -> None:
    with pytest.raises(ManeuverError, match="line 3, column 1: found duplicate key 'duration'"):
        load_maneuver("format: footfall/maneuver@1\nduration: 3\nduration: 4\nname: x\n")


@pytest.mark.parametrize("text", ["", "- 1\n- 2\n", "just words", "42"])
def test_a_document_that_is_not_a_mapping(text: str) -> None:
    got = _problems(text)
    assert list(got) == [""] and got[""].startswith("a maneuver must be a mapping")


def test_problems_carry_yaml_lines() -> None:
    text = (
        "format: footfall/maneuver@1\nname: x\nduration: 3\nevents:\n  - {t: 1, leg: FL, type: liftoff}\n"
        "  - {t: 2, leg: FL, type: touchdown, offset: [1]}\n"
    )
    with pytest.raises(ManeuverError) as e:
        load_maneuver(text)
    (p,) = e.value.problems
    assert (p.path, p.line) == ("events[1].offset", 6)
    assert p.located().startswith("line 6: events[1].offset: must be a list of 2 or 3 numbers")


def test_load_from_path_text_and_dict_agree(tmp_path: Path) -> None:
    text = "format: footfall/maneuver@1\nname: hold\nduration: 2\n"
    f = tmp_path / "hold.yaml"
    f.write_text(text)
    assert (
        load_maneuver(f)
        == load_maneuver(str(f))
        == load_maneuver(text)
        == load_maneuver({"format": "footfall/maneuver@1", "name": "hold", "duration": 2})
    )
    with pytest.raises(ManeuverError, match="no such file"):
        load_maneuver(tmp_path / "missing.yaml")


def test_error_text_names_the_file_and_counts(tmp_path: Path) -> None:
    f = tmp_path / "x.yaml"
    f.write_text("format: footfall/maneuver@1\nname: x\n")
    with pytest.raises(ManeuverError) as e:
        load_maneuver(f)
    assert str(e.value).startswith(f"{f}: invalid maneuver (1 problem):")
    assert "line" in str(e.value) and "duration: is required" in str(e.value)


def test_maneuvers_are_immutable(mk) -> None:
    m = parse_maneuver(mk())
    with pytest.raises(Exception):  # noqa: B017 (pydantic's frozen-instance error)
        m.duration = 3.0  # type: ignore[misc]


def test_yaml_aliases_are_refused() -> None:
    # nested aliases expand into exponentially many items for the validator to walk: a denial of service
    text = "format: footfall/maneuver@1\nname: x\nduration: 1\nbody: &a []\nevents: *a\n"
    with pytest.raises(ManeuverError, match="line 5, column 9: aliases"):
        load_maneuver(text)


def test_only_yaml_file_names_are_read_as_files() -> None:
    with pytest.raises(ManeuverError, match="got a str"):
        load_maneuver("/etc/passwd")  # a one-line string that is not a .yaml name is YAML text
    with pytest.raises(ManeuverError, match="no such file: nowhere.yaml"):
        load_maneuver("nowhere.yaml")
