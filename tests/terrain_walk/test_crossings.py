"""Closed loop in MuJoCo: terrain-aware walks to (6, 0) with the simulated depth sensor across the terrains the
pipeline crosses in every family draw (slope, rough, under-table: 50 of 50 each), as a rate over four variants.

Each crossing simulates ~13 s. Clean: no fall, no body collision, crossed (the body center 0.5 m past the terrain's
end) within 18 s, the goal reached, no no-step touchdown (ground-truth check). The claim is a rate (≥ 3 of 4), so a
last-bit floating-point difference between machines cannot flip it. Measured 2026-11-27 on this project's 2-core
machine: 4 of 4 (crossed at 8.5-11.3 s); about 14 s of CPU each.
"""

from __future__ import annotations

from typing import Any

import pytest
from terrain_rates import crossings

from planning.sim.run import RunOptions, WalkCommand

# (terrain, scene seed)
VARIANTS = [("slope", 0), ("rough", 0), ("under-table", 0), ("rough", 3)]
MIN_CLEAN = 3


@pytest.mark.sim
def test_terrain_crossings_with_the_sensor_at_a_rate() -> None:
    variants = [
        (
            f"{terrain} seed {seed}",
            WalkCommand(goal=(6.0, 0.0), terrain_sensor=True, stop_at_goal=True),
            RunOptions(terrain=terrain, seed=seed, duration_s=20.0),
        )
        for terrain, seed in VARIANTS
    ]

    def in_time(r: dict[str, Any]) -> str | None:
        t = r["time_to_cross_s"]
        return None if t is not None and t < 18.0 else f"crossed in {t} s (18 s allowed)"

    n, outcome, reports = crossings(variants, max_no_step=0, needed=MIN_CLEAN, check=in_time)
    for r in reports:
        nav = r["navigator"]
        assert nav["scans"] > 50 and nav["body_paths"] > 5, (
            nav
        )  # the sensor's scans and the body path, each run
    assert n >= MIN_CLEAN, outcome
