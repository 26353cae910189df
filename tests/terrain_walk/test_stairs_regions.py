"""Closed loop in MuJoCo: the terrain pipeline up staircases, as a rate.

Four climbs of 3 steps with the depth sensor (the product default), risers 0.11-0.16 m, treads 0.30-0.39 m, with and
without railings, each onto a 2 m top landing with the goal 0.8 m along it (the whole body on the landing): no
fall, no body collision, no no-step touchdown, the goal reached. Measured 3 of 4 (2026-11-26, the 0.11 m riser
without railings falls climbing); the claim is a rate (≥ 2 of 4) so that a last-bit floating-point difference
between machines cannot flip it. The stairs family (50 random staircases up and down) is measured with
`footfall sweep` (README, Terrain).
"""

from __future__ import annotations

import pytest
from terrain_rates import until_decided

from planning.sim.run import RunOptions, WalkCommand, run_walk
from planning.terrain.spec import load_terrain

# (riser m, tread m, railings, goal y m)
CLIMBS = [
    (0.11, 0.34, False, 0.2),
    (0.12, 0.39, False, -0.2),
    (0.14, 0.30, True, 0.1),
    (0.16, 0.38, True, 0.0),
]
N_STEPS = 3
MIN_CLEAN = 2


@pytest.mark.sim
def test_regions_pipeline_climbs_staircases_at_a_rate() -> None:
    clean = []
    for (riser, tread, rails, gy), record in until_decided(CLIMBS, MIN_CLEAN):
        terrain = (
            f"stairs:riser_m={riser},tread_m={tread},n_steps={N_STEPS},railings={str(rails).lower()},"
            "x_start_m=0.6,landing_m=2.0"
        )
        x_goal = load_terrain(terrain).span_x[0] + N_STEPS * tread + 0.8
        cmd = WalkCommand(goal=(x_goal, gy), terrain_aware=True, stop_at_goal=True)
        r = run_walk(cmd, RunOptions(terrain=terrain, duration_s=11.0))
        assert r["navigator"]["pipeline"] == "regions"
        clean.append(
            bool(
                r["success"] and not r["fell"] and r["body_collisions"] == 0 and r["no_step_touchdowns"] == 0
            )
        )
        record(clean[-1])
    assert sum(clean) >= MIN_CLEAN, list(zip(CLIMBS, clean, strict=False))
