"""Closed loop in MuJoCo: down a flight of tall risers backward (WalkCommand.descend_backward, the default).

Three staircases 2 m wide without railings, 3 steps of 0.17-0.19 m up and down with a 1.5 m top landing, walked to
1 m past their end with the depth sensor: on the top landing the body turns round in place (there is room for its
footprint) and goes down facing up the stairs (its knees point
back, so a leg stepping down backward leans its shank away from the nosing it steps off). Each walk must cross
clean (no fall, no body collision, no no-step touchdown, the goal reached) having walked backward for a while
(`navigator.backward_s`). The claim is a rate (≥ 2 of 3), so that a last-bit floating-point difference between
machines cannot flip it; the stairs family's rate with the rule is in the README (Terrain).
"""

from __future__ import annotations

import pytest
from terrain_rates import until_decided

from planning.sim.run import RunOptions, WalkCommand, run_walk
from planning.terrain.spec import load_terrain

# (riser m, tread m, goal y m)
FLIGHTS = [
    (0.17, 0.30, 0.0),
    (0.18, 0.34, -0.1),
    (0.19, 0.32, 0.1),
]
N_STEPS = 3
MIN_CLEAN = 2


@pytest.mark.sim
def test_a_flight_of_tall_risers_is_walked_down_backward_at_a_rate() -> None:
    clean = []
    for (riser, tread, gy), record in until_decided(FLIGHTS, MIN_CLEAN):
        terrain = f"stairs:riser_m={riser},tread_m={tread},n_steps={N_STEPS},railings=false,width_m=2.0,landing_m=1.5"
        x_goal = load_terrain(terrain).span_x[1] + 1.0
        cmd = WalkCommand(goal=(x_goal, gy), terrain_aware=True, stop_at_goal=True, descend_backward=True)
        r = run_walk(cmd, RunOptions(terrain=terrain, duration_s=45.0))
        ok = r["success"] and not r["fell"] and r["body_collisions"] == 0 and r["no_step_touchdowns"] == 0
        clean.append(bool(ok and r["navigator"]["backward_s"] > 2.0))
        record(clean[-1])
    assert sum(clean) >= MIN_CLEAN, list(zip(FLIGHTS, clean, strict=False))
