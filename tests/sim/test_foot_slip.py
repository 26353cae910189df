"""Foot slip detection (planning.handler, HandlerParams.slip_*): stance feet sliding on a slippery floor are flagged
in the run report, and the forces then assume less friction, so the trot keeps its feet."""

from __future__ import annotations

import pytest

from planning.sim.run import RunOptions, WalkCommand, run_walk


def test_trots_at_1_mps_on_a_0_3_floor_detecting_its_slips() -> None:
    """Floor friction 0.3 (the forces assume 0.6): the first stance feet slide within 0.25 s; the slips are
    detected and reported per leg with their times, the assumed friction drops, and the trot holds 1.0 m/s without
    a fall (the default floor's trot flags none: tests/sim/test_walk_fast.py; measured here: 2 slips at 0.21 s; with the reaction off it fell at 0.7 s, as did 0.5 m/s on 0.3, 1.0 on
    0.25 and 0.2, 1.5 on 0.3: 0 of 5 held against 5 of 5)."""
    rep = run_walk(WalkCommand(1.0, settle_s=1.5), RunOptions(duration_s=3.5, friction=0.3))
    assert rep["success"] and not rep["fell"], rep["failure_reason"]
    slips = rep["foot_slips"]
    assert slips["count"] >= 1
    assert sum(slips["per_leg"].values()) == slips["count"] == len(slips["events"])
    assert all(0.0 < e["t"] < 3.5 and e["duration_s"] > 0.0 for e in slips["events"])
    assert slips["friction_scale_min"] < 1.0
    assert rep["mean_velocity"]["vx"] == pytest.approx(1.0, rel=0.10)
