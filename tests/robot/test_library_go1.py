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
