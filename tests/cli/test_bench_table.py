"""The bench's plain-text table: terrain crossings and the stairs variants are printed with their verdicts and
no-step counts."""

from __future__ import annotations

from benchmarks.run import format_table


def test_table_prints_terrain_crossings_and_the_stairs_variants_count() -> None:
    result = {
        "stages": {},
        "terrain": {
            "stairs": {
                "crossed": True, "fell": False, "no_step_touchdowns": 0, "body_collisions": 0,
                "swing_collisions_per_100_steps": 0.0, "time_s": 12.56, "rtf": 1.1, "failure_reason": None,
                "step_qp_ms": {"p50": 2.5, "p99": 6.0, "bare_solver_p50": 0.4, "bare_solver_p99": 3.1, "solves": 700},
                "perception_ms": {"p50": 27.0, "p99": 31.0, "points": 11000},
            },
        },
        "stairs_variants": {
            "runs": 2,
            "crossed": 1,
            "by_variant": {
                "sensor y=+0.00": {"crossed": True, "time_s": 12.56, "failure_reason": None},
                "truth y=-0.08": {"crossed": False, "time_s": None, "failure_reason": "fell: RR_lleg_geom"},
            },
        },
        "clutter_variants": {
            "runs": 1,
            "crossed": 1,
            "by_variant": {"sensor seed 0": {"crossed": True, "time_s": 16.86, "failure_reason": None}},
        },
        "clutter_variants_shifted": {
            "runs": 1,
            "crossed": 0,
            "by_variant": {"sensor seed 0": {"crossed": False, "time_s": None, "failure_reason": "fell: trunk_geom"}},
        },
        "stones_variants": {
            "runs": 2,
            "crossed": 1,
            "by_variant": {
                "sensor seed 0": {
                    "crossed": True, "time_s": 22.08, "no_step_touchdowns": 0, "no_step_scuffs": 2,
                    "failure_reason": None,
                },
                "sensor seed 3": {"crossed": False, "time_s": None, "failure_reason": "fell: RR_lleg_geom"},
            },
        },
    }  # fmt: skip
    text = format_table(result)
    assert "terrain.stairs" in text and "crossed in 12.56 s" in text
    assert "stairs_variants          crossed 1 of 2" in text
    assert "stairs_variants.truth y=-0.08 fell: RR_lleg_geom" in text
    assert "clutter_variants         crossed 1 of 1" in text
    assert "clutter_variants.sensor seed 0 crossed in 16.86 s" in text
    assert "clutter_variants_shifted crossed 0 of 1" in text
    assert "clutter_variants_shifted.sensor seed 0 fell: trunk_geom" in text
    assert "stones_variants          crossed 1 of 2" in text
    assert "stones_variants.sensor seed 3 fell: RR_lleg_geom" in text
    # the no-step counts: landings, and the scuffs beside them
    assert "stones_variants.sensor seed 0 crossed in 22.08 s; no-step touchdowns 0 (scuffs 2)" in text
    assert "no-step touchdowns 0 (scuffs 0)" in text  # terrain.stairs, a result without the scuffs field
    # what the step QP and the perception cost in that walk, the QP beside OSQP's own solves
    assert "step QP in the loop: 700 replans, p50 2.5 ms p99 6.0 ms (bare OSQP p50 0.4 p99 3.1 ms)" in text
    assert "perception in the loop: p50 27.0 ms p99 31.0 ms, 11000 points a scan" in text
