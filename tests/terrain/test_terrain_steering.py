"""A steered terrain walk stops short of body obstacles (planning.terrain.steering), as the pipeline applies it."""

from __future__ import annotations

import numpy as np

from planning.steps import SteeringCommand
from planning.terrain.bodypath import BodyPathParams
from planning.terrain.maps import TerrainMaps, maps_from_grids
from planning.terrain.steering import StopParams, stop_short

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
