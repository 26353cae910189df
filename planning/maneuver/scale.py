"""Maneuvers scale to the robot that runs them.

A maneuver's lengths are written for the reference robot (the shipped Spot-class model: its standing height and
nominal stance, read from ``planning/robot/assets/spot.yaml``). On another robot every height scales by the ratio of
standing heights, every fore/aft length by the ratio of the stances' half-lengths and every lateral length by the
ratio of their half-widths, so the nominal stance maps onto the robot's own nominal stance and a crouch to a crouch
of the same share of its height. Times, angles, weights and friction do not change. On the reference robot itself a
maneuver is returned unchanged (the same object).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from typing import Any

import yaml

from planning.maneuver.spec import Maneuver
from planning.robot import RobotModel
from planning.robot.model import ASSETS

REFERENCE_ROBOT = "spot"


@dataclass(frozen=True)
class Scale:
    """Per-axis factors from the reference robot's lengths to a robot's (x fore/aft, y lateral, z up)."""

    x: float
    y: float
    z: float

    @property
    def identity(self) -> bool:
        return self.x == 1.0 and self.y == 1.0 and self.z == 1.0

    @property
    def horizontal(self) -> float:
        """One factor for radii and distances that have no direction (the smaller: adjust windows stay inside)."""
        return min(self.x, self.y)


@lru_cache(maxsize=1)
def reference_dimensions() -> tuple[float, float, float]:
    """The reference robot's nominal stance half-length, half-width and standing height (m)."""
    desc = yaml.safe_load((ASSETS / f"{REFERENCE_ROBOT}.yaml").read_text())
    st = desc["nominal_stance"]
    return float(st["x"]), float(st["y"]), float(desc["standing_height"])


def robot_scale(robot: RobotModel) -> Scale:
    """Returns the factors that take a maneuver written for the reference robot to `robot`."""
    sx0, sy0, h0 = reference_dimensions()
    sx, sy = robot.nominal_stance_xy
    x, y, z = sx / sx0, sy / sy0, robot.standing_height_m / h0
    # the reference robot's own numbers give factors of exactly 1 (up to rounding of its description)
    near = lambda v: 1.0 if abs(v - 1.0) < 1e-9 else float(v)  # noqa: E731
    return Scale(near(x), near(y), near(z))


def _xyz(v: Any, s: Scale) -> tuple[float, ...]:
    out = [float(v[0]) * s.x, float(v[1]) * s.y]
    if len(v) > 2:
        out.append(float(v[2]) * s.z)
    return tuple(out)


def scale_to_robot(maneuver: Maneuver, robot: RobotModel) -> Maneuver:
    """Returns `maneuver` with its lengths scaled from the reference robot to `robot` (see the module docstring)."""
    s = robot_scale(robot)
    if s.identity:
        return maneuver
    data = maneuver.model_dump(by_alias=True, exclude_unset=True)

    def adjust(a: dict[str, Any] | None) -> None:
        if not a:
            return
        if a.get("radius") is not None:
            a["radius"] = float(a["radius"]) * s.horizontal
        if a.get("region") is not None:
            a["region"] = [_xyz(p, s) for p in a["region"]]

    for ev in data.get("events", []):
        if ev.get("type") != "touchdown":
            continue
        if ev.get("at") is not None:
            ev["at"] = _xyz(ev["at"], s)
        if ev.get("offset") is not None:
            ev["offset"] = _xyz(ev["offset"], s)
        if ev.get("waypoints") is not None:
            ev["waypoints"] = [(float(w[0]), *_xyz(w[1:], s)) for w in ev["waypoints"]]
        adjust(ev.get("adjust"))
    for g in data.get("gaits", []):
        if g.get("step") is not None:
            dx, dy, dyaw = g["step"]
            g["step"] = (float(dx) * s.x, float(dy) * s.y, float(dyaw))
        if g.get("height") is not None:
            g["height"] = float(g["height"]) * s.z
        adjust(g.get("adjust"))
    for k in data.get("body", []):
        k["position"] = _xyz(k["position"], s)
    return Maneuver.model_validate(data)
