"""The step-selection benchmark runs and reports its numbers (timings themselves are not asserted here)."""

from __future__ import annotations

from planning.steps.bench import bench_step_selection


def test_bench_reports_percentiles() -> None:
    r = bench_step_selection(25, n_calls=5)
    assert {"p50_ms", "p99_ms", "replan_p50_ms", "replan_p99_ms"} <= set(r)
    assert 0.0 < r["p50_ms"] <= r["p99_ms"] and r["replan_p50_ms"] > 0.0
