"""Terrain-aware steering: the operator's velocity command on a terrain, with the maps, the modes and the step QP
under it; the speed capped where the terrain asks for it and the body stopped short of obstacles."""

from __future__ import annotations

from types import SimpleNamespace
from typing import Any

import numpy as np

from planning.sim.run import RunOptions, WalkCommand, run_walk
from planning.sim.world import RobotState
from planning.steps import SteeringCommand
from planning.terrain.maps import maps_from_grids
from planning.terrain.navigate import NavigatorParams, TerrainNavigator

RES = 0.03


def _wall_maps(x_wall: float) -> object:
    """Flat ground from (-1, -1.5) with a body-obstacle wall across y from x_wall on (not marked no-step, so the
    slowdown in dense no-step areas stays out of the way)."""
    xs = -1.0 + np.arange(120) * RES
    ys = -1.5 + np.arange(100) * RES
    body = np.broadcast_to((xs >= x_wall)[:, None], (xs.size, ys.size)).copy()
    h = np.zeros((xs.size, ys.size))
    return maps_from_grids((xs[0], ys[0]), RES, h, np.zeros_like(body), body)


def _steered(maps: object, cmd: SteeringCommand, climb_speed: float | None = None) -> SteeringCommand:
    """TerrainNavigator.steered_command on a stand-in navigator (params, maps, controller command and gait)."""
    p = NavigatorParams()
    nav: Any = SimpleNamespace(
        params=p,
        maps=maps,
        climb_speed=climb_speed,
        controller=SimpleNamespace(
            command=cmd, gait="trot", handler=SimpleNamespace(stance=np.zeros(4, bool))
        ),
    )
    nav._dense_slowdown = lambda xy, yaw: TerrainNavigator._dense_slowdown(nav, xy, yaw)
    nav._dense_share = lambda xy, yaw: TerrainNavigator._dense_share(nav, xy, yaw)
    nav._obstacle_stop = lambda s, vx, vy, wz: TerrainNavigator._obstacle_stop(nav, s, vx, vy, wz)
    nav._swept_clearance = lambda s, vx, vy, wz: TerrainNavigator._swept_clearance(nav, s, vx, vy, wz)
    nav._lag_slowdown = lambda s: TerrainNavigator._lag_slowdown(nav, s)  # no foot down: no lag
    nav._tread_lines = None  # off stairs: the climb speed as it is
    nav._tread_pace = lambda s: TerrainNavigator._tread_pace(nav, s)
    return TerrainNavigator.steered_command(nav, RobotState())


def test_steering_slows_and_stops_short_of_a_body_obstacle() -> None:
    """Walking at 0.5 m/s toward a wall: far from it the command passes; once the footprint swept over the next
    0.6 s would come within the margin the speed drops, and at the wall it stops; backing away stays allowed."""
    far = _steered(_wall_maps(2.5), SteeringCommand(0.5, 0.0, 0.0))
    assert np.isclose(far.vx, 0.5)
    near = _steered(_wall_maps(0.75), SteeringCommand(0.5, 0.0, 0.0))  # body front circle at 0.3 + 0.17 m
    assert 0.0 < near.vx < 0.5
    stop = _steered(_wall_maps(0.55), SteeringCommand(0.5, 0.0, 0.0))
    assert stop.vx == 0.0
    back = _steered(_wall_maps(0.55), SteeringCommand(-0.3, 0.0, 0.0))
    assert np.isclose(back.vx, -0.3)
    side = _steered(_wall_maps(0.55), SteeringCommand(0.0, 0.3, 0.0))  # along the wall: no closer
    assert np.isclose(side.vy, 0.3)


def test_steering_keeps_the_terrain_speed_limit() -> None:
    """On steps the navigator's climb speed (one tread per step) caps the operator's speed, direction kept."""
    out = _steered(_wall_maps(5.0), SteeringCommand(0.8, 0.6, 0.2), climb_speed=0.4)
    assert np.isclose(np.hypot(out.vx, out.vy), 0.4) and np.isclose(out.vx / out.vy, 0.8 / 0.6)
    assert out.yaw_rate == 0.2


def test_steered_under_the_table_with_the_sensor() -> None:
    """Steered straight ahead at 0.5 m/s (no goal) with the depth sensor: the body crouches under the table and
    comes out past it (crossed at ~8.5 s), no fall, no body collision."""
    r = run_walk(WalkCommand(vx=0.5, terrain_sensor=True), RunOptions(terrain="under-table", duration_s=11.0))
    assert not r["fell"], r["failure_reason"]
    assert r["body_collisions"] == 0
    assert r["crossed"], r["time_to_cross_s"]
    assert r["navigator"]["min_body_height_target_m"] < 0.47
    assert r["navigator"]["body_paths"] == 0  # steered: no path planning


STEERED_STAIRS_SPEEDS = (0.3, 0.4, 0.5)
MIN_STEERED_STAIRS = 1


def test_steered_over_the_stairs_with_the_sensor_at_a_rate() -> None:
    """Steered straight ahead (no goal) at 0.3, 0.4 and 0.5 m/s with the depth sensor: the stairs mode caps the speed
    at one tread per step (paced by the feet) and the tread-by-tread footholds carry the robot up and down. At least
    MIN_STEERED_STAIRS of the three cross with no fall and no body collision, at most two landings in a no-step
    place, in the stairs mode for more than 8 s and slower than commanded on the stairs. Measured 2026-11-26 on this
    project's 2-core build machine: 0.4 m/s crosses, 0.3 and 0.5 m/s fall (a front shin on a nosing)."""
    ok = {}
    for vx in STEERED_STAIRS_SPEEDS:
        r = run_walk(WalkCommand(vx=vx, terrain_sensor=True), RunOptions(terrain="stairs", duration_s=16.0))
        good = (
            not r["fell"]
            and r["crossed"]
            and r["body_collisions"] == 0
            and r["no_step_touchdowns"] <= 2
            and r["navigator"]["stairs_mode_s"] > 8.0
            and r["mean_velocity"]["vx"] < vx
        )
        ok[vx] = True if good else (r["failure_reason"] or f"crossed {r['crossed']}, nav {r['navigator']}")
        print(f"steered stairs at {vx} m/s: {ok[vx]}")
    assert sum(v is True for v in ok.values()) >= MIN_STEERED_STAIRS, ok
