"""The stance-area benchmarks run and report what `footfall bench` reads."""

from __future__ import annotations

import math

import pytest

from planning.bench_stance import bench_force_distribution, bench_stance_handler


@pytest.mark.parametrize("bench", [bench_stance_handler, bench_force_distribution])
def test_bench_reports_percentiles_and_bare_solver_time(bench) -> None:
    result = bench(n=40)
    assert result["n"] == 40
    for key in ("p50_ms", "p99_ms", "p99_cpu_ms", "bare_solver_p50_ms"):
        assert math.isfinite(result[key]) and result[key] > 0.0, key
    assert result["p50_ms"] <= result["p99_ms"]
    assert result["bare_solver_p50_ms"] < result["p50_ms"]  # the wrapper does strictly more than .solve()
