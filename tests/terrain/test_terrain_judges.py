"""The crossing judges (ground truth: no-step touchdowns, the terrain's span) and the terrain pipeline's refusals of
bad input (no long simulation)."""

from __future__ import annotations

import numpy as np
import pytest

from planning.sim.run import RunOptions, WalkCommand, WalkSession
from planning.terrain.crossing import no_step_flags, no_step_touchdowns, terrain_span_x
from planning.terrain.decision import PipelineParams, TerrainPipeline
from planning.terrain.scenes import build_terrain


def test_no_step_flags_on_the_stones_ground_truth() -> None:
    scene = build_terrain("stones")
    x0, x1 = terrain_span_x(scene)
    assert (x0, x1) == (1.0, 5.0)
    # Held up over the pit (on nothing that is support), on the platform, straddling the platform's edge, and flat
    # on the pit floor (a support surface, however unwise).
    pts = np.array([[x0 + 0.05, 1.0, 0.0], [0.5, 0.0, 0.0], [x0, 0.0, 0.0], [x0 + 0.05, 1.0, -0.3]])
    flags = no_step_flags(scene, pts)
    assert flags.tolist() == [True, False, True, False]
    assert no_step_touchdowns(scene, list(pts)) == 2


@pytest.mark.parametrize("name", ["stairs", "stones", "clutter", "under-table", "slope", "rough"])
def test_terrain_span_lies_between_start_and_goal(name: str) -> None:
    x0, x1 = terrain_span_x(build_terrain(name))
    assert 0.5 <= x0 < x1 <= 5.2


def test_bad_goal_is_rejected_with_the_field_named() -> None:
    cmd = WalkCommand(goal=(3.0, 0.0), terrain_aware=True, terrain_sensor=False)
    session = WalkSession(cmd, RunOptions(terrain="flat", duration_s=1.0))
    with pytest.raises(ValueError, match="goal_xy"):
        TerrainPipeline(session.robot, session.world.model, session.world.data, (np.nan, 0.0), session.scene)
    with pytest.raises(ValueError, match="use_sensor"):
        TerrainPipeline(
            session.robot, session.world.model, session.world.data, (1.0, 0.0), None,
            PipelineParams(use_sensor=False),
        )  # fmt: skip
