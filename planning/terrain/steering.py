"""A steered terrain walk (the operator's velocity command, no goal) stopping short of body obstacles.

A walk to a goal follows a body path planned around the body obstacles; a steered walk has no path, so the terrain
pipeline scales the operator's command down where the body's footprint, swept over the next horizon_s at that
velocity, would come closer than margin_m to a body obstacle (a wall, a table leg, a tall box) than it is now.
A pure function of the maps, the body pose and the command; the pipeline applies it to its steered decision.

A walk to a goal may also keep a barrier (BarrierParams, barrier_command): the least change of the path's command
with which no circle of the body's footprint (the trunk and the legs) approaches a body obstacle faster than a rate
times its clearance beyond a margin, a control-barrier rule on (vx, vy, yaw rate) solved exactly (at most four
rules, three unknowns).
"""

from __future__ import annotations

import itertools
import math
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


@dataclass(frozen=True)
class BarrierParams:
    """A walk to a goal keeps its body off body obstacles by its command, whatever its path (a path may graze a tall
    box: the body path's search keeps the footprint clear with no margin, and the body lags its path's yaw).

    The obstacles it reads are those the body can hit (maps.sdf_collide): the edge of a drop below the body's band,
    a landing's open side seen from the landing, is a body obstacle for the body path but not for the barrier (it
    held a turn round on a 1.2 m landing for seconds once the sensor saw the floor beyond its sides).

    margin_m: the clearance (m) each circle of the barrier's footprint keeps from body obstacles; None: off (the
    command as the path asks; on, the clutter family crossed 26 of 50 clean against 19 off, its trunk falls 5 to 0,
    and the stairs 27 either way; 0.08 crossed clutter 24: docs/terrain-notes.md, session 15); rate_hz: a circle
    may approach an obstacle at rate_hz × its clearance beyond the margin (m/s), and not at all within it (it may
    slide along it or move away); yaw_weight_m2: what a rad/s of yaw
    rate changed costs against a m/s of velocity in the least change of the command that keeps every circle's rule;
    near_m: circles farther than this beyond the margin are left out (no rule can bind at the walk's speeds);
    max_rules: at most this many of the nearest circles' rules are kept."""

    margin_m: float | None = 0.05
    rate_hz: float = 2.0
    yaw_weight_m2: float = 0.1
    near_m: float = 0.4
    max_rules: int = 4


def barrier_rules(
    maps: TerrainMaps,
    xy: NDArray[np.float64],
    yaw: float,
    footprint: BodyPathParams,
    p: BarrierParams,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Gives the barrier's rules on the body-frame command u = (vx, vy, yaw rate) as G u >= h (rows (k, 3), (k,)):
    each footprint circle within near_m beyond the margin approaches the body obstacles (along the body SDF's
    gradient at its centre) at most rate_hz × its clearance beyond margin_m, and not at all inside it."""
    assert p.margin_m is not None
    off = np.asarray(footprint.footprint_x_m, dtype=np.float64)
    c, s = math.cos(yaw), math.sin(yaw)
    cx = float(xy[0]) + c * off
    cy = float(xy[1]) + s * off
    on = np.asarray(maps.in_map(cx, cy), dtype=bool)
    d = np.where(on, np.asarray(maps.sdf_collide(cx, cy), dtype=np.float64), np.inf) - footprint.footprint_r_m
    excess = d - p.margin_m
    near = np.flatnonzero(excess < p.near_m)
    if near.size == 0:
        return np.zeros((0, 3)), np.zeros(0)
    near = near[np.argsort(excess[near], kind="stable")[: p.max_rules]]
    g = np.asarray(maps.sdf_collide_grad(cx[near], cy[near]), dtype=np.float64).reshape(-1, 2)
    norm = np.linalg.norm(g, axis=1)
    keep = norm > 1e-6
    near, g = near[keep], g[keep] / norm[keep, None]
    # The circle's world velocity: R(yaw) (vx, vy) + yaw rate × off (−sin, cos); its approach rate along g.
    gb = np.stack([c * g[:, 0] + s * g[:, 1], -s * g[:, 0] + c * g[:, 1]], axis=1)
    G = np.column_stack([gb, off[near] * (-s * g[:, 0] + c * g[:, 1])])
    h = -p.rate_hz * np.maximum(excess[near], 0.0)
    return G, h


def barrier_command(
    maps: TerrainMaps | None,
    xy: NDArray[np.float64],
    yaw: float,
    cmd: SteeringCommand,
    footprint: BodyPathParams,
    p: BarrierParams,
) -> SteeringCommand:
    """Gives the command nearest (velocity and weighted yaw rate) to cmd that keeps the barrier's rules
    (barrier_rules); unchanged with the barrier off, without maps, or where no rule binds. The command standing
    still always keeps them, and the change never makes the command faster in that weighted norm."""
    if maps is None or p.margin_m is None:
        return cmd
    G, h = barrier_rules(maps, xy, yaw, footprint, p)
    u0 = np.array([cmd.vx, cmd.vy, cmd.yaw_rate], dtype=np.float64)
    if G.shape[0] == 0 or bool(np.all(G @ u0 >= h - 1e-12)):
        return cmd
    u = _nearest_kept(u0, G, h, np.array([1.0, 1.0, p.yaw_weight_m2]))
    return SteeringCommand(float(u[0]), float(u[1]), float(u[2]))


def _nearest_kept(
    u0: NDArray[np.float64], G: NDArray[np.float64], h: NDArray[np.float64], w: NDArray[np.float64]
) -> NDArray[np.float64]:
    """Gives argmin (u − u0)ᵀ W (u − u0) subject to G u >= h (W = diag(w)): every set of at most three rules taken
    as active (equalities), the best point that keeps all of them; zero if none does (zero keeps rules with h <= 0)."""
    k = G.shape[0]
    Winv = 1.0 / w
    best, best_cost = np.zeros(3), float(np.sum(w * u0 * u0))
    for size in (1, 2, 3):
        for act in itertools.combinations(range(k), size):
            A = G[list(act)]
            r = h[list(act)] - A @ u0
            M = (A * Winv) @ A.T
            try:
                lam = np.linalg.solve(M, r)
            except np.linalg.LinAlgError:
                continue
            if np.any(lam < -1e-12):
                continue
            u = u0 + Winv * (A.T @ lam)
            if np.all(G @ u >= h - 1e-9):
                cost = float(np.sum(w * (u - u0) ** 2))
                if cost < best_cost:
                    best, best_cost = u, cost
    return best
