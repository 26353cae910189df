"""Judging a terrain crossing from ground truth: the terrain's extent, no-step touchdowns and body collisions.

- ``terrain_span_x(scene)``: where along x the terrain lies (m), so "crossed" means the body got past its end;
- ``no_step_touchdowns(scene, points)``: touchdowns whose contact point straddles an edge or is off a support
  surface, judged on the scene's true support height (not on any map): within ``radius_m`` of the contact point
  the true ground varies by more than ``max_spread_m``, or the contact lies more than ``max_gap_m`` above the true
  ground there (the foot rests on an obstacle or an edge's corner), or a foot touched an obstacle geom;
- ``BodyCollisionMonitor``: a loop monitor counting contact events (rising edges per pair) between a robot geom other
  than a foot and a ``terrain_obstacle_*`` geom, plus feet touching obstacles;
- ``NearMissMonitor``: a loop monitor counting near misses, a non-foot robot geom within ``NEAR_MISS_M`` of the
  world without touching it.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import mujoco
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


def no_step_details(
    scene: TerrainScene,
    p_world_contact: Sequence[NDArray[np.float64]] | NDArray[np.float64],
    check: NoStepCheck | None = None,
) -> tuple[NDArray[np.bool_], NDArray[np.float64], NDArray[np.float64]]:
    """Gives, for contact points (N, 3) (m, world), whether each is a no-step touchdown on the scene's ground truth
    (N,), and why: the true ground's height spread within the check's ring around it (an edge: above max_spread_m)
    and the point's height above the true ground under it (on an obstacle: above max_gap_m) (N,) m each."""
    c = check or NoStepCheck()
    p = np.asarray(p_world_contact, dtype=np.float64).reshape(-1, 3)
    if p.shape[0] == 0:
        return np.zeros(0, dtype=bool), np.zeros(0), np.zeros(0)
    pts = p[:, None, :2] + c.radius_m * _RING[None]
    pts = np.concatenate([p[:, None, :2], pts], axis=1)
    h = np.asarray(scene.ground_height(pts[..., 0], pts[..., 1]), dtype=np.float64)
    spread = h.max(axis=1) - h.min(axis=1)
    gap = p[:, 2] - h[:, 0]
    return (spread > c.max_spread_m) | (gap > c.max_gap_m), spread, gap


def no_step_flags(
    scene: TerrainScene, p_world_contact: NDArray[np.float64], check: NoStepCheck | None = None
) -> NDArray[np.bool_]:
    """Gives (N,) whether each contact point (N, 3) (m, world) is a no-step touchdown on the scene's ground truth."""
    return no_step_details(scene, p_world_contact, check)[0]


def no_step_touchdowns(
    scene: TerrainScene, p_world_contact: Sequence[NDArray[np.float64]], check: NoStepCheck | None = None
) -> int:
    """Gives how many of the touchdown contact points are no-step touchdowns (see no_step_flags)."""
    if len(p_world_contact) == 0:
        return 0
    return int(np.count_nonzero(no_step_flags(scene, np.array(p_world_contact), check)))


# A near-edge landing: a landing, not a no-step one, whose contact point has an edge of the true ground (a height
# spread above NoStepCheck.max_spread_m) within the foot's radius + NEAR_EDGE_M: the sole within NEAR_EDGE_M of it.
NEAR_EDGE_M = 0.01
# the rings (m) around a landing's contact point on which edge_distance looks for the nearest edge, 16 points each
EDGE_RINGS_M = (0.025, 0.03, 0.035, 0.04, 0.045, 0.05, 0.06, 0.07, 0.08, 0.1)
_RING16 = np.stack([np.cos(np.arange(16) * np.pi / 8), np.sin(np.arange(16) * np.pi / 8)], axis=1)


def edge_distance(
    scene: TerrainScene,
    p_world_contact: Sequence[NDArray[np.float64]] | NDArray[np.float64],
    check: NoStepCheck | None = None,
) -> NDArray[np.float64]:
    """Gives, for contact points (N, 3) (m, world), how near the true ground's nearest edge lies (N,) m: the
    smallest of EDGE_RINGS_M within which (the point and the rings up to it, 16 points each) the true ground's height
    spread exceeds the check's max_spread_m; inf where none does (no edge within the largest ring)."""
    c = check or NoStepCheck()
    p = np.asarray(p_world_contact, dtype=np.float64).reshape(-1, 3)
    if p.shape[0] == 0:
        return np.zeros(0)
    radii = np.asarray(EDGE_RINGS_M)
    offs = (radii[:, None, None] * _RING16[None]).reshape(-1, 2)  # (R * 16, 2), ring by ring
    pts = np.concatenate([p[:, None, :2], p[:, None, :2] + offs[None]], axis=1)
    h = np.asarray(scene.ground_height(pts[..., 0], pts[..., 1]), dtype=np.float64)
    # the running spread over the centre and the rings up to each one
    rings = h[:, 1:].reshape(p.shape[0], len(radii), 16)
    hi = np.maximum.accumulate(np.maximum(rings.max(axis=2), h[:, :1]), axis=1)
    lo = np.minimum.accumulate(np.minimum(rings.min(axis=2), h[:, :1]), axis=1)
    edge = (hi - lo) > c.max_spread_m
    first = np.argmax(edge, axis=1)
    return np.where(edge.any(axis=1), radii[first], np.inf)


NEAR_MISS_M = 0.02  # a near miss: a non-foot part of the robot within this of the world (m), not touching it
NEAR_MISS_CLEAR_M = 0.025  # ... which ends when it is farther than this again
NEAR_MISS_EVERY = 2  # the distances are measured every this many physics steps


class NearMissMonitor:
    """Counts near misses: a non-foot robot geom (a lower leg, a thigh, the body) coming within NEAR_MISS_M of a
    terrain geom without touching it (one per approach: it counts again after moving away beyond
    NEAR_MISS_CLEAR_M; an approach that ends in a touch, a fall, is none), and keeps the least such distance of
    the run. A touch is a fall, so a rate of falls over a
    family of terrains moves by whole walks; near misses are their precursors, counted per step, and compare two
    versions of the stack on far fewer walks (docs/terrain-notes.md, session 29).

    Measured with MuJoCo's own distance (mj_geomDistance) every NEAR_MISS_EVERY physics steps on the pairs whose
    bounding spheres (a plane's half-space) come within NEAR_MISS_CLEAR_M: the simulation itself is untouched (a
    contact margin on the robot's geoms would have MuJoCo report the near contacts for free, but it changes how
    its colliders place a touching contact)."""

    def __init__(self, world: World) -> None:
        self.world = world
        m = world.model
        foot = world.leg_of_foot_geom >= 0  # the feet and the geoms that count as their leg's foot
        collides = (m.geom_contype != 0) | (m.geom_conaffinity != 0)
        self._links = np.nonzero(world.is_robot_geom & ~foot & collides)[0]
        terrain = np.nonzero(~world.is_robot_geom & collides)[0]
        plane = m.geom_type[terrain] == mujoco.mjtGeom.mjGEOM_PLANE
        self._planes = terrain[plane]
        self._solids = terrain[~plane]
        self._rb_links = m.geom_rbound[self._links]
        self._rb_solids = m.geom_rbound[self._solids]
        self._fromto = np.zeros(6)
        self._tick = 0
        self._inside: set[int] = set()
        self._open: dict[int, int] = {}  # a geom within NEAR_MISS_M now: the index of its approach's event
        self.near_misses = 0
        self.least_m = math.inf
        self.events: list[tuple[float, str, float]] = []

    def _distances(self) -> dict[int, float]:
        """Each link geom's least distance (m) to the terrain where it is under NEAR_MISS_CLEAR_M (touching: 0)."""
        m, d = self.world.model, self.world.data
        watch = NEAR_MISS_CLEAR_M
        xl = d.geom_xpos[self._links]
        out: dict[int, float] = {}
        pairs: list[tuple[int, int]] = []
        if len(self._solids):
            xs = d.geom_xpos[self._solids]
            gap = (
                np.linalg.norm(xl[:, None, :] - xs[None, :, :], axis=-1)
                - self._rb_links[:, None]
                - self._rb_solids[None, :]
            )
            li, si = np.nonzero(gap < watch)
            pairs += zip(self._links[li].tolist(), self._solids[si].tolist(), strict=True)
        for p in self._planes.tolist():
            n = d.geom_xmat[p].reshape(3, 3)[:, 2]
            h = (xl - d.geom_xpos[p]) @ n - self._rb_links
            pairs += [(int(g), p) for g in self._links[h < watch]]
        for g, t in pairs:
            dist = mujoco.mj_geomDistance(m, d, g, t, watch, self._fromto)
            if dist < watch:
                out[g] = min(out.get(g, watch), max(dist, 0.0))
        return out

    def __call__(self, s: RobotState) -> None:
        self._tick += 1
        if self._tick % NEAR_MISS_EVERY:
            return
        now: set[int] = set()
        for g, dist in self._distances().items():
            if dist <= 0.0:
                now.add(g)  # touching: a fall (the run ends), not a near miss (see finish)
                continue
            if dist < self.least_m:
                self.least_m = dist
            if dist < NEAR_MISS_M:
                now.add(g)
                if g not in self._inside:
                    self.near_misses += 1
                    self.events.append((s.t, self.world.geom_names[g], round(dist, 4)))
                    self._open[g] = len(self.events) - 1
            elif g in self._inside:
                now.add(g)  # (under NEAR_MISS_CLEAR_M: the same approach)
        for g in self._inside - now:
            self._open.pop(g, None)  # moved away: a near miss
        self._inside = now

    def finish(self, fell: bool) -> None:
        """Ends the run: after a fall, the approaches still open are the ones that ended in the touch (or were cut
        short by it), and are no near misses."""
        if fell and self._open:
            drop = set(self._open.values())
            self.events = [e for i, e in enumerate(self.events) if i not in drop]
            self.near_misses -= len(drop)
        self._open.clear()


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
