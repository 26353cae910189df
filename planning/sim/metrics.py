"""What a run measured: a recorder that watches the loop, and the JSON run report of CONTRACT.md."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from planning.geometry import clip_scalar
from planning.robot import LEGS
from planning.sim.world import RobotState


def percentiles(values: list[float] | np.ndarray) -> dict[str, float]:
    """Returns {"p50_ms", "p99_ms"} of a list of milliseconds (absent values → empty dict)."""
    if len(values) == 0:
        return {}
    a = np.asarray(values, dtype=float)
    return {"p50_ms": round(float(np.percentile(a, 50)), 4), "p99_ms": round(float(np.percentile(a, 99)), 4)}


# A contact onset is a landing when the foot rose at least this far (m) above where it last left the ground: less
# is a foot scuffing along the ground as it lifts, or chattering on it while it slides (seen at 2-10 ms apart on
# the stones), not a step.
LANDING_RISE_M = 0.01


@dataclass
class Touchdown:
    leg: int
    t: float
    p_world: np.ndarray  # contact point (foot center minus radius along z)
    # how high the foot rose above where it last stood before this contact (m)
    rise_m: float = float("inf")

    @property
    def landing(self) -> bool:
        """Whether this contact ends a swing (the foot rose LANDING_RISE_M or more), not a scuff or a chatter."""
        return self.rise_m >= LANDING_RISE_M


@dataclass
class Recorder:
    """Watches every physics step: touchdowns (contact rising edges, each with how high the foot rose before it),
    the body path, velocity samples."""

    foot_radius_m: float
    sample_period_s: float = 0.02
    touchdowns: list[Touchdown] = field(default_factory=list)
    landings: int = 0  # how many of the touchdowns are landings (Touchdown.landing): the steps taken
    t: list[float] = field(default_factory=list)
    p_body: list[np.ndarray] = field(default_factory=list)
    rpy_body: list[np.ndarray] = field(default_factory=list)
    v_body: list[np.ndarray] = field(default_factory=list)
    yaw_rate: list[float] = field(default_factory=list)
    airborne: list[float] = field(default_factory=list)  # airborne_s so far, at each sample
    max_foot_slip_m: float = 0.0  # largest horizontal slide of a foot in contact from where it touched down
    airborne_s: float = 0.0  # total time with no foot on the ground (flight)
    max_body_height_m: float = 0.0
    _t_prev: float = 0.0
    _prev_contact: np.ndarray = field(default_factory=lambda: np.ones(4, dtype=bool))
    _anchor: np.ndarray | None = None
    _z_off: np.ndarray | None = None  # (4,) each foot's height when it was last on the ground, m
    _z_top: np.ndarray | None = None  # (4,) each foot's highest point since, m
    _next_sample: float = 0.0

    def __call__(self, s: RobotState) -> None:
        if self._anchor is None:
            self._anchor = s.p_world_foot[:, :2].copy()
        if self._z_off is None or self._z_top is None:
            self._z_off = s.p_world_foot[:, 2].copy()
            self._z_top = self._z_off.copy()
        contact = s.loaded  # the ground pushes the foot (a soft foot may overlap the floor in flight)
        any_contact = bool(contact.any())
        if not any_contact:
            self.airborne_s += s.t - self._t_prev
        self._t_prev = s.t
        if s.p_world_body[2] > self.max_body_height_m:
            self.max_body_height_m = float(s.p_world_body[2])
        prev = self._prev_contact
        z = s.p_world_foot[:, 2]
        np.maximum(self._z_top, z, out=self._z_top, where=~contact)
        rising = contact & ~prev
        if rising.any():
            for leg in np.flatnonzero(rising):
                p = s.p_world_foot[leg].copy()
                p[2] -= self.foot_radius_m
                td = Touchdown(int(leg), s.t, p, float(self._z_top[leg] - self._z_off[leg]))
                self.touchdowns.append(td)
                self.landings += td.landing
                self._anchor[leg] = p[:2]
        # where each foot in contact stands: the height the next rise is measured from
        np.copyto(self._z_off, z, where=contact)
        np.copyto(self._z_top, z, where=contact)
        if any_contact:
            d = s.p_world_foot[:, :2] - self._anchor
            slip = np.hypot(d[:, 0], d[:, 1])
            m = float(np.where(contact, slip, 0.0).max())
            if m > self.max_foot_slip_m:
                self.max_foot_slip_m = m
        prev[:] = contact
        if s.t + 1e-9 >= self._next_sample:
            self._next_sample += self.sample_period_s
            self.t.append(s.t)
            self.p_body.append(s.p_world_body.copy())
            R = s.R_world_body
            self.rpy_body.append(
                np.array(
                    [
                        np.arctan2(R[2, 1], R[2, 2]),
                        np.arcsin(clip_scalar(-R[2, 0], -1.0, 1.0)),
                        np.arctan2(R[1, 0], R[0, 0]),
                    ]
                )
            )
            # body-frame horizontal velocity (heading frame) and yaw rate
            c, sn = R[0, 0], R[1, 0]
            n = np.hypot(c, sn) or 1.0
            c, sn = c / n, sn / n
            v = s.v_world_body
            self.v_body.append(np.array([c * v[0] + sn * v[1], -sn * v[0] + c * v[1]]))
            self.yaw_rate.append(float(s.omega_world[2]))
            self.airborne.append(self.airborne_s)

    def flight_fraction(self, t_from: float) -> float | None:
        """The fraction of the time since the first sample at or after t_from (s) with no foot on the ground (a flight
        phase), up to the last sample; None when there is no time to measure."""
        k = next((i for i, t in enumerate(self.t) if t >= t_from), None)
        if k is None or self.t[-1] <= self.t[k]:
            return None
        return (self.airborne[-1] - self.airborne[k]) / (self.t[-1] - self.t[k])


def match_touchdowns(
    planned: list[tuple[int, float, np.ndarray, float, float]], actual: list[Touchdown]
) -> list[dict[str, Any]]:
    """Pairs each planned touchdown (leg, t, p, time window, radius) with the nearest actual one of that leg."""
    out: list[dict[str, Any]] = []
    used: set[int] = set()
    for leg, t, p, win, radius in planned:
        best, best_dt = None, np.inf
        for k, a in enumerate(actual):
            if a.leg != leg or k in used:
                continue
            d = abs(a.t - t)
            if d < best_dt:
                best, best_dt = k, d
        row: dict[str, Any] = {
            "leg": LEGS[leg],
            "planned_t": round(t, 4),
            "planned_at": np.round(p, 4).tolist(),
        }
        if best is None or best_dt > max(0.3, 2 * win + 0.15):
            row.update(actual_t=None, actual_at=None, error_m=None, within_window=False)
        else:
            used.add(best)
            a = actual[best]
            err = float(np.linalg.norm(a.p_world[:2] - p[:2]))
            row.update(
                actual_t=round(a.t, 4),
                actual_at=np.round(a.p_world, 4).tolist(),
                error_m=round(err, 4),
                within_window=bool(best_dt <= win + 0.1 and err <= radius + 0.08),
            )
        out.append(row)
    return out
