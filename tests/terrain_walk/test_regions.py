"""Closed loop in MuJoCo: the terrain pipeline, as a rate over variants; the removed modes refused by name.

Four walks on the scenes' ground-truth maps (≈8 s simulated each): up the slope onto its plateau (goal at x = 3 m) and over rough
ground of two seeds. The claim is a rate, ≥ 3 of 4 clean (no fall, no body collision, no no-step touchdown, the
goal reached), so a last-bit floating-point difference between machines cannot flip it.
"""

from __future__ import annotations

import pytest
from terrain_rates import until_decided

from planning.sim.run import RunOptions, WalkCommand, run_walk

VARIANTS = [
    ("slope", 0, (3.0, -0.05)),
    ("slope", 0, (3.0, 0.05)),
    ("rough", 1, (4.5, 0.0)),
    ("rough", 2, (4.5, 0.0)),
]
MIN_CLEAN = 3
MIN_TABLES = 2  # of the three clearances below


@pytest.mark.sim
def test_regions_pipeline_crosses_slopes_and_rough_ground_at_a_rate() -> None:
    clean = []
    for (terrain, seed, goal), record in until_decided(VARIANTS, MIN_CLEAN):
        cmd = WalkCommand(goal=goal, terrain_aware=True, terrain_sensor=False, stop_at_goal=True)
        r = run_walk(cmd, RunOptions(terrain=terrain, seed=seed, duration_s=14.0))
        nav = r["navigator"]
        assert nav["pipeline"] == "regions" and nav["scans"] > 20 and nav["footholds_ms_p50"] is not None
        clean.append(
            bool(
                r["success"] and not r["fell"] and r["body_collisions"] == 0 and r["no_step_touchdowns"] == 0
            )
        )
        record(clean[-1])
    assert sum(clean) >= MIN_CLEAN, list(zip(VARIANTS, clean, strict=False))


def test_the_removed_modes_are_refused_by_name_and_regions_still_accepted() -> None:
    from planning.sweep.spec import SweepSpecError, parse_spec

    def spec(pipeline: str) -> dict[str, object]:
        walk = {"goal": "terrain", "maps": "sensor", "terrain_pipeline": pipeline}
        return {
            "format": "footfall/sweep@1",
            "name": "s",
            "run": {"walk": walk},
            "defaults": {"terrain": "stairs"},
        }

    with pytest.raises(SweepSpecError, match="terrain_pipeline.*removed: there is one terrain pipeline"):
        parse_spec(spec("modes"))
    assert parse_spec(spec("regions")).name == "s"  # old specs still run


@pytest.mark.sim
def test_regions_pipeline_crouches_under_tables_it_no_longer_sees_at_a_rate() -> None:
    # with the depth sensor: the cameras lose a table's top once the body is under it, and the pipeline keeps the
    # undersides it saw (OverhangMemory); before, every clearance below 0.61 m stood the body up into the table
    clearances = [0.56, 0.58, 0.60]
    clean = []
    for c, record in until_decided(clearances, MIN_TABLES):
        cmd = WalkCommand(goal=(6.0, 0.0), terrain_aware=True, stop_at_goal=True)
        r = run_walk(cmd, RunOptions(terrain=f"under-table:clearance_m={c}", duration_s=16.0))
        assert r["navigator"]["pipeline"] == "regions"
        clean.append(bool(r["success"] and not r["fell"] and r["body_collisions"] == 0))
        record(clean[-1])
    assert sum(clean) >= MIN_TABLES, list(zip(clearances, clean, strict=False))
