"""benchmarks.swing_replay: a walk's plan() calls, recorded and replayed through a fresh planner, give the same
selections (the recording holds copies of everything the loop later changes in place)."""

from __future__ import annotations

from pathlib import Path

from benchmarks.swing_replay import record, replay


def test_a_recorded_trot_replays_to_the_same_selections(tmp_path: Path) -> None:
    path = str(tmp_path / "sw.pkl")
    calls = record(path, "flat", 0.8)
    out = replay(path, repeats=1)
    assert calls == out["calls"] > 100
    assert out["legs_planned"] > 100
    assert out["selections_differ"] == 0
    assert out["worst_position_diff_m"] < 1e-9
    assert 0.0 < out["per_leg_cpu_us_p50"] <= out["per_leg_cpu_us_p99"]
    # the walk ran with the event-driven selection; the full tier analysis every replan selects the same
    assert out["reused_selections"] > 0.1 * out["legs_planned"]
    full = replay(path, repeats=1, full=True)
    assert full["reused_selections"] == 0
    assert full["selections_differ"] == 0
