"""The plan frame: where a maneuver's own frame sits in the world.

A maneuver's footholds, keyframes and swing waypoints are written relative to the robot's start pose: the maneuver
frame has its origin on the ground under the start pose and its x axis along the start heading. A run started off
the origin (a start position and yaw) maps every point, direction and rotation of the plan through this frame.
"""

from __future__ import annotations

import numpy as np


class PlanFrame:
    """A planar rigid placement of the maneuver frame in the world: a yaw about z and a translation (x, y, z)."""

    def __init__(self, x_m: float = 0.0, y_m: float = 0.0, z_m: float = 0.0, yaw_rad: float = 0.0) -> None:
        self.yaw = float(yaw_rad)
        c, s = np.cos(self.yaw), np.sin(self.yaw)
        self.R = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        self.R2 = self.R[:2, :2].copy()
        self.t = np.array([x_m, y_m, z_m], dtype=float)
        self.turned = self.yaw != 0.0

    def point(self, p: np.ndarray) -> np.ndarray:
        """Returns a maneuver-frame point (3,) or points (N,3) in the world."""
        p = np.asarray(p, dtype=float)
        return (p @ self.R.T if self.turned else p) + self.t

    def vector(self, v: np.ndarray) -> np.ndarray:
        """Returns a maneuver-frame direction or velocity (3,) (or (N,3)) in the world."""
        v = np.asarray(v, dtype=float)
        return v @ self.R.T if self.turned else v

    def rotation(self, R: np.ndarray) -> np.ndarray:
        """Returns a maneuver-frame orientation (3,3) in the world."""
        return self.R @ R if self.turned else R

    def xy(self, p: np.ndarray) -> np.ndarray:
        """Returns maneuver-frame horizontal points (2,) or (K,2) in the world."""
        p = np.asarray(p, dtype=float)
        return (p @ self.R2.T if self.turned else p) + self.t[:2]

    def direction_xy(self, d: np.ndarray) -> np.ndarray:
        """Returns a maneuver-frame horizontal direction (2,) in the world."""
        d = np.asarray(d, dtype=float)
        return self.R2 @ d if self.turned else d
