"""The shipped library on the project's smaller robot: the dynamic maneuvers (flight phases and bounds, the ones a
12.6 kg robot with 4x less torque finds hardest once scaled) run on `go1` through the same stack. The whole library
on both robots is the sweep `footfall sweep library-robots` (36 runs; 18 of 18 on go1, README's robot section)."""

from __future__ import annotations

import pytest

from planning.maneuver import find_maneuver, load_maneuver
from planning.sim.run import RunOptions, run_maneuver

pytestmark = pytest.mark.sim

DYNAMIC = ("jump", "pronk", "bound")


def test_the_dynamic_maneuvers_run_on_go1() -> None:
    reports = {
        name: run_maneuver(load_maneuver(find_maneuver(name)), RunOptions(robot="go1")) for name in DYNAMIC
    }
    ok = [n for n, r in reports.items() if r["success"] and not r["fell"]]
    assert len(ok) >= 2, {n: r["failure_reason"] for n, r in reports.items()}
    for r in reports.values():
        assert r["robot"] == "go1"


def test_go1_stands_through_a_10_ns_sideways_push_on_its_planner() -> None:
    # 10 N·s on 12.6 kg moves the capture point ~0.135 m sideways, past the feet (±0.127 m): the generator's push
    # recovery (short horizon, a foot may unload) keeps the solver's plan driving; without it the backup
    # controller drove 12% of the run (a failure by the 5% rule)
    from planning.sim.run import ManeuverSession, backup_share
    from planning.sim.world import Push

    ok = 0
    for fy in (100.0, -100.0):
        sess = ManeuverSession(
            load_maneuver(find_maneuver("stand")),
            RunOptions(robot="go1", duration_s=2.5, pushes=(Push(1.0, (0.0, fy, 0.0), 0.1),)),
        )
        rep = sess.run()
        assert not rep["fell"]
        assert sess.generator.recovery_ticks > 0  # the push was recognized
        ok += bool(rep["success"] and backup_share(rep["solver"]) <= 0.05)
    assert ok == 2
