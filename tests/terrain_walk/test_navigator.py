"""Navigator pieces (no long simulation): keep-outs, path following, crouching, step-QP footholds, crossing checks."""

from __future__ import annotations

import numpy as np
import pytest

from planning.sim.run import RunOptions, WalkCommand, WalkSession
from planning.steps import SteeringCommand
from planning.steps.state import StepPath
from planning.terrain.bodypath import plan_body_path
from planning.terrain.crossing import no_step_flags, no_step_touchdowns, terrain_span_x
from planning.terrain.maps import maps_from_grids
from planning.terrain.navigate import (
    NavigatorParams,
    TerrainNavigator,
    corridor_middle,
    shin_keepout,
    with_keepouts,
)
from planning.terrain.scenes import build_terrain

RES = 0.03


def _grid(nx: int = 120, ny: int = 80, x0: float = -1.0, y0: float = -1.2) -> tuple[np.ndarray, np.ndarray]:
    return x0 + np.arange(nx) * RES, y0 + np.arange(ny) * RES


def _session(terrain: str = "flat", goal: tuple[float, float] = (3.0, 0.0)) -> WalkSession:
    cmd = WalkCommand(goal=goal, terrain_aware=True, terrain_sensor=False)
    return WalkSession(cmd, RunOptions(terrain=terrain, duration_s=1.0))


def test_shin_keepout_is_behind_a_step_up_only() -> None:
    xs, ys = _grid()
    h = np.where(xs[:, None] >= 1.0, 0.15, 0.0) * np.ones((1, ys.size))
    maps = maps_from_grids((xs[0], ys[0]), RES, h, np.zeros(h.shape, bool))
    keep = shin_keepout(maps, yaw=np.pi, slope=0.875, radius_m=0.04, reach_m=0.27)  # walking toward -x: down
    col = keep[:, 40]
    # facing -x, the shin trails toward +x: the cells just below the step (x < 1) are blocked, about 0.12 m of them
    blocked_x = xs[col]
    assert blocked_x.size > 0 and blocked_x.max() < 1.0
    assert 0.09 <= 1.0 - blocked_x.min() <= 0.2
    # facing +x (up the step), the step is ahead of the foot: nothing is blocked
    assert not shin_keepout(maps, 0.0, 0.875, 0.04, 0.27).any()


def test_keepouts_grow_step_obstacles_by_the_foot_margin() -> None:
    xs, ys = _grid()
    step = (np.abs(xs[:, None] - 0.5) < 0.05) & (np.abs(ys[None, :]) < 0.05)
    maps = maps_from_grids((xs[0], ys[0]), RES, np.zeros(step.shape), step)
    grown = with_keepouts(maps, 0.0, 0.875, 0.04, 0.27, foot_margin_m=0.06)
    assert grown.step_obstacle.sum() > step.sum()
    assert bool(grown.no_step(0.5, 0.09)) and not bool(maps.no_step(0.5, 0.09))
    assert float(grown.sdf_step(0.5, 0.0)) < float(maps.sdf_step(0.5, 0.0))


def test_command_follows_the_path_and_stops_at_the_goal() -> None:
    session = _session()
    nav: TerrainNavigator = session.navigator
    s = session.loop.state
    nav.path = plan_body_path(None, s.p_world_body[:2], s.yaw, nav.goal)
    cmd = nav.command(s)
    assert cmd.vx > 0.1 and abs(cmd.vy) < 0.05 and abs(cmd.yaw_rate) < 1e-6
    assert cmd.vx <= nav.params.max_speed_mps + 1e-9
    s.p_world_body[:2] = nav.goal + 0.01
    stop = nav.command(s)
    assert stop.vx == 0.0 and stop.vy == 0.0


def test_command_slows_where_the_step_map_is_dense() -> None:
    session = _session()
    nav: TerrainNavigator = session.navigator
    s = session.loop.state
    xs, ys = _grid()
    nav.path = plan_body_path(None, s.p_world_body[:2], s.yaw, nav.goal)
    free = maps_from_grids(
        (xs[0], ys[0]), RES, np.zeros((xs.size, ys.size)), np.zeros((xs.size, ys.size), bool)
    )
    dense = maps_from_grids(
        (xs[0], ys[0]),
        RES,
        np.zeros((xs.size, ys.size)),
        (np.arange(xs.size)[:, None] % 3 == 0) & (ys[None] < 9),
    )
    nav.maps = free
    fast = nav.command(s).vx
    nav.maps = dense
    slow = nav.command(s).vx
    assert slow < 0.8 * fast
    assert slow >= nav.params.min_speed_mps - 1e-9


def test_command_waits_for_a_foot_left_behind() -> None:
    session = _session()
    nav: TerrainNavigator = session.navigator
    s = session.loop.state
    nav.path = plan_body_path(None, s.p_world_body[:2], s.yaw, nav.goal)
    full = nav.command(s).vx
    lo, hi = nav.params.lag_slow_m
    hips = s.p_world_body[:2] + nav.p_body_hip_xy
    s.p_world_foot[3, :2] = hips[3] - [
        (lo + hi) / 2,
        0.0,
    ]  # RR, in stance, trails its hip halfway into the band
    half = nav.command(s).vx
    assert half == pytest.approx(full / 2, rel=0.05)
    s.p_world_foot[3, :2] = hips[3] - [hi + 0.02, 0.0]
    assert nav.command(s).vx == 0.0  # the body waits for that foot
    nav.controller.handler.stance[3] = False  # the same foot in the air (its step under way) does not hold it
    assert nav.command(s).vx == pytest.approx(full)


def test_a_sideways_path_beside_a_box_keeps_its_direction_in_the_walk() -> None:
    """In the walk (sideways limit 0.19 m/s) a path leg at 45° to the right: with a box straight ahead, clipping
    vy alone would walk the body into it, so the whole velocity is scaled and keeps the path's direction; in the
    open the clipped command (more forward progress) stands."""
    session = _session(goal=(3.0, -3.0))
    nav: TerrainNavigator = session.navigator
    s = session.loop.state
    nav.controller.set_gait("walk")
    nav.controller.planner.clock.advance(0.0)
    nav.path = plan_body_path(None, s.p_world_body[:2], s.yaw, nav.goal)
    xs, ys = _grid()
    h = np.zeros((xs.size, ys.size))
    nothing = np.zeros(h.shape, bool)
    box = (np.abs(xs[:, None] - 0.75) < 0.15) & (np.abs(ys[None, :]) < 0.3)
    walk = nav._steered_gait()
    assert walk.name == "walk"
    lim = nav.controller.planner.steering.limit(SteeringCommand(1.0, -1.0, 0.0), walk)

    nav.maps = maps_from_grids((xs[0], ys[0]), RES, h, nothing, box)
    kept = nav.command(s)
    assert kept.vy < 0.0 and kept.vx == pytest.approx(-kept.vy, rel=0.02)  # 45°, as the path
    assert abs(kept.vy) <= abs(lim.vy) + 1e-9

    nav.maps = maps_from_grids((xs[0], ys[0]), RES, h, nothing, nothing)
    open_ground = nav.command(s)
    assert open_ground.vx > kept.vx + 0.01 and open_ground.vx == pytest.approx(-open_ground.vy, rel=0.02)
    limited = nav.controller.planner.steering.limit(open_ground, walk)
    assert limited.vx > abs(limited.vy) + 0.01  # the steering filter then clips it off the diagonal


def test_body_height_is_lowered_under_an_overhang_only() -> None:
    session = _session()
    nav: TerrainNavigator = session.navigator
    s = session.loop.state
    xs, ys = _grid()
    maps = maps_from_grids(
        (xs[0], ys[0]), RES, np.zeros((xs.size, ys.size)), np.zeros((xs.size, ys.size), bool)
    )
    nav.maps = maps
    nav._update_height(s)
    assert session.controller.height == pytest.approx(nav.standing_height)
    clearance = np.where((xs[:, None] > 0.3) & (np.abs(ys[None]) < 0.7), 0.60, np.inf) * np.ones((1, ys.size))
    nav.maps = maps_from_grids((xs[0], ys[0]), RES, maps.ground_height, maps.step_obstacle)
    object.__setattr__(nav.maps, "clearance_m", clearance)
    nav._update_height(s)
    p = nav.params
    assert session.controller.height == pytest.approx(0.60 - p.body_top_m - p.head_margin_m)
    assert session.controller.height >= p.min_height_m


def test_a_remembered_overhang_keeps_the_crouch_after_it_drops_out_of_the_maps() -> None:
    # The sensor sees a table top only from a distance; under it, the voxel map forgets it.
    session = _session()
    nav: TerrainNavigator = session.navigator
    s = session.loop.state
    xs, ys = _grid()
    flat = np.zeros((xs.size, ys.size))
    clearance = np.where((xs[:, None] > 0.3) & (np.abs(ys[None]) < 0.7), 0.60, np.inf) * np.ones((1, ys.size))
    nav.maps = maps_from_grids((xs[0], ys[0]), RES, flat, np.zeros(flat.shape, bool))
    object.__setattr__(nav.maps, "clearance_m", clearance)
    nav._update_height(s)
    crouched = session.controller.height
    assert crouched < nav.standing_height - 0.05
    nav.maps = maps_from_grids((xs[0], ys[0]), RES, flat, np.zeros(flat.shape, bool))  # no overhang seen now
    nav._update_height(s)
    assert session.controller.height == pytest.approx(crouched)


def test_an_overhang_lower_than_the_feet_is_no_ceiling() -> None:
    # Over a pit, the side of a stone seen from afar sits a little above the pit floor: not a ceiling.
    session = _session()
    nav: TerrainNavigator = session.navigator
    s = session.loop.state
    xs, ys = _grid()
    pit = np.where(xs[:, None] > 0.3, -0.3, 0.0) * np.ones((1, ys.size))
    clearance = np.where(xs[:, None] > 0.3, 0.32, np.inf) * np.ones((1, ys.size))  # 2 cm above the stone tops
    nav.maps = maps_from_grids((xs[0], ys[0]), RES, pit, np.zeros(pit.shape, bool))
    object.__setattr__(nav.maps, "clearance_m", clearance)
    nav._update_height(s)
    assert session.controller.height == pytest.approx(nav.standing_height)


def test_body_pitch_target_follows_the_slope_with_a_bounded_rate() -> None:
    session = _session()
    nav: TerrainNavigator = session.navigator
    s = session.loop.state
    xs, ys = _grid()
    slope = np.tan(np.radians(10.0))
    h = (xs[:, None] - s.p_world_body[0]) * slope * np.ones((1, ys.size))
    nav.maps = maps_from_grids((xs[0], ys[0]), RES, h, np.zeros(h.shape, bool))
    p = nav.params
    nav._update_pitch(s)
    assert session.controller.pitch == pytest.approx(-p.max_pitch_rate_rps / p.perception_rate_hz)
    for _ in range(20):
        nav._update_pitch(s)
    assert session.controller.pitch == pytest.approx(-np.radians(10.0), abs=0.01)  # nose up, uphill


def test_step_qp_moves_planned_footholds_off_no_step_cells() -> None:
    session = _session()
    c = session.controller
    nav: TerrainNavigator = session.navigator
    loop = session.loop
    for _ in range(300):  # 0.6 s: standing up and starting to walk on flat maps
        loop.step()
    sel = c.planner.last
    assert sel is not None and sel.path.n_touchdowns >= 8
    # A no-step patch around every planned touchdown of the first 8 (of the unrefined selection).
    xs, ys = _grid(nx=200, ny=100, x0=-1.0, y0=-1.5)
    X, Y = np.meshgrid(xs, ys, indexing="ij")
    step = np.zeros(X.shape, bool)
    path: StepPath = sel.path
    order = np.lexsort((path.leg, path.t_touchdown))[:8]
    for p in path.p_world_touchdown[order]:
        step |= np.hypot(X - p[0], Y - p[1]) < 0.05
    nav.maps = maps_from_grids((xs[0], ys[0]), RES, np.zeros(X.shape), step)
    refined = nav.refine(loop.state, sel)
    assert refined.path.kind.endswith("+qp")
    t_rel = path.t_touchdown[order] - loop.state.t
    moved = [k for j, k in enumerate(order) if t_rel[j] >= nav.params.qp_min_time_s]
    assert moved
    new = refined.path.p_world_touchdown[moved]
    assert not np.any(np.asarray(nav.maps.no_step(new[:, 0], new[:, 1]), dtype=bool))
    assert np.all(np.linalg.norm(new[:, :2] - path.p_world_touchdown[moved, :2], axis=1) < 0.15)


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
    session = _session()
    with pytest.raises(ValueError, match="goal_xy"):
        TerrainNavigator(
            session.controller, session.world.model, session.world.data, (np.nan, 0.0), session.scene
        )
    with pytest.raises(ValueError, match="use_sensor"):
        TerrainNavigator(
            session.controller, session.world.model, session.world.data, (1.0, 0.0), None,
            NavigatorParams(use_sensor=False),
        )  # fmt: skip


def test_corridor_middle_centres_between_railings_and_leaves_open_ground_alone() -> None:
    """Between two railings (body obstacles at y = ±0.67) a point 10 cm right of the middle is moved 10 cm left,
    whichever way the body faces along the corridor; turned 90° the same railings leave no span to center in
    (none across the heading), nor does open ground or a point inside an obstacle."""
    offsets = np.linspace(-0.8, 0.8, 81)

    def rails(x: np.ndarray, y: np.ndarray) -> np.ndarray:
        return 0.65 - np.abs(np.asarray(y))  # > 0 between the railings' inner faces at ±0.65

    shift = corridor_middle(rails, np.array([2.0, -0.10]), 0.0, offsets)
    assert np.allclose(shift, [0.0, 0.10], atol=0.011)
    shift = corridor_middle(rails, np.array([2.0, 0.10]), np.pi, offsets)  # walking the other way
    assert np.allclose(shift, [0.0, -0.10], atol=0.011)
    assert np.allclose(corridor_middle(rails, np.array([2.0, -0.1]), np.pi / 2, offsets), 0.0)
    assert np.allclose(corridor_middle(lambda x, y: np.ones_like(x), np.array([2.0, 0.0]), 0.0, offsets), 0.0)
    assert np.allclose(corridor_middle(rails, np.array([2.0, 0.7]), 0.0, offsets), 0.0)


def test_the_studio_overlays_show_the_navigators_maps_path_and_footholds() -> None:
    """Walking to (6, 0) over the stones on ground-truth maps, 5 s in (the front feet at the first stone): the plan
    overlays outline the navigator's own no-step cells near the body, draw its body path to the goal, and the step
    QP's footholds it is refining now."""
    cmd = WalkCommand(goal=(6.0, 0.0), terrain_aware=True, terrain_sensor=False, stop_at_goal=True)
    session = WalkSession(cmd, RunOptions(terrain="stones", duration_s=10.0))
    while session.world.data.time < 5.0:
        session.loop.step()
    nav: TerrainNavigator = session.navigator
    ov = session.controller.plan_overlays()
    no_step = np.asarray(ov["terrain_no_step"]["points"])
    assert len(no_step) > 100
    assert np.all(np.asarray(nav.maps.no_step(no_step[:, 0], no_step[:, 1]), dtype=bool))
    body_xy = session.loop.state.p_world_body[:2]
    assert np.all(np.hypot(*(no_step[:, :2] - body_xy).T) < 2.3)
    path = np.asarray(ov["body_path_plan"]["points"])
    np.testing.assert_allclose(path[-1, :2], [6.0, 0.0], atol=0.1)
    assert nav.last_plan is not None
    feet = np.asarray(ov["step_qp_footholds"]["points"])
    np.testing.assert_allclose(feet, np.round(nav.last_plan.footholds, 3))
    assert "depth_cloud" not in ov  # ground-truth maps: no scan
