from planning.swing.bench import bench_swing_select


def test_bench_reports_every_case_within_the_evaluation_bound():
    out = bench_swing_select(calls=15)
    assert out["case"] == "flat" and out["p50_ms"] > 0.0
    for case in ("flat", "box", "crossing"):
        r = out[case]
        assert 0.0 < r["p50_ms"] <= r["p99_ms"]
        assert r["evaluations_max"] <= r["evaluations_bound"]
        assert r["tier"] == "SUCCESS"
    assert out["flat"]["evaluations_max"] == 2  # Cubic at once, then the gentlest vertical
    assert out["crossing"]["policy"].startswith(("SwingAround", "Wiggle"))


def test_bench_reports_cpu_time_and_the_geometry_inside_it():
    out = bench_swing_select(calls=15)
    for case in ("flat", "box", "crossing"):
        r = out[case]
        assert 0.0 < r["cpu_p50_us"] <= r["cpu_p99_us"]
        geo = r["geometry_cpu_us"]
        assert 0.0 <= geo["p50_us"] <= geo["p99_us"]
    # flat ground is never looked up and no other leg is near: no geometry; beside the box the ground is
    assert out["flat"]["geometry_cpu_us"]["p99_us"] < out["box"]["geometry_cpu_us"]["p50_us"]
    assert out["box"]["geometry_cpu_us"]["p50_us"] < out["box"]["cpu_p50_us"]


def test_bench_reports_the_full_tier_analysis_of_every_replan():
    """full_analysis: the same cases with no reused selection (every replan analysed), the same first plans."""
    from planning.swing.bench import bench_full_analysis

    out = bench_full_analysis(calls=15)
    for case in ("flat", "box", "crossing"):
        r = out[case]
        assert isinstance(r, dict)
        assert 0.0 < r["cpu_p50_us"] <= r["cpu_p99_us"]
        assert r["evaluations_max"] <= r["evaluations_bound"]
        assert r["tier"] == "SUCCESS"
    assert out["flat"]["evaluations_max"] == 2
