"""A steered terrain walk stops short of body obstacles (planning.terrain.steering), as the pipeline applies it."""

from __future__ import annotations

import numpy as np

from planning.steps import SteeringCommand
from planning.terrain.bodypath import BodyPathParams
from planning.terrain.maps import TerrainMaps, maps_from_grids
from planning.terrain.steering import BarrierParams, StopParams, barrier_command, barrier_rules, stop_short

RES = 0.03


def _wall_maps(x_wall: float) -> TerrainMaps:
    """Flat ground from (-1, -1.5) with a body-obstacle wall across y from x_wall on (not marked no-step)."""
    xs = -1.0 + np.arange(120) * RES
    ys = -1.5 + np.arange(100) * RES
    body = np.broadcast_to((xs >= x_wall)[:, None], (xs.size, ys.size)).copy()
    h = np.zeros((xs.size, ys.size))
    return maps_from_grids((xs[0], ys[0]), RES, h, np.zeros_like(body), body)


def _steer(x_wall: float, cmd: SteeringCommand) -> SteeringCommand:
    return stop_short(_wall_maps(x_wall), np.zeros(2), 0.0, cmd, BodyPathParams(), StopParams())


def test_steering_slows_and_stops_short_of_a_body_obstacle() -> None:
    """Walking at 0.5 m/s toward a wall: far from it the command passes; once the footprint swept over the next
    0.6 s would come within the margin the speed drops, and at the wall it stops; backing away and walking along
    the wall stay allowed, and the yaw rate is kept."""
    far = _steer(2.5, SteeringCommand(0.5, 0.0, 0.0))
    assert np.isclose(far.vx, 0.5)
    near = _steer(0.75, SteeringCommand(0.5, 0.0, 0.0))  # the body's front circle at 0.3 + 0.17 m
    assert 0.0 < near.vx < 0.5
    stop = _steer(0.55, SteeringCommand(0.5, 0.0, 0.2))
    assert stop.vx == 0.0 and stop.yaw_rate == 0.2
    back = _steer(0.55, SteeringCommand(-0.3, 0.0, 0.0))
    assert np.isclose(back.vx, -0.3)
    side = _steer(0.55, SteeringCommand(0.0, 0.3, 0.0))  # along the wall: no closer
    assert np.isclose(side.vy, 0.3)
    assert (
        stop_short(None, np.zeros(2), 0.0, SteeringCommand(0.5, 0.0, 0.0), BodyPathParams(), StopParams()).vx
        == 0.5
    )


def _barrier(x_wall: float, cmd: SteeringCommand, yaw: float = 0.0, **kw: float) -> SteeringCommand:
    p = BarrierParams(**{"margin_m": 0.05, **kw})  # type: ignore[arg-type]
    return barrier_command(_wall_maps(x_wall), np.zeros(2), yaw, cmd, BodyPathParams(), p)


def test_the_barrier_keeps_the_body_off_a_body_obstacle_by_the_least_change_of_its_command() -> None:
    """A walk to a goal with the barrier on: far from a wall the command passes unchanged; near it the speed toward
    it is at most rate × the clearance beyond the margin, and nil within the margin, while the speed along the wall
    is kept (the body slides along, as it would along a path that grazes a tall box); backing away passes; a body
    turned toward the wall is not let turn its nose into it; off, or without maps, the command is the path's."""
    fwd = SteeringCommand(0.5, 0.0, 0.0)
    assert _barrier(2.5, fwd) == fwd  # the front circle 2.03 m from the wall
    # The front circle's centre at 0.3 m, radius 0.17: 0.83 - 0.47 = 0.36 m clear, 0.31 beyond the margin: it may
    # close in at 0.62 m/s, more than asked.
    assert _barrier(0.83, fwd) == fwd
    nearer = _barrier(0.62, fwd)  # 0.15 m clear: 0.10 beyond the margin, 0.2 m/s
    assert 0.12 < nearer.vx < 0.28 and abs(nearer.vy) < 1e-9
    inside = _barrier(0.50, SteeringCommand(0.4, 0.3, 0.0))  # 0.03 m clear, within the margin
    assert abs(inside.vx) < 1e-6 and np.isclose(inside.vy, 0.3)
    back = SteeringCommand(-0.3, 0.0, 0.0)
    assert _barrier(0.50, back) == back
    # Turned 0.3 rad and asked to turn right, its nose (within the margin of a wall across x) toward the wall:
    # the least change keeps the nose circle from closing in (here by backing off a little: a m/s costs more
    # than a rad/s, but the nose moves 0.3 m per rad).
    ask = SteeringCommand(0.0, 0.0, -0.8)
    turned = _barrier(0.50, ask, yaw=0.3)
    G, h = barrier_rules(_wall_maps(0.50), np.zeros(2), 0.3, BodyPathParams(), BarrierParams(margin_m=0.05))
    u = np.array([turned.vx, turned.vy, turned.yaw_rate])
    assert turned != ask and np.all(G @ u >= h - 1e-9)
    c, s = np.cos(0.3), np.sin(0.3)
    nose_vx = c * turned.vx - s * turned.vy - 0.3 * s * turned.yaw_rate
    assert nose_vx <= 1e-9
    assert _barrier(0.50, fwd, margin_m=None) == fwd  # type: ignore[arg-type]
    assert barrier_command(None, np.zeros(2), 0.0, fwd, BodyPathParams(), BarrierParams(margin_m=0.05)) == fwd


def test_the_barrier_lets_the_body_turn_over_the_open_edge_of_a_landing_it_stands_on() -> None:
    """A body turning in place on a landing 0.6 m above the floor, its open side 0.45 m to the left: the landing's
    edge is a body obstacle (the body path keeps off the drop) but nothing the body can hit, so the barrier lets the
    turn go on as asked; the same cells read as a wall (no drop told apart) stop the turn's nose from closing in."""
    import dataclasses

    from planning.terrain.maps import MapParams, build_maps
    from planning.terrain.voxels import Columns

    n, nz, z0, dz = 80, 40, -0.1, 0.03
    ground = np.zeros((n, n))
    ground[:, :55] = 0.6  # y < 0.45 m from the origin at y -1.2: the landing; its open side beyond
    columns = Columns((-1.2, -1.2), RES, ground, np.zeros((n, n, nz), dtype=bool), z0, dz)
    maps = build_maps(columns, dataclasses.replace(MapParams(), band_from_support=True), default_ground_z=0.6)
    assert maps.drop_only is not None and maps.no_body(0.0, 0.47)
    turn = SteeringCommand(0.0, 0.0, 0.5)
    p = BarrierParams(margin_m=0.05)
    assert barrier_command(maps, np.zeros(2), 0.6, turn, BodyPathParams(), p) == turn
    wall = dataclasses.replace(maps, drop_only=None)
    held = barrier_command(wall, np.zeros(2), 0.6, turn, BodyPathParams(), p)
    assert held != turn
