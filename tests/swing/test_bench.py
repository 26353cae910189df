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
