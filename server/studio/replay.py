"""Replay and compare: a finished (or running) preview kept as a take of body poses, shown at any time of the
timeline's playhead, frame by frame, with the run before it as a translucent ghost robot (before/after an edit)."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any

import numpy as np

from server.engine import Visuals
from server.studio.robot_view import add_geom

GHOST_RGBA = (0.55, 0.7, 1.0, 0.35)  # the ghost robot's color and opacity


@dataclass(frozen=True)
class Take:
    """One recorded preview: times t (F,) s since its start, body poses xpos (F,nb,3) m and xquat (F,nb,4) wxyz."""

    maneuver: str
    terrain: str
    t: np.ndarray
    xpos: np.ndarray
    xquat: np.ndarray

    def index_at(self, t: float) -> int:
        """Returns the frame shown at time t (s): the last one at or before it (the first before the start)."""
        return int(np.clip(np.searchsorted(self.t, t + 1e-9, side="right") - 1, 0, len(self.t) - 1))

    def pose_at(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        k = self.index_at(t)
        return self.xpos[k], self.xquat[k]

    def step(self, t: float, frames: int) -> float:
        """Returns the time of the frame `frames` away from the one shown at t (clamped to the take)."""
        k = int(np.clip(self.index_at(t) + frames, 0, len(self.t) - 1))
        return float(self.t[k])


def take_of(session: Any) -> Take | None:
    """Returns a copy of the session's recording (None when it has fewer than two frames)."""
    with session.lock:
        rec = session.recording
        if len(rec.t) < 2:
            return None
        return Take(rec.maneuver, rec.terrain, np.array(rec.t, dtype=float), np.array(rec.xpos, dtype=float),
                    np.array(rec.xquat, dtype=float))  # fmt: skip


class GhostRobot:
    """The robot alone (no terrain), translucent, posed from a take."""

    def __init__(self, scene: Any, visuals: Visuals, root: str = "/ghost") -> None:
        self.bodies = [
            scene.add_frame(f"{root}/{b:02d}_{n}", show_axes=False) for b, n in enumerate(visuals.body_names)
        ]
        self.geoms = []
        for i, g in enumerate(visuals.robot_geoms):
            h = add_geom(
                scene, f"{self.bodies[g.body].name}/{i:02d}_{g.name}", dataclasses.replace(g, rgba=GHOST_RGBA)
            )
            if h is not None:
                self.geoms.append(h)

    def set_poses(self, xpos: np.ndarray, xquat: np.ndarray) -> None:
        for h, p, q in zip(self.bodies, xpos, xquat, strict=False):
            h.position = p
            h.wxyz = q

    def set_visible(self, on: bool) -> None:
        for h in self.bodies:
            h.visible = on

    def remove(self) -> None:
        for h in [*self.geoms, *self.bodies]:
            try:
                h.remove()
            except Exception:  # noqa: BLE001 - already gone with the client
                pass
        self.geoms.clear()
        self.bodies.clear()
