"""Judging a terrain crossing from ground truth: the terrain's extent, no-step touchdowns and body collisions.

- ``terrain_span_x(scene)``: where along x the terrain lies (m), so "crossed" means the body got past its end;
- ``no_step_touchdowns(scene, points)``: touchdowns whose contact point straddles an edge or is off a support
  surface, judged on the scene's true support height (not on any map): within ``radius_m`` of the contact point
  the true ground varies by more than ``max_spread_m``, or the contact lies more than ``max_gap_m`` above the true
  ground there (the foot rests on an obstacle or an edge's corner), or a foot touched an obstacle geom;
- ``BodyCollisionMonitor``: a loop monitor counting contact events (rising edges per pair) between a robot geom other
  than a foot and a ``terrain_obstacle_*`` geom, plus feet touching obstacles.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from planning.sim.world import RobotState, World
from planning.terrain.scenes import TerrainScene


def terrain_span_x(scene: TerrainScene) -> tuple[float, float]:
    """Gives (x_start, x_end) (m) of the scene's terrain along x; (0, 0) for flat ground."""
    return scene.span_x


@dataclass(frozen=True)
class NoStepCheck:
    """radius_m: ring around the contact point where the true ground is sampled (m); max_spread_m: largest true
    height spread within it that is not an edge (m); max_gap_m: largest height of the contact point above the true
    ground (m)."""

    radius_m: float = 0.025
    max_spread_m: float = 0.04
    max_gap_m: float = 0.03


_RING = np.stack([np.cos(np.arange(8) * np.pi / 4), np.sin(np.arange(8) * np.pi / 4)], axis=1)


def no_step_flags(
    scene: TerrainScene, p_world_contact: NDArray[np.float64], check: NoStepCheck | None = None
) -> NDArray[np.bool_]:
    """Gives (N,) whether each contact point (N, 3) (m, world) is a no-step touchdown on the scene's ground truth."""
    c = check or NoStepCheck()
    p = np.asarray(p_world_contact, dtype=np.float64).reshape(-1, 3)
    if p.shape[0] == 0:
        return np.zeros(0, dtype=bool)
    pts = p[:, None, :2] + c.radius_m * _RING[None]
    pts = np.concatenate([p[:, None, :2], pts], axis=1)
    h = np.asarray(scene.ground_height(pts[..., 0], pts[..., 1]), dtype=np.float64)
    spread = h.max(axis=1) - h.min(axis=1)
    gap = p[:, 2] - h[:, 0]
    return (spread > c.max_spread_m) | (gap > c.max_gap_m)


def no_step_touchdowns(
    scene: TerrainScene, p_world_contact: Sequence[NDArray[np.float64]], check: NoStepCheck | None = None
) -> int:
    """Gives how many of the touchdown contact points are no-step touchdowns (see no_step_flags)."""
    if len(p_world_contact) == 0:
        return 0
    return int(np.count_nonzero(no_step_flags(scene, np.array(p_world_contact), check)))


class BodyCollisionMonitor:
    """Counts contact events between robot geoms (non-foot) and obstacle geoms, and feet on obstacles."""

    def __init__(self, world: World) -> None:
        self.world = world
        foot = np.zeros(world.model.ngeom, dtype=bool)
        foot[world.foot_geom] = True
        self._body = world.is_robot_geom & ~foot
        self._foot = foot
        self._obstacle = world.is_obstacle_geom
        self._active: set[tuple[int, int]] = set()
        self.body_collisions = 0
        self.foot_on_obstacle = 0
        self.events: list[tuple[float, str, str]] = []

    def __call__(self, s: RobotState) -> None:
        d = self.world.data
        now: set[tuple[int, int]] = set()
        n = d.ncon
        # the contacts' geom pairs as Python ints in one conversion (each d.contact access builds a view; this
        # runs every physics step)
        for g1, g2 in d.contact.geom[:n].tolist() if n else ():
            if self._obstacle[g1]:
                g1, g2 = g2, g1
            if not self._obstacle[g2] or not (self._body[g1] or self._foot[g1]):
                continue
            pair = (g1, g2)
            now.add(pair)
            if pair not in self._active:
                if self._body[g1]:
                    self.body_collisions += 1
                else:
                    self.foot_on_obstacle += 1
                names = self.world.geom_names
                self.events.append((s.t, names[g1], names[g2]))
        self._active = now
