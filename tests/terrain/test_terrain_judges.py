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


def test_the_swing_replanning_runs_at_the_pipeline_s_rate_on_a_terrain_and_at_the_walk_s_off_it() -> None:
    """PipelineParams.swing_rate_hz sets the swing stage's rate on the pipeline's walk (perception at
    PipelineParams.perception_rate_hz); a walk off the pipeline keeps WalkParams.swing_rate_hz."""
    import dataclasses

    from planning.walk import WalkController, WalkParams

    on = WalkSession(WalkCommand(goal=(3.0, 0.0)), RunOptions(terrain="stairs", duration_s=1.0))
    rates = {st.name: st.rate_hz for st in on.loop.stages}
    assert rates["swing"] == pytest.approx(PipelineParams().swing_rate_hz)
    assert rates["perception"] == pytest.approx(PipelineParams().perception_rate_hz)
    assert rates["step_plan"] == pytest.approx(WalkParams().step_rate_hz)
    off = WalkSession(WalkCommand(0.3, 0.0, 0.0, terrain_aware=False), RunOptions(duration_s=1.0))
    rates = {st.name: st.rate_hz for st in off.loop.stages}
    assert rates["swing"] == pytest.approx(WalkParams().swing_rate_hz)
    assert "perception" not in rates
    # another rate on the pipeline: the controller's stage and its params follow it
    pipeline = on.pipeline
    pipeline.params = dataclasses.replace(pipeline.params, swing_rate_hz=250.0)
    controller = WalkController(on.robot)
    controller.use_terrain(pipeline)
    assert {st.name: st.rate_hz for st in controller.stages}["swing"] == pytest.approx(250.0)
    assert controller.params.swing_rate_hz == pytest.approx(250.0)
