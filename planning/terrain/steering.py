"""A steered terrain walk (the operator's velocity command, no goal) stopping short of body obstacles.

A walk to a goal follows a body path planned around the body obstacles; a steered walk has no path, so the terrain
pipeline scales the operator's command down where the body's footprint, swept over the next horizon_s at that
velocity, would come closer than margin_m to a body obstacle (a wall, a table leg, a tall box) than it is now.
A pure function of the maps, the body pose and the command; the pipeline applies it to its steered decision.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from planning.steps import SteeringCommand
from planning.steps.state import rotate_yaw
from planning.terrain.bodypath import BodyPathParams, sweep_points_clearance
from planning.terrain.maps import TerrainMaps


@dataclass(frozen=True)
class StopParams:
    """horizon_s: how far ahead (s) the body's footprint is swept at the steered velocity (0: never stop);
    margin_m: the clearance from body obstacles it keeps (or, when already closer, it does not come closer);
    samples: poses along the sweep; scales: the shares of the command tried, largest first (then 0)."""

    horizon_s: float = 0.6
    margin_m: float = 0.05
    samples: int = 7
    scales: tuple[float, ...] = (1.0, 0.75, 0.5, 0.25)


def swept_clearance(
    maps: TerrainMaps,
    xy: NDArray[np.float64],
    yaw: float,
    cmd: SteeringCommand,
    footprint: BodyPathParams,
    p: StopParams,
) -> float:
    """Gives the smallest clearance (m) from the body-obstacle map of the body's footprint (footprint_x_m circles of
    footprint_r_m) swept over horizon_s at the body-frame command from the pose (xy, yaw)."""
    t = np.linspace(0.0, p.horizon_s, max(p.samples, 2))
    v = rotate_yaw(yaw, np.array([cmd.vx, cmd.vy], dtype=np.float64))
    pts = np.asarray(xy, dtype=np.float64)[None, :2] + t[:, None] * v[None, :]
    clear = sweep_points_clearance(maps, pts, yaw + cmd.yaw_rate * t, footprint.footprint_x_m)
    return float(np.min(clear)) - footprint.footprint_r_m


def stop_short(
    maps: TerrainMaps | None,
    xy: NDArray[np.float64],
    yaw: float,
    cmd: SteeringCommand,
    footprint: BodyPathParams,
    p: StopParams,
) -> SteeringCommand:
    """Gives the steered command scaled by the largest of p.scales (else 0) whose footprint sweep keeps margin_m
    from body obstacles (or no less than the body has now); the yaw rate is kept. Unchanged without maps, with no
    horizon, or with no translation asked."""
    if maps is None or p.horizon_s <= 0.0 or np.hypot(cmd.vx, cmd.vy) < 1e-6:
        return cmd
    still = SteeringCommand(0.0, 0.0, 0.0)
    need = min(p.margin_m, swept_clearance(maps, xy, yaw, still, footprint, p))
    for k in p.scales:
        scaled = SteeringCommand(cmd.vx * k, cmd.vy * k, cmd.yaw_rate)
        if swept_clearance(maps, xy, yaw, scaled, footprint, p) >= need - 1e-3:
            return scaled
    return SteeringCommand(0.0, 0.0, cmd.yaw_rate)
