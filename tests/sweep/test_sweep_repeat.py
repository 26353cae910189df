"""`sampling.repeat`: each random draw run at every value of a nuisance axis (the same draws as without it), the
checks on the repeat axes, and the summary's steady count of draws with one outcome at every repeat."""

from __future__ import annotations

import csv
import io
import json
from typing import Any

import pytest

from planning.sweep import SweepSpecError, expand, format_table, parse_spec, summarize
from planning.sweep.spec import DRAW, SHIPPED_SWEEPS, load_spec
from planning.sweep.summary import cases_csv, default_by

_AXES = {"friction": {"min": 0.3, "max": 0.9}, "seed": {"min": 0, "max": 99, "integer": True}}


def _spec(**kw: Any):
    return parse_spec({"format": "footfall/sweep@1", "name": "t", "run": {"probe": {}}, **kw})


def _drawn(case: dict[str, Any], repeat: list[str]) -> dict[str, Any]:
    """A case's drawn values: its axes but the repeat axes and the draw number."""
    return {a: v for a, v in case["axes"].items() if a not in (*repeat, DRAW)}


def test_each_draw_runs_at_every_combination_of_the_repeat_values() -> None:
    plain = expand(_spec(axes=_AXES, sampling={"random": 4, "seed": 3}))
    repeat = {"start_x_m": [0.0, 0.001], "push_impulse_ns": [0, 5, 10]}
    cases = expand(_spec(axes=_AXES, sampling={"random": 4, "seed": 3, "repeat": repeat}))
    assert len(cases) == 4 * 2 * 3
    assert [c["axes"][DRAW] for c in cases] == [i for i in range(4) for _ in range(6)]
    for i, p in enumerate(plain):
        mine = cases[6 * i : 6 * i + 6]
        # the draws are the unrepeated spec's (drawn first, the generator's sequence unchanged)
        assert all(_drawn(c, list(repeat)) == p["axes"] for c in mine)
        assert {(c["axes"]["start_x_m"], c["axes"]["push_impulse_ns"]) for c in mine} == {
            (x, j) for x in (0.0, 0.001) for j in (0, 5, 10)
        }
        assert {c["params"]["start"][0] for c in mine} == {0.0, 0.001}
    assert len({c["key"] for c in cases}) == len(cases)


def test_the_shipped_repeat_spec_walks_family_clutters_draws_its_cases_at_zero_the_same_runs() -> None:
    plain = expand(load_spec(SHIPPED_SWEEPS / "family-clutter.yaml"))
    spec = load_spec(SHIPPED_SWEEPS / "family-clutter-repeat.yaml")
    cases = expand(spec)
    assert len(plain) == 50 and len(cases) == 100
    at_zero = [c for c in cases if c["axes"]["start_x_m"] == 0.0]
    forward = [c for c in cases if c["axes"]["start_x_m"] == 0.001]
    assert [c["axes"][DRAW] for c in at_zero] == list(range(50))
    assert [c["key"] for c in at_zero] == [c["key"] for c in plain]  # the default value: the very same runs
    assert [c["params"] for c in at_zero] == [c["params"] for c in plain]
    assert [_drawn(c, ["start_x_m"]) for c in forward] == [c["axes"] for c in plain]
    assert not {c["key"] for c in forward} & {c["key"] for c in plain}
    assert all(c["params"]["start"][0] == 0.001 for c in forward)


@pytest.mark.parametrize(
    ("sampling", "axes", "needle"),
    [
        ({"random": 5, "repeat": {"wind": [1]}}, {}, "sampling.repeat.wind: unknown axis"),
        ({"random": 5, "repeat": {DRAW: [0, 1]}}, {}, "sampling.repeat.draw: unknown axis"),
        ({"random": 5, "repeat": {"run": ["a"]}}, {}, "sampling.repeat.run: list the runs"),
        (
            {"random": 5, "repeat": {"seed": [1, 2]}},
            {"seed": [1, 2, 3]},
            "sampling.repeat.seed: also axes.seed",
        ),
        ({"random": 5, "repeat": {"start_x_m": list(range(11))}}, {}, "sampling.Sampling.repeat.start_x_m"),
        ({"random": 5, "repeat": {"start_x_m": []}}, {}, "sampling.Sampling.repeat.start_x_m"),
        ({"random": 60_000, "repeat": {"start_x_m": [0, 1]}}, {}, "120000 cases, over the 100000"),
        # a grid has no repeat: repeat is a field of random sampling
        ({"repeat": {"start_x_m": [0, 0.001]}}, {}, "sampling.Sampling.random: Field required"),
    ],
)
def test_bad_repeats_name_the_field(sampling: dict[str, Any], axes: dict[str, Any], needle: str) -> None:
    with pytest.raises(SweepSpecError) as e:
        _spec(axes={"friction": [0.5, 0.8], **axes}, sampling=sampling)
    assert needle in str(e.value)


def test_a_repeat_axis_may_not_also_be_a_runs_axis() -> None:
    doc = {"format": "footfall/sweep@1", "name": "t", "sampling": {"random": 3, "repeat": {"friction": [0.5]}},
           "run": [{"label": "a", "probe": {}}, {"label": "b", "probe": {}, "axes": {"friction": [0.8]}}]}  # fmt: skip
    with pytest.raises(SweepSpecError, match=r"sampling.repeat.friction: also run.b.axes.friction"):
        parse_spec(doc)


def test_repeat_and_draw_group_only_when_summary_by_names_them() -> None:
    sampling = {"random": 12, "seed": 1, "repeat": {"start_x_m": [0.0, 0.001]}}
    spec = _spec(axes={"terrain": ["flat", "slope"], **_AXES}, sampling=sampling)
    cases = expand(spec)
    assert default_by(spec, cases) == ["terrain", "friction"]
    s = summarize(spec, cases, {})
    assert s["by"] == ["terrain", "friction"] and s["heatmap"]["x"] == "terrain"
    by_draw = _spec(axes=_AXES, sampling=sampling, summary={"by": [DRAW, "start_x_m"]})
    cells = summarize(by_draw, cases, {})["cells"]
    # a draw number is never binned: one cell per draw and start
    assert [(c["axes"][DRAW], c["axes"]["start_x_m"], c["cases"]) for c in cells[:3]] == [
        ("0", "0", 1),
        ("0", "0.001", 1),
        ("1", "0", 1),
    ]
    assert len(cells) == 24
    assert cases_csv(cases, {}).splitlines()[0].startswith("terrain,friction,seed,start_x_m,draw,status")


def _record(ok: bool, **report: Any) -> dict[str, Any]:
    rep = {"success": ok, "failure_reason": None if ok else "fell: trunk touched the world", **report}
    return {"status": "done", "report": rep, "wall_s": 1.0}


CRASHED = {"status": "crashed", "report": None, "error": "worker died", "wall_s": 1.0}


def _summary(outcomes: list[tuple[Any, ...]], success: str = "report") -> dict[str, Any]:
    """The summary of a probe sweep of len(outcomes) draws at two starts; outcomes: each draw's two records."""
    spec = _spec(axes=_AXES, sampling={"random": len(outcomes), "repeat": {"start_x_m": [0.0, 0.001]}},
                 summary={"success": success})  # fmt: skip
    cases = expand(spec)
    records = {}
    for c, r in zip(cases, [r for pair in outcomes for r in pair], strict=True):
        if r is not None:
            records[c["key"]] = r
    return summarize(spec, cases, records)


def test_steady_counts_draws_with_one_outcome_at_every_repeat() -> None:
    fall, ok = _record(False), _record(True)
    s = _summary([(ok, ok), (ok, ok), (fall, fall), (ok, fall), (fall, ok), (ok, None), (CRASHED, ok)])
    assert s["steady"] == {"draws": 5, "steady": 3, "always": 2, "never": 1, "flipping": 2, "left_out": 2}
    # each repeat is a case in the rates: 12 done of 14 (1 crashed, 1 pending), 8 successes
    o = s["overall"]
    assert (o["cases"], o["done"], o["crashed"], o["pending"], o["successes"]) == (14, 12, 1, 1, 8)
    text = format_table(s)
    assert "steady: 3 of 5 draws have one outcome at every repeat (2 always, 1 never, 2 flip)" in text
    assert "2 draws left out (a repeat pending or crashed)" in text


def test_steady_follows_the_summarys_success_rule() -> None:
    ok, touched = _record(True), _record(True, body_collisions=1)
    assert _summary([(ok, touched)])["steady"]["always"] == 1
    clean = _summary([(ok, touched)], success="clean")["steady"]
    assert (clean["always"], clean["flipping"]) == (0, 1)


def test_an_unrepeated_sweep_has_no_steady_count() -> None:
    spec = _spec(axes=_AXES, sampling={"random": 3})
    cases = expand(spec)
    s = summarize(spec, cases, {c["key"]: _record(True) for c in cases})
    assert "steady" not in s and "steady" not in format_table(s)
    assert all(DRAW not in c["axes"] for c in cases)


def test_a_repeated_probe_sweep_runs_and_writes_its_steady_count(tmp_path) -> None:
    from planning.sweep import LocalBackend, run_sweep

    # a probe's case number i fails when i + 1 is a multiple of 3: cases 2 and 5 (draw 1 at 0 mm, draw 2 at 1 mm)
    spec = parse_spec({"format": "footfall/sweep@1", "name": "probe", "run": {"probe": {"fail_every": 3}},
                       "axes": _AXES, "sampling": {"random": 3, "repeat": {"start_x_m": [0.0, 0.001]}}})  # fmt: skip
    s = run_sweep(spec, LocalBackend(workers=1), tmp_path, progress=False)
    assert s["overall"]["done"] == 6 and s["overall"]["successes"] == 4
    assert s["steady"] == {"draws": 3, "steady": 1, "always": 1, "never": 0, "flipping": 2, "left_out": 0}
    assert json.loads((tmp_path / "summary.json").read_text())["steady"]["flipping"] == 2
    rows = list(csv.DictReader(io.StringIO((tmp_path / "cases.csv").read_text())))
    assert [(r["draw"], r["start_x_m"], r["success"]) for r in rows[2:4]] == [
        ("1", "0", "False"),
        ("1", "0.001", "True"),
    ]
