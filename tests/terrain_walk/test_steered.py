"""Terrain-aware steering: the operator's velocity command on a terrain (no goal), the terrain pipeline under it
(maps from the depth sensor, regions, footholds by the step QP), its speed capped by the terrain speed; rates over
variants, never one walk."""

from __future__ import annotations

import pytest

from planning.sim.run import RunOptions, WalkCommand, run_walk

# (clearance m): under-table variants steered straight ahead at 0.5 m/s
TABLE_CLEARANCES = (0.56, 0.58, 0.60, 0.62)
MIN_TABLES = 3


@pytest.mark.sim
def test_steered_under_tables_with_the_sensor_at_a_rate() -> None:
    """Steered straight ahead at 0.5 m/s (no goal) with the depth sensor under tables 0.56-0.62 m high: the body
    crouches under each and comes out past it, no fall, no body collision, no body path planned (steered)."""
    ok = {}
    for c in TABLE_CLEARANCES:
        r = run_walk(
            WalkCommand(vx=0.5, terrain_sensor=True),
            RunOptions(terrain=f"under-table:clearance_m={c}", duration_s=11.0),
        )
        nav = r["navigator"]
        assert nav["body_paths"] == 0  # steered: no path planning
        good = (
            not r["fell"]
            and r["body_collisions"] == 0
            and r["crossed"]
            and nav["min_body_height_target_m"] < 0.47
        )
        ok[c] = (
            True
            if good
            else (r["failure_reason"] or f"crossed {r['crossed']}, {r['body_collisions']}, {nav}")
        )
        print(f"steered under a {c} m table: {ok[c]}")
    assert sum(v is True for v in ok.values()) >= MIN_TABLES, ok
