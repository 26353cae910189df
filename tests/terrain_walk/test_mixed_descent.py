"""Closed loop in MuJoCo with the depth sensor: down a flight whose foot lies within the slow gait's look-ahead of a
stone pit (the mixed family), as a rate.

On the mixed family's flights (a 0.6 m top, 2-4 risers of 0.11-0.15 m, then 0.4 m of floor before the pit) the
cadence switched to the slow gait as soon as the pit came within gap_ahead_m, mid-flight: the body slowed from the
climb gait's ~0.45 m/s to the crawl's 0.19 while a hind foot stepped down, its hip stayed behind the nosing, and the
shin came down on it (all 13 of the family's hind lower-leg falls, docs/terrain-notes.md, session 24). With the
switch waiting for the hind feet to finish the descent (DecisionParams.slow_drop_m) the same draws walk down and
onto the stones. Each walk runs 11 s (the falls came at 6.7-9.3 s): it passes when the body did not fall, stands
past the flight's last riser, and the slow gait waited (the run report's navigator.slow_gait_waits). Measured: 3 of
the first 3 (the verdict then settled); main without the rule: 0 of the first 2 (623 and 675: a hind lower leg at
6.8 s). The claim is a rate, >= 3 of 4, so a last-bit difference between machines cannot flip it. About 35-60 s.
"""

from __future__ import annotations

import pytest
from terrain_rates import until_decided

from planning.sim.run import RunOptions, WalkCommand, WalkSession
from planning.terrain.scenes import terrain_params
from planning.terrain.spec import load_terrain

# (terrain, seed): draws of sweeps/family-mixed.yaml that fell there on a hind lower leg, the switch mid-flight
DRAWS = [
    (0.1297, 2, "0.15..0.2", 623),
    (0.1501, 2, "0.25..0.3", 675),
    (0.1066, 3, "0.15..0.2", 492),
    (0.1128, 4, "0.25..0.3", 992),
]


def _last_riser_x(n_steps: int) -> float:
    """The x (m) of the flight's last riser going down (where the floor before the pit begins)."""
    p = terrain_params("mixed", n_steps=n_steps)
    return float(p.x_start_m + (2 * p.n_steps - 1) * p.tread_m + p.landing_m)


@pytest.mark.sim
def test_down_a_flight_before_a_pit_without_a_hind_shin_on_a_nosing_at_a_rate() -> None:
    ok = []
    for (riser, n_steps, gaps, seed), record in until_decided(DRAWS, needed=3):
        terrain = f"mixed:riser_m={riser},n_steps={n_steps},gap_m={gaps}"
        scene = load_terrain(terrain, seed=seed)
        sess = WalkSession(
            WalkCommand(goal=scene.goal_xy), RunOptions(terrain=terrain, seed=seed, duration_s=11.0)
        )
        r = sess.run()
        x_end = _last_riser_x(n_steps)
        x = float(sess.loop.state.p_world_body[0])
        waits = r["navigator"]["slow_gait_waits"]
        # down the flight without a fall, the slow gait having waited for the hind feet
        passed = not r["fell"] and x > x_end + 0.3 and waits > 0
        print(
            f"{terrain} seed {seed}: {r['failure_reason'] or 'no fall'}, body at x {x:.2f} (last riser {x_end:.2f}),"
            f" the slow gait waited {waits} ticks"
        )
        ok.append(passed)
        record(passed)
    assert sum(ok) >= 3, list(zip(DRAWS, ok, strict=False))
