"""Inputs and labels of the swing planner: requests, tiers, trips, the body's motion and the ground.

Frames: ``world`` is the maneuver frame (x forward, y left, z up at the start); the *heading* frame is the world
turned by the body's yaw at planning time. Feet are contact points (the bottom of the foot sphere).
"""

from __future__ import annotations

import enum
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np


class Tier(enum.IntEnum):
    """Tiers of the detailed analysis (seed FIG. 3), most preferred first; the value is the rank."""

    SUCCESS = 0
    XY_SUCCESS_Z_IMPOSSIBLE = 1
    CLIFF_SCRAPING = 2
    KNEE_TERRAIN_COLLISION = 3
    KNEE_SELF_COLLISION = 4
    TERRAIN_COLLISION = 5
    XY_CANT_REACH = 6
    SELF_COLLISION = 7
    DEFAULT = 8
    VIOLATES_CONSTRAINTS = 9


#: Colors the studio uses for a swing trajectory of each tier (0–255 RGB): green is good, red is bad.
TIER_RGB: dict[Tier, tuple[int, int, int]] = {
    Tier.SUCCESS: (46, 204, 64),
    Tier.XY_SUCCESS_Z_IMPOSSIBLE: (160, 210, 40),
    Tier.CLIFF_SCRAPING: (255, 220, 0),
    Tier.KNEE_TERRAIN_COLLISION: (255, 170, 0),
    Tier.KNEE_SELF_COLLISION: (255, 140, 0),
    Tier.TERRAIN_COLLISION: (255, 100, 0),
    Tier.XY_CANT_REACH: (240, 60, 60),
    Tier.SELF_COLLISION: (220, 20, 60),
    Tier.DEFAULT: (150, 150, 150),
    Tier.VIOLATES_CONSTRAINTS: (90, 0, 0),
}


class TripKind(enum.Enum):
    """What tripped a swing leg (seed FIG. 16)."""

    NORMAL = "normal"  # the swing foot hit something it did not expect
    KNEE = "knee"  # the knee hit something
    SELF_CROSSED = "self_crossed"  # the leg hit another leg and is on that leg's far side
    SELF_UNCROSSED = "self_uncrossed"  # the leg hit another leg from its own side


@dataclass(frozen=True, slots=True)
class TripEvent:
    """A trip detected on a swing leg at time t_s (s); other_leg is the leg hit in a self-collision."""

    kind: TripKind
    t_s: float
    other_leg: int | None = None


@dataclass(frozen=True, slots=True)
class SwingRequest:
    """One swing leg to plan: where the foot is, where and when it must touch down.

    leg: index in FL, FR, RL, RR order. p_world_foot, v_world_foot: measured contact point (3,) m and velocity
    (3,) m/s. p_touchdown: target contact point (3,) m. t_touchdown: target time (s, same clock as t_now).
    trip: a trip detected this tick, or None.
    """

    leg: int
    p_world_foot: np.ndarray
    v_world_foot: np.ndarray
    p_touchdown: np.ndarray
    t_touchdown: float
    trip: TripEvent | None = None

    def __post_init__(self) -> None:
        if not (isinstance(self.leg, int | np.integer) and 0 <= int(self.leg) < 4):
            raise ValueError(f"SwingRequest.leg: must be a leg index 0..3 (FL, FR, RL, RR), got {self.leg!r}")
        for name in ("p_world_foot", "v_world_foot", "p_touchdown"):
            a = np.asarray(getattr(self, name), dtype=float)
            # np.isfinite(a).all() on the three floats (built every replan, 333 Hz: a third of the time)
            if a.shape != (3,) or not all(map(math.isfinite, a.tolist())):
                raise ValueError(
                    f"SwingRequest.{name}: must be 3 finite numbers, got {getattr(self, name)!r}"
                )
            object.__setattr__(self, name, a)
        if not math.isfinite(self.t_touchdown):
            raise ValueError(f"SwingRequest.t_touchdown: must be a finite time, got {self.t_touchdown!r}")


def _rz(yaw: float) -> np.ndarray:
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


@dataclass(frozen=True, slots=True)
class BodyMotion:
    """The body's predicted pose over a swing: constant linear velocity and yaw rate from (t0, pose).

    The planner needs the orientation as well as the hips (knees come from the leg IK in the body frame), hence
    this rather than hip positions alone. ``hips_world_at`` gives those.
    """

    t0: float
    p_world_body: np.ndarray  # (3,) m
    R_world_body: np.ndarray  # (3,3)
    v_world_body: np.ndarray = field(default_factory=lambda: np.zeros(3))  # (3,) m/s
    yaw_rate: float = 0.0  # rad/s about world z

    def __post_init__(self) -> None:
        for name, shape in (("p_world_body", (3,)), ("R_world_body", (3, 3)), ("v_world_body", (3,))):
            a = np.asarray(getattr(self, name), dtype=float)
            if a.shape != shape or not all(map(math.isfinite, a.ravel().tolist())):  # np.isfinite(a).all()
                raise ValueError(f"BodyMotion.{name}: must be a finite array of shape {shape}")
            object.__setattr__(self, name, a)

    @property
    def yaw(self) -> float:
        """Heading (rad) at t0."""
        R = self.R_world_body
        return math.atan2(R[1, 0], R[0, 0])

    def pose_at(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """Returns (p_world_body (3,), R_world_body (3,3)) at time t (s)."""
        dt = t - self.t0
        if dt == 0.0:
            return self.p_world_body.copy(), self.R_world_body
        R = self.R_world_body if self.yaw_rate == 0.0 else _rz(self.yaw_rate * dt) @ self.R_world_body
        return self.p_world_body + self.v_world_body * dt, R

    def hips_world_at(self, t: float, p_body_hip: np.ndarray) -> np.ndarray:
        """Returns the hip positions (4,3) in the world at time t for hips p_body_hip (4,3) in the body frame."""
        p, R = self.pose_at(t)
        return p + p_body_hip @ R.T

    def hip_world_many(self, ts: np.ndarray, p_body_hip_leg: np.ndarray) -> np.ndarray:
        """Returns one hip's world positions (K,3) at times ts (K,) for its body-frame position (3,)."""
        dt = ts - self.t0
        r = self.R_world_body @ p_body_hip_leg
        out = self.p_world_body + dt[:, None] * self.v_world_body
        if self.yaw_rate == 0.0:
            return out + r
        c, s = np.cos(self.yaw_rate * dt), np.sin(self.yaw_rate * dt)
        out[:, 0] += c * r[0] - s * r[1]
        out[:, 1] += s * r[0] + c * r[1]
        out[:, 2] += r[2]
        return out


class GroundHeightFn(Protocol):
    """Terrain height (m) at world (x, y); vectorized: x, y and the result are arrays of one shape."""

    def __call__(self, x: np.ndarray, y: np.ndarray) -> np.ndarray: ...


@dataclass(frozen=True, slots=True)
class FlatGround:
    """Flat ground at height_m: the planner recognizes it and skips terrain sampling."""

    height_m: float = 0.0

    def __call__(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        return np.full(np.shape(x), self.height_m)


@dataclass(frozen=True, slots=True)
class Box:
    """An axis-aligned box on flat ground: x and y extents (m) and its top height (m)."""

    x_min: float
    x_max: float
    y_min: float
    y_max: float
    height_m: float


@dataclass(frozen=True, slots=True)
class BoxGround:
    """Flat ground at base_m with boxes on it — a stand-in height map until the terrain maps arrive."""

    boxes: Sequence[Box]
    base_m: float = 0.0
    _b: np.ndarray = field(init=False, repr=False)
    _rows: list[tuple[float, ...]] = field(
        init=False, repr=False, compare=False
    )  # _b's rows as floats (faster to unpack)

    def __post_init__(self) -> None:
        arr = np.array([[b.x_min, b.x_max, b.y_min, b.y_max, b.height_m] for b in self.boxes], dtype=float)
        object.__setattr__(self, "_b", arr.reshape(-1, 5))
        object.__setattr__(self, "_rows", [tuple(float(v) for v in row) for row in self._b])

    def __call__(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        x = np.asarray(x, dtype=float)
        y = np.asarray(y, dtype=float)
        h = np.full(x.shape, self.base_m)
        for x0, x1, y0, y1, top in self._rows:
            inside = x >= x0
            inside &= x <= x1
            inside &= y >= y0
            inside &= y <= y1
            np.maximum(h, top, out=h, where=inside)
        return h


flat_ground = FlatGround(0.0)
