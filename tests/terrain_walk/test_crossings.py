"""Closed loop in MuJoCo: terrain-aware walks to (6, 0) across the terrains that work, with the simulated sensor.

Each crossing simulates ~13 s (≈15–25 s of wall time on this machine). Bounds: no fall, no body collision, crossed
(the body center 0.5 m past the terrain's end), the goal reached, and no no-step touchdown (ground-truth check).
"""

from __future__ import annotations

import pytest

from planning.sim.run import RunOptions, WalkCommand, run_walk

MAX_NO_STEP_TOUCHDOWNS = 0


@pytest.mark.parametrize("terrain", ["slope", "rough", "under-table"])
def test_terrain_crossing(terrain: str) -> None:
    cmd = WalkCommand(goal=(6.0, 0.0), terrain_aware=True, terrain_sensor=True, stop_at_goal=True)
    r = run_walk(cmd, RunOptions(terrain=terrain, duration_s=20.0))
    assert not r["fell"], r["failure_reason"]
    assert r["body_collisions"] == 0
    assert r["crossed"] and r["time_to_cross_s"] is not None and r["time_to_cross_s"] < 18.0
    assert r["success"], r["failure_reason"]
    assert r["no_step_touchdowns"] <= MAX_NO_STEP_TOUCHDOWNS
    nav = r["navigator"]
    assert nav["scans"] > 50 and nav["body_paths"] > 10 and nav["invalid_paths"] == 0
    # the report's own timings: the depth scans' size, and the step QP's replans beside OSQP's solves in them
    assert nav["cloud_points_p50"] > 5000
    if nav["step_qp_solves"]:
        assert 0 < nav["step_qp_bare_solver_ms_p50"] <= nav["step_qp_ms_p50"]
