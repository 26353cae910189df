"""Shared helpers for the step-planning tests (a cached robot, states, simple maps)."""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from planning.robot import RobotModel, load_robot
from planning.steps import (
    GaitClock,
    SteeringCommand,
    StepPath,
    WalkState,
    get_gait,
    reference_step_path,
    standing_state,
)


@lru_cache(maxsize=2)
def robot(name: str = "spot") -> RobotModel:
    return load_robot(name)


def walking_reference(
    gait: str = "trot",
    v: tuple[float, float, float] = (0.5, 0.0, 0.0),
    v_state: tuple[float, float] | None = None,
    t0: float = 0.0,
    name: str = "spot",
) -> tuple[StepPath, WalkState, GaitClock]:
    """Returns a reference path for a robot standing at its nominal stance moving at v_state (default the command)."""
    r = robot(name)
    vs = v_state if v_state is not None else (v[0], v[1])
    state = standing_state(r, v_xy=vs, t=t0)
    clock = GaitClock(gait, t0=t0)
    ref = reference_step_path(SteeringCommand(*v), state, r, get_gait(gait), clock, t0)
    return ref, state, clock


class StripMaps:
    """No-step map: a strip |x - x0| < half_width_m (a gap); flat ground at z_m."""

    def __init__(self, x0: float, half_width_m: float, z_m: float = 0.0) -> None:
        self.x0, self.hw, self.z = x0, half_width_m, z_m

    def no_step(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        return np.abs(np.asarray(x) - self.x0) < self.hw

    def ground_height(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        return np.full(np.broadcast(np.asarray(x), np.asarray(y)).shape, self.z)
