"""The run options a sweep varies reach the simulation: start pose offsets, friction, scene parameters, pushes."""

from __future__ import annotations

import math

import numpy as np
import pytest

from planning.maneuver import find_maneuver, load_maneuver
from planning.sim.run import ManeuverSession, RunOptions


def test_start_offset_friction_and_terrain_params_reach_the_world() -> None:
    opts = RunOptions(terrain="stairs:riser_m=0.11,n_steps=3", start_offset=(0.3, -0.2, 0.5),
                      friction=0.35, duration_s=0.01)  # fmt: skip
    s = ManeuverSession(load_maneuver(find_maneuver("stand")), opts)
    w = s.world
    assert s.scene.params.riser_m == pytest.approx(0.11) and s.scene.params.n_steps == 3
    q = w.data.qpos[w.free_qpos : w.free_qpos + 7]
    assert q[:2] == pytest.approx([0.3, -0.2])
    yaw = math.atan2(2 * (q[3] * q[6] + q[4] * q[5]), 1 - 2 * (q[5] ** 2 + q[6] ** 2))
    assert yaw == pytest.approx(0.5, abs=1e-6)
    assert np.allclose(w.model.geom_friction[w.foot_geom, 0], 0.35)
    floor = [g for g, n in enumerate(w.geom_names) if n == "terrain_floor"]
    assert np.allclose(w.model.geom_friction[floor, 0], 0.35)
    r = s.run()
    assert r["duration_s"] == pytest.approx(0.01, abs=0.003)
