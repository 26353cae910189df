"""`footfall sweep --compare A B`: two results directories paired case by case, with the exact sign test."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import pytest

from planning.sweep.compare import CompareError, compare, format_compare, rate_test_p, sign_test_p
from server.cli import main as cli_main


def _record(
    i: int, ok: bool, version: str, no_step: int = 0, reason: str = "fell: FL_lleg touched the world"
) -> dict[str, Any]:
    params = {"kind": "walk", "terrain": "stairs", "terrain_params": {"riser_m": 0.1 + 0.01 * i}, "seed": 0}
    report = {"success": ok, "failure_reason": None if ok else f"{reason} at t={5 + i}.00 s",
              "no_step_touchdowns": no_step, "body_collisions": 0}  # fmt: skip
    return {"key": f"{version}{i:04d}", "status": "done", "report": report,
            "case": {"key": f"{version}{i:04d}", "params": params, "axes": {"terrain.riser_m": 0.1 + 0.01 * i}}}  # fmt: skip


def _write(d: Path, records: list[dict[str, Any]], summary: dict[str, Any] | None = None) -> Path:
    (d / "cases").mkdir(parents=True)
    for r in records:
        (d / "cases" / f"{r['key']}.json").write_text(json.dumps(r))
    if summary is not None:
        (d / "summary.json").write_text(json.dumps(summary))
    return d


def test_sign_test_is_the_exact_binomial_tail() -> None:
    assert sign_test_p(0, 0) == 1.0
    assert sign_test_p(2, 0) == pytest.approx(0.5)  # two gains and no loss: no evidence
    assert sign_test_p(0, 6) == pytest.approx(2 / 64)
    assert sign_test_p(3, 3) == 1.0
    n, k = 20, 4
    assert sign_test_p(16, 4) == pytest.approx(2 * sum(math.comb(n, i) for i in range(k + 1)) / 2**n)


def test_cases_pair_by_their_draw_not_by_key(tmp_path: Path) -> None:
    a_ok = [True, True, False, False, True, False]
    b_ok = [True, False, True, True, True, False]
    a = _write(tmp_path / "a", [_record(i, ok, "aaaa") for i, ok in enumerate(a_ok)])
    # B ran one draw A did not, and its keys (another code version) differ from A's
    b = _write(
        tmp_path / "b", [_record(i, ok, "bbbb") for i, ok in enumerate(b_ok)] + [_record(9, True, "bbbb")]
    )
    c = compare(a, b)
    assert c["paired"] == 6 and c["a_only"] == 0 and c["b_only"] == 1
    assert (c["a_successes"], c["b_successes"]) == (3, 4)
    assert (c["gains"], c["losses"]) == (2, 1)
    assert c["sign_test_p"] == pytest.approx(1.0)
    kinds = sorted(ch["change"] for ch in c["changed"])
    assert kinds == ["gain", "gain", "loss"]
    text = format_compare(c)
    assert "B gains 2, loses 1" in text and "riser_m=0.11" in text


def test_a_clean_sweep_counts_a_no_step_touchdown_as_a_failure(tmp_path: Path) -> None:
    a = _write(tmp_path / "a", [_record(0, True, "a")], {"success": "clean"})
    b = _write(tmp_path / "b", [_record(0, True, "b", no_step=2)], {"success": "clean"})
    c = compare(a, b)
    assert (c["gains"], c["losses"]) == (0, 1)
    assert "no-step" in c["changed"][0]["b"]
    assert c["params_differ"] == []
    # the same results judged by plain success: no change
    (b / "summary.json").write_text(json.dumps({"success": "success"}))
    assert compare(a, b)["losses"] == 0


def test_the_cli_compares_and_refuses_what_it_cannot(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    a = _write(tmp_path / "a", [_record(i, i % 2 == 0, "a") for i in range(4)])
    b = _write(tmp_path / "b", [_record(i, True, "b") for i in range(4)])
    out = tmp_path / "c.json"
    assert cli_main(["sweep", "--compare", str(a), str(b), "--json", str(out)]) == 0
    assert "B gains 2, loses 0" in capsys.readouterr().out
    assert json.loads(out.read_text())["gains"] == 2
    assert cli_main(["sweep", "--compare", str(a), str(tmp_path / "nowhere")]) == 2
    assert "no sweep results here" in capsys.readouterr().err
    other = _write(tmp_path / "other", [_record(7, True, "o")])
    other_rec = json.loads((other / "cases" / "o0007.json").read_text())
    other_rec["case"]["params"]["seed"] = 5
    (other / "cases" / "o0007.json").write_text(json.dumps(other_rec))
    other_rec["case"]["axes"] = {"seed": 5}
    (other / "cases" / "o0007.json").write_text(json.dumps(other_rec))
    with pytest.raises(CompareError, match="share no draw"):
        compare(a, other)
    assert cli_main(["sweep", "sweeps/family-stairs.yaml", "--compare", str(a), str(b)]) == 2


def test_a_change_of_the_run_itself_pairs_by_draw_and_is_named(tmp_path: Path) -> None:
    a = _write(tmp_path / "a", [_record(i, i == 0, "a") for i in range(3)])
    slow = [_record(i, True, "b") for i in range(3)]
    for r in slow:
        r["case"]["params"]["walk"] = {"speed_mps": 0.3}
    b = _write(tmp_path / "b", slow)
    c = compare(a, b)
    assert c["paired"] == 3 and c["gains"] == 2
    assert c["params_differ"] == ["walk"] or c["params_differ"] == ["walk.speed_mps"]
    assert "differ in: walk" in format_compare(c)


def test_a_walks_speed_reaches_the_case_and_is_checked_against_the_terrain() -> None:
    from planning.sweep.cases import expand
    from planning.sweep.spec import SweepSpecError, parse_spec

    def spec(speed: float | None, terrain: str = "stairs") -> dict[str, Any]:
        walk: dict[str, Any] = {"goal": "terrain", "maps": "sensor"}
        if speed is not None:
            walk["speed_mps"] = speed
        return {"format": "footfall/sweep@1", "name": "s", "run": {"walk": walk},
                "defaults": {"terrain": terrain}, "axes": {"seed": [0, 1]}}  # fmt: skip

    slow = expand(parse_spec(spec(0.3)))
    assert [c["params"]["walk"]["speed_mps"] for c in slow] == [0.3, 0.3]
    plain = expand(parse_spec(spec(None)))
    assert (
        "speed_mps" not in plain[0]["params"]["walk"]
    )  # the default leaves the case (and its key) as it was
    assert plain[0]["key"] != slow[0]["key"]
    assert expand(parse_spec(spec(0.9, "slope")))[0]["params"]["walk"]["speed_mps"] == 0.9
    with pytest.raises(SweepSpecError, match="run.walk.speed_mps"):
        expand(parse_spec(spec(0.9)))  # faster than the stairs' 0.5 m/s


def test_a_walks_descent_way_reaches_the_case_and_backward_needs_a_goal_and_a_terrain() -> None:
    from planning.sweep.cases import expand
    from planning.sweep.spec import SweepSpecError, parse_spec

    def spec(walk: dict[str, Any], terrain: str = "stairs") -> dict[str, Any]:
        return {"format": "footfall/sweep@1", "name": "s", "run": {"walk": {"maps": "sensor", **walk}},
                "defaults": {"terrain": terrain}, "axes": {"seed": [0, 1]}}  # fmt: skip

    back = expand(parse_spec(spec({"goal": "terrain", "descend_backward": True})))
    assert [c["params"]["walk"]["descend_backward"] for c in back] == [True, True]
    plain = expand(parse_spec(spec({"goal": "terrain"})))
    assert "descend_backward" not in plain[0]["params"]["walk"]  # the default keeps the case's key
    assert plain[0]["key"] != back[0]["key"]
    fwd = expand(parse_spec(spec({"goal": "terrain", "descend_backward": False})))
    assert fwd[0]["params"]["walk"]["descend_backward"] is False and fwd[0]["key"] not in (
        back[0]["key"],
        plain[0]["key"],
    )
    assert expand(
        parse_spec(spec({"vx": 0.3, "descend_backward": False}))
    )  # forward asks nothing of the walk
    with pytest.raises(SweepSpecError, match="run.walk.descend_backward"):
        expand(parse_spec(spec({"vx": 0.3, "descend_backward": True})))  # no goal
    with pytest.raises(SweepSpecError, match="run.walk.descend_backward"):
        expand(parse_spec(spec({"goal": [3.0, 0.0], "descend_backward": True}, "flat")))


def _repeated(draw: int, start: float, ok: bool, version: str, repeat: bool = True) -> dict[str, Any]:
    """A record of a repeated clutter sweep's case: draw `draw` started `start` m forward."""
    r = _record(draw, ok, version)
    r["key"] = r["case"]["key"] = f"{version}{draw:04d}{int(start * 1000)}"
    r["case"]["params"]["start"] = [start, 0.0, 0.0]
    if repeat:
        r["case"]["axes"] = {**r["case"]["axes"], "start_x_m": start, "draw": draw}
    return r


def test_repeated_sweeps_pair_each_repeat_and_compare_each_draws_fraction(tmp_path: Path) -> None:
    # (A at 0 mm, A at 1 mm, B at 0 mm, B at 1 mm) for four draws
    outcomes = [(False, False, True, True), (True, False, True, True), (True, True, False, True),
                (False, True, True, False)]  # fmt: skip
    a = _write(tmp_path / "a", [_repeated(d, s, o[j], "a") for d, o in enumerate(outcomes)
                                for j, s in enumerate((0.0, 0.001))])  # fmt: skip
    b = _write(tmp_path / "b", [_repeated(d, s, o[2 + j], "b") for d, o in enumerate(outcomes)
                                for j, s in enumerate((0.0, 0.001))])  # fmt: skip
    c = compare(a, b)
    assert c["paired"] == 8 and (c["a_successes"], c["b_successes"]) == (4, 6)
    assert (c["gains"], c["losses"]) == (4, 2)
    # draw 0: 0/2 → 2/2 up; draw 1: 1/2 → 2/2 up; draw 2: 2/2 → 1/2 down; draw 3: 1/2 → 1/2 the same
    assert c["draws"] == {"paired": 4, "up": 2, "down": 1, "same": 1, "sign_test_p": 1.0}
    text = format_compare(c)
    assert "B up on 2, down on 1, the same on 1 of 4 draws" in text
    assert "start_x_m=0.001 draw=3" in text  # each changed case named with its repeat and draw
    # an unrepeated sweep has no per-draw line, and does not pair with a repeated one
    plain = _write(tmp_path / "plain", [_repeated(d, 0.0, True, "p", repeat=False) for d in range(4)])
    assert compare(plain, plain)["draws"] is None and "per draw" not in format_compare(compare(plain, plain))
    with pytest.raises(CompareError, match="one of them repeated its draws"):
        compare(plain, b)


def test_the_rate_test_is_the_exact_conditional_binomial() -> None:
    assert rate_test_p(0, 100.0, 0, 100.0) == 1.0
    assert rate_test_p(5, 100.0, 5, 100.0) == pytest.approx(1.0)
    # 0 against 6 on equal exposure: the two tails of Binomial(6, 1/2) at their ends
    assert rate_test_p(0, 100.0, 6, 100.0) == pytest.approx(2 / 64)
    # B walked three times as far: 2 against 6 is what one rate gives
    assert rate_test_p(2, 100.0, 6, 300.0) == pytest.approx(1.0)
    assert rate_test_p(42, 4337.0, 66, 4201.0) < 0.05 < rate_test_p(42, 4337.0, 50, 4201.0)


def test_near_misses_compare_over_the_walks_both_sides_counted(tmp_path: Path) -> None:
    def with_near(r: dict[str, Any], n: int | None) -> dict[str, Any]:
        if n is not None:
            r["report"].update(near_misses=n, steps_taken=100)
        return r

    a = _write(
        tmp_path / "a", [with_near(_record(i, True, "aaaa"), n) for i, n in enumerate([1, 0, 2, None])]
    )
    b = _write(tmp_path / "b", [with_near(_record(i, True, "bbbb"), n) for i, n in enumerate([4, 3, 5, 7])])
    c = compare(a, b)
    nm = c["near_misses"]
    assert (nm["walks"], nm["a"], nm["b"], nm["a_steps"], nm["b_steps"]) == (3, 3, 12, 300, 300)
    assert (
        nm["rate_test_p"] == pytest.approx(rate_test_p(3, 300.0, 12, 300.0), abs=1e-4)
        and nm["rate_test_p"] < 0.05
    )
    assert "A 3 in 300 steps (1.00 per 100), B 12 in 300 steps (4.00 per 100)" in format_compare(c)
    plain = compare(
        _write(tmp_path / "c", [_record(0, True, "cccc")]), _write(tmp_path / "d", [_record(0, True, "dddd")])
    )
    assert plain["near_misses"] is None and "near misses" not in format_compare(plain)


def test_compare_counts_the_kinds_of_failure_on_each_side(tmp_path: Path) -> None:
    """--compare's failures by kind: a fall by touch by the part's kind (the run report's fall_contact), a body
    dropped, a no-step touchdown counted under the clean criterion, older reports' falls by their reason."""
    from planning.sweep.summary import failure_kind

    def fell(i: int, version: str, kind: str | None) -> dict[str, Any]:
        r = _record(i, False, version)
        if kind is not None:
            r["report"]["fall_contact"] = {"part": "FL_lleg", "kind": kind, "touched": "terrain_step_3",
                                           "point_m": [1.0, 0.0, 0.2]}  # fmt: skip
        return r

    a = [fell(0, "aaaa", "lower leg"), fell(1, "aaaa", "lower leg"), fell(2, "aaaa", None),
         _record(3, True, "aaaa", no_step=1), _record(4, False, "aaaa", reason="fell: body dropped to 0.20 m")]  # fmt: skip
    b = [fell(0, "bbbb", "trunk"), _record(1, True, "bbbb"), _record(2, True, "bbbb"),
         _record(3, True, "bbbb"), _record(4, True, "bbbb")]  # fmt: skip
    assert failure_kind(a[0]) == "fell: lower leg" and failure_kind(a[2]) == "fell: touch"
    assert failure_kind(a[3]) is None and failure_kind(a[3], "clean") == "no-step touchdown"
    assert failure_kind({"status": "crashed"}) == "crashed" and failure_kind(b[1], "clean") is None
    c = compare(
        _write(tmp_path / "a", a, {"success": "clean"}), _write(tmp_path / "b", b, {"success": "clean"})
    )
    assert c["failure_kinds"] == {
        "fell: lower leg": {"a": 2, "b": 0},
        "fell: touch": {"a": 1, "b": 0},
        "no-step touchdown": {"a": 1, "b": 0},
        "fell: body dropped": {"a": 1, "b": 0},
        "fell: trunk": {"a": 0, "b": 1},
    }
    assert "failures by kind, A → B: fell: lower leg 2 → 0" in format_compare(c)


def test_near_edge_landings_compare_like_near_misses(tmp_path: Path) -> None:
    """--compare's near-edge landings (the sole within NEAR_EDGE_M of an edge): over the walks both sides counted
    them on, with the exact test of one rate."""

    def with_edges(r: dict[str, Any], n: int | None) -> dict[str, Any]:
        if n is not None:
            r["report"].update(near_edge_landings=n, steps_taken=50)
        return r

    a = _write(tmp_path / "a", [with_edges(_record(i, True, "aaaa"), n) for i, n in enumerate([None, 2, 2])])
    b = _write(tmp_path / "b", [with_edges(_record(i, True, "bbbb"), n) for i, n in enumerate([9, 0, 1])])
    c = compare(a, b)
    ne = c["near_edge_landings"]
    assert (ne["walks"], ne["a"], ne["b"], ne["a_steps"], ne["b_steps"]) == (2, 4, 1, 100, 100)
    text = format_compare(c)
    assert "near-edge landings (the sole within 1 cm of an edge" in text
    assert "A 4 in 100 steps (4.00 per 100), B 1 in 100 steps (1.00 per 100)" in text
    assert c["near_misses"] is None and "near misses" not in text
