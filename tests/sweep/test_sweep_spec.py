"""The sweep spec format (footfall/sweep@1): loading, errors naming the field, expansion into cases, keys."""

from __future__ import annotations

import json
import math

import pytest

from planning.sweep import SweepSpecError, case_key, expand, parse_spec, sweep_json_schema
from planning.sweep.spec import SHIPPED_SWEEPS, load_spec
from server.cli import main


def _spec(**kw):
    return parse_spec({"format": "footfall/sweep@1", "name": "t", "run": {"probe": {}}, **kw})


def test_grid_is_the_product_of_the_axes() -> None:
    spec = _spec(axes={"push_impulse_ns": [0, 10, 20], "push_direction_deg": {"min": 0, "max": 270, "step": 90},
                       "seed": {"min": 0, "max": 1, "integer": True}})  # fmt: skip
    cases = expand(spec)
    assert len(cases) == 3 * 4 * 2
    assert {c["axes"]["push_direction_deg"] for c in cases} == {0.0, 90.0, 180.0, 270.0}
    assert {c["params"]["seed"] for c in cases} == {0, 1}
    assert len({c["key"] for c in cases}) == len(cases)


def test_random_sampling_is_reproducible_and_within_ranges() -> None:
    axes = {"friction": {"min": 0.3, "max": 0.9}, "seed": {"min": 0, "max": 99, "integer": True}}
    a = expand(_spec(axes=axes, sampling={"random": 25, "seed": 7}))
    b = expand(_spec(axes=axes, sampling={"random": 25, "seed": 7}))
    c = expand(_spec(axes=axes, sampling={"random": 25, "seed": 8}))
    assert [x["key"] for x in a] == [x["key"] for x in b] != [x["key"] for x in c]
    assert all(0.3 <= x["params"]["friction"] <= 0.9 for x in a)
    assert all(isinstance(x["params"]["seed"], int) for x in a)


def test_terrain_parameters_are_checked_and_coerced() -> None:
    spec = _spec(defaults={"terrain": "stairs"}, axes={"terrain.riser_m": {"min": 0.1, "max": 0.2, "count": 3},
                                                        "terrain.n_steps": [3, 4.0]})  # fmt: skip
    cases = expand(spec)
    assert sorted({c["params"]["terrain_params"]["riser_m"] for c in cases}) == [0.1, 0.15, 0.2]
    assert {type(c["params"]["terrain_params"]["n_steps"]) for c in cases} == {int}


@pytest.mark.parametrize(
    ("doc", "needle"),
    [
        ({"axes": {"wind": [1]}}, "axes.wind: unknown axis"),
        ({"axes": {"friction": {"min": 1, "max": 0}}}, "max 0.0 is below min 1.0"),
        (
            {"axes": {"friction": {"min": 0.2, "max": 0.9}}},
            "axes.friction: a range in a grid needs count or step",
        ),
        ({"axes": {"terrain": ["moon"]}}, "unknown terrain 'moon'"),
        ({"defaults": {"terrain": "stairs"}, "axes": {"terrain.riser": [0.1]}}, "has no parameter riser"),
        (
            {"defaults": {"terrain": "stairs"}, "axes": {"terrain.n_steps": [2.5]}},
            "2.5 is not a whole number",
        ),
        ({"defaults": {"robot": "atlas"}}, "robot:"),
        ({"axes": {"seed": [-1]}}, "axes.seed: -1 is not a whole number"),
        ({"run": {"walk": {}, "probe": {}}}, "give exactly one of maneuver, walk and probe"),
        ({"run": {"maneuver": "no-such"}}, "run.maneuver: "),
        ({"axes": {"push_impulse_ns": [0]}, "sampling": {"random": 0}}, "sampling"),
    ],
)
def test_bad_specs_name_the_field(doc, needle) -> None:
    base = {"format": "footfall/sweep@1", "name": "t", "run": {"probe": {}}}
    with pytest.raises(SweepSpecError) as e:
        expand(parse_spec({**base, **doc}))
    assert needle in str(e.value)


def test_key_follows_params_and_code_version() -> None:
    p = expand(_spec())[0]["params"]
    assert case_key(p, "v1") == case_key(json.loads(json.dumps(p)), "v1")
    assert case_key(p, "v1") != case_key(p, "v2")
    assert case_key(p, "v1") != case_key({**p, "seed": 1}, "v1")


def test_schema_and_shipped_specs_load() -> None:
    schema = sweep_json_schema()
    assert schema["properties"]["format"]["const"] == "footfall/sweep@1"
    assert "axes" in schema["properties"]
    shipped = sorted(SHIPPED_SWEEPS.glob("*.yaml"))
    assert len(shipped) >= 6 + 4
    for path in shipped:
        spec = load_spec(path)
        assert spec.name == path.stem, path


def test_cli_bad_spec_is_one_line_and_exit_2(tmp_path, capsys) -> None:
    p = tmp_path / "s.yaml"
    p.write_text("format: footfall/sweep@1\nname: s\nrun: {probe: {}}\naxes: {push_impulse_ns: {min: 0}}\n")
    assert main(["sweep", str(p), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip()
    assert "axes.push_impulse_ns" in err and "max" in err
    assert len(err.splitlines()) == 1


def test_shipped_specs_expand_and_summarize() -> None:
    from planning.sweep import summarize

    for path in sorted(SHIPPED_SWEEPS.glob("*.yaml")):
        spec = load_spec(path)
        cases = expand(spec)
        # small, each runs in minutes; the terrain families (issue 26's measure) are 50 variants each (each
        # walked once per repeat in a repeated spec)
        repeats = math.prod(len(v) for v in spec.repeat().values())
        most = (50 if path.stem.startswith("family-") else 40) * repeats
        assert 1 <= len({c["key"] for c in cases}) <= most, path
        s = summarize(spec, cases, {})
        assert s["overall"]["pending"] == len({c["key"] for c in cases})


def test_per_run_axes_replace_the_sweeps() -> None:
    spec = parse_spec({"format": "footfall/sweep@1", "name": "t", "axes": {"seed": [0, 1, 2]},
                       "run": [{"label": "a", "probe": {}}, {"label": "b", "probe": {}, "axes": {"seed": [5]}}]})  # fmt: skip
    cases = expand(spec)
    assert [(c["axes"]["run"], c["axes"]["seed"]) for c in cases] == [("a", 0), ("a", 1), ("a", 2), ("b", 5)]


def test_runs_with_axes_of_their_own_summarize_together() -> None:
    from planning.sweep import summarize

    spec = parse_spec({"format": "footfall/sweep@1", "name": "t", "summary": {"by": ["run", "friction"]},
                       "run": [{"label": "a", "probe": {}, "axes": {"seed": [0, 1]}},
                               {"label": "b", "probe": {}, "axes": {"friction": [0.5, 0.8]}}]})  # fmt: skip
    cases = expand(spec)
    s = summarize(spec, cases, {})
    assert [(c["axes"]["run"], c["axes"]["friction"], c["cases"]) for c in s["cells"]] == [
        ("a", "—", 2),
        ("b", "0.5", 1),
        ("b", "0.8", 1),
    ]


def test_a_walk_to_the_terrains_own_goal() -> None:
    """`goal: terrain` walks each variant to its own goal (1 m past a long staircase), offsets added."""
    from planning.terrain.spec import load_terrain, spec_from_mapping

    spec = parse_spec({"format": "footfall/sweep@1", "name": "t", "run": {"walk": {"goal": "terrain"}},
                       "defaults": {"terrain": "stairs"},
                       "axes": {"terrain.n_steps": [2, 8], "goal_dy_m": [0.2]}})  # fmt: skip
    goals = []
    for c in expand(spec):
        w, p = c["params"]["walk"], c["params"]
        assert w["goal"] == "terrain" and w["goal_offset"] == [0.0, 0.2]
        t = spec_from_mapping({"name": p["terrain"], "params": p["terrain_params"]}).text()
        goals.append(load_terrain(t, seed=p["seed"]).goal_xy[0])
    assert goals[0] == pytest.approx(6.0) and goals[1] > 7.0  # eight steps up and down end beyond 6 m
    with pytest.raises(SweepSpecError, match="goal"):
        parse_spec({"format": "footfall/sweep@1", "name": "t", "run": {"walk": {"goal": "there"}}})


def test_clean_success_counts_body_collisions_and_no_step_touchdowns_as_failures() -> None:
    from planning.sweep.summary import summarize

    spec = _spec(axes={"seed": [0, 1, 2]}, summary={"success": "clean"})
    cases = expand(spec)
    reps = [{"success": True, "body_collisions": 0, "no_step_touchdowns": 0},
            {"success": True, "body_collisions": 2, "no_step_touchdowns": 0},
            {"success": True, "no_step_touchdowns": 1}]  # fmt: skip
    records = {
        c["key"]: {"status": "done", "report": r, "wall_s": 1.0} for c, r in zip(cases, reps, strict=True)
    }
    s = summarize(spec, cases, records)
    assert s["overall"]["successes"] == 1
    assert set(s["overall"]["failure_reasons"]) == {
        "not clean: # body collisions",
        "not clean: # no-step touchdowns",
    }
    assert summarize(_spec(axes={"seed": [0, 1, 2]}), cases, records)["overall"]["successes"] == 3


def test_falls_by_touch_are_counted_by_the_part_and_the_kind_of_thing_touched() -> None:
    """The summary's falls_touched (the run reports' fall_contact: a geom's trailing index dropped, so two low boxes
    are one kind), its lines in the table, and cases.csv's no-step and fall columns."""
    import csv
    import io

    from planning.sweep.summary import cases_csv, format_table, summarize, touched_kind

    assert touched_kind("terrain_box_low_3") == "terrain_box_low" == touched_kind("terrain_box_low_10")
    assert touched_kind("terrain_box_platform") == "terrain_box_platform" and touched_kind(None) == "?"
    spec = _spec(axes={"seed": [0, 1, 2, 3]})
    cases = expand(spec)

    def fell(part: str, touched: str) -> dict:
        return {"success": False, "failure_reason": f"fell: {part} touched the world at t=1.00 s",
                "fall_contact": {"part": part, "touched": touched, "point_m": [1.0, 0.0, 0.1]}}  # fmt: skip

    reps = [fell("FL_lleg", "terrain_box_low_3"), fell("FL_lleg", "terrain_box_low_0"),
            fell("trunk", "terrain_obstacle_box_tall_1"), {"success": True, "no_step_touchdowns": 2}]  # fmt: skip
    records = {
        c["key"]: {"status": "done", "report": r, "wall_s": 1.0} for c, r in zip(cases, reps, strict=True)
    }
    s = summarize(spec, cases, records)
    assert s["overall"]["falls_touched"] == {
        "FL_lleg on terrain_box_low": 2,
        "trunk on terrain_obstacle_box_tall": 1,
    }
    table = format_table(s)
    assert "falls by touch" in table and "FL_lleg on terrain_box_low" in table
    rows = list(csv.DictReader(io.StringIO(cases_csv(cases, records))))
    assert [r["fall_touched"] for r in rows] == ["terrain_box_low_3", "terrain_box_low_0",
                                                  "terrain_obstacle_box_tall_1", ""]  # fmt: skip
    assert rows[3]["no_step_touchdowns"] == "2" and rows[0]["no_step_touchdowns"] == ""


def test_near_misses_are_summed_per_100_steps_over_the_walks_that_watched() -> None:
    from planning.sweep.summary import format_table, summarize

    spec = _spec(axes={"seed": [0, 1, 2]})
    cases = expand(spec)
    reps = [
        {"success": True, "near_misses": 3, "steps_taken": 100, "link_clearance_min_m": 0.004},
        {"success": False, "near_misses": 1, "steps_taken": 50, "link_clearance_min_m": 0.012},
        {"success": True, "steps_taken": 400},
    ]  # (the last: no near-miss watch, not counted)
    records = {
        c["key"]: {"status": "done", "report": r, "wall_s": 1.0} for c, r in zip(cases, reps, strict=True)
    }
    s = summarize(spec, cases, records)
    assert s["overall"]["near_misses"] == 4
    assert s["overall"]["near_misses_per_100_steps"] == pytest.approx(100 * 4 / 150, abs=0.01)
    assert s["overall"]["link_clearance_min_m"]["p50"] == pytest.approx(0.008)
    assert "near misses /100 steps" in format_table(s) and "2.67 (4)" in format_table(s)
    plain = summarize(spec, cases, {k: {**r, "report": {"success": True}} for k, r in records.items()})
    assert plain["overall"]["near_misses"] is None and "near misses" not in format_table(plain)


def test_near_edge_landings_are_summed_per_100_steps() -> None:
    import csv
    import io

    from planning.sweep.summary import cases_csv, format_table, summarize

    spec = _spec(axes={"seed": [0, 1, 2]})
    cases = expand(spec)
    reps = [
        {"success": True, "near_edge_landings": 5, "steps_taken": 100},
        {"success": True, "near_edge_landings": 0, "steps_taken": 100},
        {"success": True, "steps_taken": 400},
    ]  # (the last: a walk without terrain, not counted)
    records = {
        c["key"]: {"status": "done", "report": r, "wall_s": 1.0} for c, r in zip(cases, reps, strict=True)
    }
    s = summarize(spec, cases, records)
    assert s["overall"]["near_edge_landings"] == 5
    assert s["overall"]["near_edge_landings_per_100_steps"] == pytest.approx(2.5)
    assert "near edges /100 steps" in format_table(s) and "2.50 (5)" in format_table(s)
    rows = list(csv.DictReader(io.StringIO(cases_csv(cases, records))))
    assert [r["near_edge_landings"] for r in rows] == ["5", "0", ""]
