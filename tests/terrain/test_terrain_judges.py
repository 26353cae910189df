"""The crossing judges (ground truth: no-step touchdowns, the terrain's span) and the terrain pipeline's refusals of
bad input (no long simulation)."""

from __future__ import annotations

import numpy as np
import pytest

from planning.sim.run import RunOptions, WalkCommand, WalkSession
from planning.terrain.crossing import no_step_details, no_step_flags, no_step_touchdowns, terrain_span_x
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


def test_no_step_details_say_why_a_contact_point_is_no_step() -> None:
    """no_step_details: the flags of no_step_flags, and why: the true ground's height spread around the point (an
    edge) and the point's height above the ground under it (held up on nothing, or on an obstacle)."""
    scene = build_terrain("stones")
    x0, _ = terrain_span_x(scene)
    pts = np.array([[x0 + 0.05, 1.0, 0.0], [0.5, 0.0, 0.0], [x0, 0.0, 0.0]])
    flags, spread, gap = no_step_details(scene, pts)
    assert flags.tolist() == no_step_flags(scene, pts).tolist() == [True, False, True]
    assert gap[0] > 0.03  # over the pit
    assert spread[1] == pytest.approx(0.0, abs=1e-9) and gap[1] == pytest.approx(
        0.0, abs=1e-9
    )  # the platform
    assert spread[2] > 0.04  # the platform's edge
    empty = no_step_details(scene, np.zeros((0, 3)))
    assert [a.size for a in empty] == [0, 0, 0]


@pytest.mark.parametrize("back_m", [0.027, 0.032, 0.043, 0.055, 0.075, 0.09])
def test_edge_distance_finds_the_platforms_edge_within_a_ring(back_m: float) -> None:
    """edge_distance: the smallest ring (EDGE_RINGS_M) around a contact point within which the true ground has an
    edge; a point back_m from the stones' start platform's edge finds it on the first ring at least that far out."""
    from planning.terrain.crossing import EDGE_RINGS_M, edge_distance

    scene = build_terrain("stones")
    x0, _ = terrain_span_x(scene)
    d = edge_distance(scene, np.array([[x0 - back_m, 0.0, 0.0]]))
    assert d[0] == min(r for r in EDGE_RINGS_M if r >= back_m)


def test_edge_distance_away_from_any_edge_and_on_none() -> None:
    from planning.terrain.crossing import edge_distance

    scene = build_terrain("stones")
    x0, _ = terrain_span_x(scene)
    d = edge_distance(scene, np.array([[x0 - 0.3, 0.0, 0.0], [x0 - 0.015, 0.5, 0.0]]))
    assert d[0] == np.inf and d[1] == 0.025  # 30 cm back: none within 10 cm; 1.5 cm back: the first ring
    assert edge_distance(scene, np.zeros((0, 3))).size == 0


def test_a_fall_by_touch_names_the_part_what_it_touched_and_where() -> None:
    """The run report's fall_contact: the robot's part, the world geom it touched and the contact point; the
    robot set down with its body's front in the clutter's first tall box falls at once on that box."""
    import mujoco

    session = WalkSession(
        WalkCommand(0.0, 0.0, 0.0, terrain_aware=False), RunOptions(terrain="clutter", duration_s=0.1)
    )
    m = session.world.model
    gid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, "terrain_obstacle_box_tall_0")
    centre, half = m.geom_pos[gid].copy(), m.geom_size[gid].copy()
    session.world.place(float(centre[0] - half[0] - 0.25), float(centre[1]), 0.0)
    rep = session.run()
    fc = rep["fall_contact"]
    assert rep["fell"] and fc is not None
    assert fc["touched"] == "terrain_obstacle_box_tall_0" and fc["part"] in rep["failure_reason"]
    assert fc["kind"] in ("trunk", "upper leg", "lower leg")
    point = np.array(fc["point_m"])
    assert np.all(np.abs(point - centre) <= half + 0.01)  # on the box
    assert isinstance(rep["no_step_events"], list)
    standing = WalkSession(WalkCommand(0.0, 0.0, 0.0, terrain_aware=False), RunOptions(duration_s=0.2)).run()
    assert not standing["fell"] and standing["fall_contact"] is None


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


def test_a_turn_round_that_does_not_come_round_in_time_is_given_up_for_the_walk() -> None:
    """The pipeline's turn watch (DecisionParams.turn_timeout_s): facing "back" with the body still facing its way
    (the barrier holding it) past the timeout: no other turn round in this walk, counted in the report; a turn that
    came round in time is not given up. The turn's footprint is the barrier's, from the robot."""
    import dataclasses

    from planning.steps import SteeringCommand
    from planning.terrain.bodypath import BodyPath
    from planning.terrain.decision import TerrainView, TerrainWorld
    from planning.terrain.maps import maps_from_grids

    session = WalkSession(WalkCommand(goal=(3.0, 0.0)), RunOptions(terrain="flat", duration_s=1.0))
    pipe = TerrainPipeline(session.robot, session.world.model, session.world.data, (3.0, 0.0), session.scene)
    assert pipe.decision_params.turn_circles_x_m == tuple(pipe.barrier_footprint.footprint_x_m)
    assert pipe.decision_params.turn_margin_m > PipelineParams().barrier.margin_m
    x = np.arange(0.0, 3.0, 0.05)
    path = BodyPath(np.column_stack([x, 0 * x]), 0 * x, x, "straight", True, 1.0)
    h = np.zeros((20, 20))
    pipe.world = TerrainWorld(maps_from_grids((0.0, -0.3), 0.03, h, h > 1), None, None, path)  # type: ignore[arg-type]
    view = TerrainView(
        t_s=0.0, p_world_body=np.array([0.0, 0.0, 0.5]), yaw=0.0, p_world_foot=np.zeros((4, 3)),
        v_world_foot=np.zeros((4, 3)), stance=np.ones(4, bool), z_contact=0.0, gait="trot", gait_since_s=0.0,
        fast_gait="trot", operator=SteeringCommand(), goal=np.array([3.0, 0.0]), pitch_rad=0.0, height_m=0.5,
        foot_radius_m=0.02, standing_height_m=0.52, p_body_hip=np.zeros((4, 2)), dt_s=0.01,
    )  # fmt: skip
    limit = pipe.decision_params.turn_timeout_s
    pipe._watch_turn(view, "back")  # the turn begins (the tick before faced forward)
    pipe.facing = "back"
    pipe._watch_turn(dataclasses.replace(view, t_s=limit - 1.0), "back")
    assert pipe.may_turn
    pipe._watch_turn(dataclasses.replace(view, t_s=limit + 0.5), "back")
    assert not pipe.may_turn and pipe.stats.summary()["turns_given_up"] == 1
    # a turn that came round (facing against its way) in time stands
    pipe.may_turn, pipe.facing = True, "forward"
    pipe._watch_turn(view, "back")
    pipe.facing = "back"
    pipe._watch_turn(dataclasses.replace(view, t_s=5.0, yaw=np.pi), "back")
    pipe._watch_turn(dataclasses.replace(view, t_s=limit + 5.0, yaw=np.pi - 0.8), "back")
    assert pipe.may_turn


def test_landings_near_the_start_platforms_edge_are_counted() -> None:
    """The run report's near_edge_landings: a blind trot at 0.1 m/s started with the front feet 6-10 cm from the
    stones' start platform's edge lands a foot with its sole within NEAR_EDGE_M of it (not a no-step landing) in
    at least two of three starts; landing_edge_min_m says how near; a slope has no edge at all."""
    from planning.robot import load_robot
    from planning.terrain.crossing import NEAR_EDGE_M

    robot = load_robot("spot")
    x0, _ = terrain_span_x(build_terrain("stones"))
    front_x = float(robot.nominal_stance_xy[0])
    hits = 0
    for back in (0.06, 0.08, 0.1):
        opts = RunOptions(terrain="stones", duration_s=1.2, start_offset=(x0 - front_x - back, 0.0, 0.0))
        r = WalkSession(WalkCommand(0.1, 0.0, 0.0, terrain_aware=False), opts).run()
        assert not r["fell"]
        assert 0 <= r["near_edge_landings"] <= r["steps_taken"] - r["no_step_touchdowns"]
        if r["near_edge_landings"]:
            hits += 1
            assert r["landing_edge_min_m"] <= robot.foot_radius_m + NEAR_EDGE_M + 1e-9
    assert hits >= 2
    slope = WalkSession(WalkCommand(0.3, 0.0, 0.0), RunOptions(terrain="slope", duration_s=1.0)).run()
    assert slope["near_edge_landings"] == 0 and slope["landing_edge_min_m"] is None
