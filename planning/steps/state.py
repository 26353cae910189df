"""Inputs and outputs of step planning: the walking state, the steering command, step paths, body motion.

Frames: ``world`` is the maneuver frame (x forward at start, y left, z up, origin on the ground under the start
body center); ``heading`` is the world frame turned by the body yaw (x forward along the body, z up). Per-leg data
is always ordered FL, FR, RL, RR (index 0..3). Times are absolute simulation seconds.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

F64 = NDArray[np.float64]
I64 = NDArray[np.int64]
B = NDArray[np.bool_]

N_LEGS = 4


class StepRobot(Protocol):
    """What step planning reads from a ``planning.robot.RobotModel``."""

    standing_height_m: float
    max_leg_length_m: float
    foot_radius_m: float
    p_body_hip: F64  # (4,3)
    nominal_foot_body: F64  # (4,3)


class StepMaps(Protocol):
    """Terrain knowledge for screening (``planning.terrain.TerrainMaps`` is one): ``no_step(x, y)`` on world m,
    scalars or arrays. Touchdown heights come from its ``height_at(x, y)`` (or a callable ``ground_height(x, y)``)
    when it has one."""

    def no_step(self, x: F64, y: F64) -> object:
        """True where a foot must not be placed."""
        ...


def _array(name: str, value: object, shape: tuple[int, ...], dtype: type = np.float64) -> NDArray:
    """Returns ``value`` as a read-only array of ``shape``; raises ValueError naming the field otherwise."""
    try:
        a: NDArray = np.array(value, dtype=dtype)
    except (TypeError, ValueError) as e:
        raise ValueError(f"{name}: not a numeric array of shape {shape} ({e})") from None
    if a.shape != shape:
        raise ValueError(f"{name}: expected shape {shape}, got {a.shape}")
    if a.dtype.kind == "f" and not np.all(np.isfinite(a)):
        raise ValueError(f"{name}: contains NaN or infinite values")
    a.setflags(write=False)
    return a


def _finite(name: str, value: float) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name}: expected a number, got {value!r}") from None
    if not math.isfinite(v):
        raise ValueError(f"{name}: must be finite, got {v}")
    return v


@dataclass(frozen=True)
class SteeringCommand:
    """A steering command in the heading frame.

    vx: longitudinal velocity, m/s (forward +). vy: lateral velocity, m/s (left +). yaw_rate: rad/s (CCW +).
    """

    vx: float = 0.0
    vy: float = 0.0
    yaw_rate: float = 0.0

    def __post_init__(self) -> None:
        for name in ("vx", "vy", "yaw_rate"):
            object.__setattr__(self, name, _finite(f"SteeringCommand.{name}", getattr(self, name)))

    @property
    def is_zero(self) -> bool:
        return self.vx == 0.0 and self.vy == 0.0 and self.yaw_rate == 0.0


@dataclass(frozen=True)
class WalkState:
    """The measured state step planning starts from (the lead fills it from the simulator each tick).

    p_world_com: (3,) CoM position, m. v_world_com: (3,) CoM velocity, m/s. yaw: body heading, rad.
    yaw_rate: rad/s. p_world_feet: (4,3) foot contact points, m. contact: (4,) bool, foot on the ground. t: s.
    """

    p_world_com: F64
    v_world_com: F64
    yaw: float
    yaw_rate: float
    p_world_feet: F64
    contact: B
    t: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "p_world_com", _array("WalkState.p_world_com", self.p_world_com, (3,)))
        object.__setattr__(self, "v_world_com", _array("WalkState.v_world_com", self.v_world_com, (3,)))
        object.__setattr__(self, "p_world_feet", _array("WalkState.p_world_feet", self.p_world_feet, (4, 3)))
        object.__setattr__(self, "contact", _array("WalkState.contact", self.contact, (4,), np.bool_))
        for name in ("yaw", "yaw_rate", "t"):
            object.__setattr__(self, name, _finite(f"WalkState.{name}", getattr(self, name)))

    def ground_z(self) -> float:
        """Returns the ground height under the robot (m): mean height of the stance feet, else of all feet."""
        feet_z = self.p_world_feet[:, 2]
        return float(feet_z[self.contact].mean() if self.contact.any() else feet_z.min())


def standing_state(
    robot: StepRobot,
    *,
    t: float = 0.0,
    yaw: float = 0.0,
    v_xy: tuple[float, float] = (0.0, 0.0),
    xy: tuple[float, float] = (0.0, 0.0),
) -> WalkState:
    """Returns a WalkState of the robot standing at its nominal stance on flat ground (z=0)."""
    c, s = math.cos(yaw), math.sin(yaw)
    R = np.array([[c, -s], [s, c]])
    feet = np.zeros((4, 3))
    feet[:, :2] = np.asarray(robot.nominal_foot_body)[:, :2] @ R.T + np.asarray(xy)
    return WalkState(
        p_world_com=np.array([xy[0], xy[1], robot.standing_height_m]),
        v_world_com=np.array([v_xy[0], v_xy[1], 0.0]),
        yaw=yaw,
        yaw_rate=0.0,
        p_world_feet=feet,
        contact=np.ones(4, dtype=bool),
        t=t,
    )


def rotate_yaw(yaw: F64 | float, d: F64) -> F64:
    """Returns planar vectors d (..., 2) turned by yaw (...,) rad (broadcasting)."""
    y = np.asarray(yaw, dtype=np.float64)
    return rotate_cs(np.cos(y), np.sin(y), d)


def rotate_cs(c: F64, s: F64, d: F64) -> F64:
    """Returns planar vectors d (..., 2) turned by the angle whose cosine and sine are c, s (...,) (broadcasting);
    rotate_yaw with the trigonometry done once by the caller."""
    dx, dy = d[..., 0], d[..., 1]
    x = c * dx
    out = np.empty(x.shape + (2,))
    np.subtract(x, s * dy, out=out[..., 0])
    np.add(s * dx, c * dy, out=out[..., 1])
    return out


@dataclass(frozen=True)
class BodyMotion:
    """The body's planar motion predicted from a command: constant heading-frame velocity and yaw rate.

    p0_world: (2,) body position at t0, m. yaw0: rad. v_heading: (2,) m/s. yaw_rate: rad/s. t0: s.
    """

    p0_world: F64
    yaw0: float
    v_heading: F64
    yaw_rate: float
    t0: float

    def yaw(self, t: F64 | float) -> F64:
        """Returns the predicted yaw (rad) at times t (s), any shape."""
        return self.yaw0 + self.yaw_rate * (np.asarray(t, dtype=np.float64) - self.t0)

    def position(self, t: F64 | float) -> F64:
        """Returns the predicted body position (..., 2) in world m at times t (...,) s (closed-form arc)."""
        tau = np.asarray(t, dtype=np.float64) - self.t0
        r = self.yaw_rate
        vx, vy = float(self.v_heading[0]), float(self.v_heading[1])
        if abs(r) < 1e-6:
            c, s = math.cos(self.yaw0), math.sin(self.yaw0)
            dx = (c * vx - s * vy) * tau
            dy = (s * vx + c * vy) * tau
        else:
            y1 = self.yaw0 + r * tau
            dsin = (np.sin(y1) - math.sin(self.yaw0)) / r
            dcos = (np.cos(y1) - math.cos(self.yaw0)) / r
            dx = dsin * vx + dcos * vy
            dy = -dcos * vx + dsin * vy
        out = np.empty(np.shape(dx) + (2,))
        out[..., 0] = self.p0_world[0] + dx
        out[..., 1] = self.p0_world[1] + dy
        return out

    def velocity_world(self, t: F64 | float) -> F64:
        """Returns the predicted body velocity (..., 2) in world m/s at times t (...,) s."""
        return rotate_yaw(self.yaw(t), self.v_heading)

    def neutral_points(self, t: F64, neutral_body: F64, legs: I64) -> F64:
        """Returns the world xy (..., 2) of the legs' neutral points (nominal foot xy, body frame) at times t."""
        return self.position(t) + rotate_yaw(self.yaw(t), neutral_body[legs])


_FIRST_CACHE: dict[tuple[str, bytes], I64] = {}  # each leg's first touchdown index, by touchdown-leg sequence


@dataclass(frozen=True)
class StepPath:
    """A step path: touchdowns (leg, time, place) plus the timing around them, sorted by touchdown time.

    leg: (K,) int leg index of each touchdown. t_touchdown: (K,) s. t_liftoff: (K,) s, when the foot placed at
    this touchdown lifts off again. p_world_touchdown: (K,3) m. t_liftoff_now: (4,) s, next liftoff of the legs in
    stance now (inf when not within the path, nan for legs in swing now). body: the body motion it assumes.
    kind: which generator made it ("reference", "offset", "timing", "template", "footprint", "push", ...).
    gait: the gait it was planned for. violation: how far it violates the robot's constraints (0 = feasible).
    """

    leg: I64
    t_touchdown: F64
    t_liftoff: F64
    p_world_touchdown: F64
    t_liftoff_now: F64
    body: BodyMotion
    kind: str = "reference"
    gait: str = ""
    violation: float = 0.0
    _first: I64 = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        k = self.leg.shape[0]
        if (
            self.t_touchdown.shape != (k,)
            or self.t_liftoff.shape != (k,)
            or self.p_world_touchdown.shape != (k, 3)
        ):
            raise ValueError(f"StepPath: inconsistent shapes for {k} touchdowns")
        key = (self.leg.dtype.str, self.leg.tobytes())
        first = _FIRST_CACHE.get(key)
        if first is None:
            first = np.full(N_LEGS, -1, dtype=np.int64)
            for i in range(k - 1, -1, -1):
                first[self.leg[i]] = i
            first.flags.writeable = False  # shared by every path with these touchdown legs
            if len(_FIRST_CACHE) > 256:
                _FIRST_CACHE.clear()
            _FIRST_CACHE[key] = first
        object.__setattr__(self, "_first", first)

    def sibling(
        self,
        t_touchdown: F64,
        t_liftoff: F64,
        p_world_touchdown: F64,
        t_liftoff_now: F64,
        kind: str,
        violation: float,
    ) -> StepPath:
        """Returns a path with this one's touchdown legs, body and gait and the given timing and places, whose
        shapes the caller guarantees ((K,), (K,), (K,3), (4,), e.g. rows of a batch stacked from this path): the
        checks of the constructor are skipped (a replan builds dozens of these)."""
        out = object.__new__(StepPath)
        out.__dict__.update(
            leg=self.leg,
            t_touchdown=t_touchdown,
            t_liftoff=t_liftoff,
            p_world_touchdown=p_world_touchdown,
            t_liftoff_now=t_liftoff_now,
            body=self.body,
            kind=kind,
            gait=self.gait,
            violation=violation,
            _first=self._first,
        )
        return out

    @property
    def n_touchdowns(self) -> int:
        return int(self.leg.shape[0])

    def next_touchdowns(self) -> tuple[F64, F64]:
        """Returns each leg's first touchdown in the path: times (4,) s and places (4,3) m (nan when none)."""
        t = np.full(N_LEGS, np.nan)
        p = np.full((N_LEGS, 3), np.nan)
        ok = self._first >= 0
        t[ok] = self.t_touchdown[self._first[ok]]
        p[ok] = self.p_world_touchdown[self._first[ok]]
        return t, p

    def contact_at(self, t: float, contact_now: B) -> B:
        """Returns the planned contact flags (4,) at time t (s) given the contact flags now."""
        out = np.array(contact_now, dtype=bool)
        for leg in range(N_LEGS):
            if out[leg] and t >= self.t_liftoff_now[leg]:
                out[leg] = False
            for i in np.flatnonzero(self.leg == leg):
                if t >= self.t_touchdown[i]:
                    out[leg] = t < self.t_liftoff[i]
        return out

    def with_touchdowns(self, p_world_touchdown: F64, kind: str, t_shift: float = 0.0) -> StepPath:
        """Returns a copy with other touchdown places (K,3) and all future events shifted by t_shift s."""
        return StepPath(
            leg=self.leg,
            t_touchdown=self.t_touchdown + t_shift if t_shift else self.t_touchdown,
            t_liftoff=self.t_liftoff + t_shift if t_shift else self.t_liftoff,
            p_world_touchdown=p_world_touchdown,
            t_liftoff_now=self.t_liftoff_now + t_shift if t_shift else self.t_liftoff_now,
            body=self.body,
            kind=kind,
            gait=self.gait,
        )
