"""Terrain-aware steering in MuJoCo: the operator's velocity command on a terrain (no goal, no body path), the
terrain pipeline under it (depth sensor, steppable regions, footholds by the step QP, the body's height from the
overhangs it saw); rates over variants, never one walk. The stop short of body obstacles is unit-tested in
tests/terrain/test_terrain_steering.py."""

from __future__ import annotations

import pytest
from terrain_rates import until_decided

from planning.sim.run import RunOptions, WalkCommand, run_walk
from planning.terrain.decision import DecisionParams

TABLE_CLEARANCES = (0.56, 0.58, 0.60, 0.62)  # m: the table's underside
MIN_TABLES = 3


@pytest.mark.sim
def test_steered_under_tables_with_the_sensor_at_a_rate() -> None:
    """Steered straight ahead at 0.5 m/s under tables 0.56-0.62 m high with the depth sensor: the body height target
    comes down to keep the body's top and the head margin under the table, and the body comes out past it with no
    fall and no body collision. Measured 4 of 4 (2026-11-27, crossed at 8.4 s each); the bound leaves one."""
    q = DecisionParams()
    ok = {}
    for c, record in until_decided(TABLE_CLEARANCES, MIN_TABLES):
        r = run_walk(
            WalkCommand(vx=0.5, terrain_sensor=True),
            RunOptions(terrain=f"under-table:clearance_m={c}", duration_s=11.0),
        )
        nav = r["navigator"]
        assert nav["body_paths"] == 0  # steered: no path planning
        crouched = nav["min_body_height_target_m"] <= c - q.body_top_m - q.head_margin_m + 0.005
        good = not r["fell"] and r["body_collisions"] == 0 and r["crossed"] and crouched
        ok[c] = (
            True
            if good
            else (r["failure_reason"] or f"crossed {r['crossed']}, {r['body_collisions']}, {nav}")
        )
        print(f"steered under a {c} m table: {ok[c]}")
        record(ok[c] is True)
    assert sum(v is True for v in ok.values()) >= MIN_TABLES, ok


STEERED_STAIRS_SPEEDS = (0.3, 0.4, 0.45, 0.5)  # m/s
MIN_STEERED_STAIRS = 2


@pytest.mark.sim
def test_steered_over_the_stairs_with_the_sensor_at_a_rate() -> None:
    """Steered straight ahead (no goal) at 0.3-0.5 m/s with the depth sensor up the default stairs (four risers, a
    landing, four down): the pipeline's speed rule keeps the body below the command on the stairs and its footholds
    carry it up and down. Clean: crossed, no fall, no body collision, no landing in a no-step place. Measured
    2026-11-27 on this project's 2-core machine: 3 of 4 (0.4, 0.45, 0.5 m/s crossed at 12.8-14.1 s, mean 0.37-0.42
    m/s; 0.3 m/s fell going down at 14.4 s, a hind lower leg on a nosing); about 16 s of CPU each."""
    ok = {}
    for vx, record in until_decided(STEERED_STAIRS_SPEEDS, MIN_STEERED_STAIRS):
        r = run_walk(WalkCommand(vx=vx, terrain_sensor=True), RunOptions(terrain="stairs", duration_s=16.0))
        good = (
            not r["fell"]
            and r["crossed"]
            and r["body_collisions"] == 0
            and r["no_step_touchdowns"] == 0
            and r["mean_velocity"]["vx"] < vx
        )
        ok[vx] = (
            True if good else (r["failure_reason"] or f"crossed {r['crossed']}, {r['no_step_touchdowns']}")
        )
        print(f"steered stairs at {vx} m/s: {ok[vx]}")
        record(ok[vx] is True)
    assert sum(v is True for v in ok.values()) >= MIN_STEERED_STAIRS, ok
