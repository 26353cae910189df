"""Cheap stand-ins for the simulation, so the API's plumbing is tested without MuJoCo (module-level: they pickle)."""

from __future__ import annotations

import os
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
from fastapi.testclient import TestClient

from server.app import create_app
from server.engine import SteeringUnavailable
from server.settings import Settings


class FakeSim:
    """A 'robot' whose body drifts along +x at 0.1 m/s; `crash = True` makes the next step raise."""

    dt = 0.002

    def __init__(self, maneuver: Any, terrain: str, robot: str = "spot") -> None:
        self.maneuver = maneuver
        self.terrain = terrain
        self.steps = 0
        self.crash = False
        self.pushes: list[tuple[tuple[float, float, float], float]] = []
        self.offset = np.zeros(3)

    @property
    def t(self) -> float:
        return self.steps * self.dt

    def step(self) -> None:
        if self.crash:
            raise RuntimeError("boom: the fake simulation exploded")
        self.steps += 1

    def trim(self) -> None:
        pass

    def push(self, force_n: tuple[float, float, float], duration_s: float) -> None:
        self.pushes.append((force_n, duration_s))

    def steer(self, vx: float, vy: float, yaw_rate: float, gait: str) -> None:
        raise SteeringUnavailable()

    def body_poses(self) -> tuple[np.ndarray, np.ndarray]:
        xpos = np.zeros((2, 3))
        xpos[:, 0] = 0.1 * self.t
        xpos[:, 2] = 0.52
        xquat = np.tile([1.0, 0.0, 0.0, 0.0], (2, 1))
        return xpos, xquat

    def reference(self) -> tuple[np.ndarray, np.ndarray] | None:
        return np.array([0.1 * self.t, 0.0, 0.52]), np.array([0.1, 0.0, 0.0])

    def tick_ms(self) -> float | None:
        return 0.1

    def state_dict(self) -> dict[str, Any]:
        return {
            "t": round(self.t, 4),
            "body": {"position": [0.1 * self.t, 0.0, 0.52], "velocity": [0.1, 0.0, 0.0]},
            "fell": False,
            "failure_reason": None,
        }

    def plan_dict(self) -> dict[str, Any]:
        return {
            "t": self.t,
            "overlays": {"body_path": {"kind": "polyline", "points": [[0, 0, 0.52], [0.1, 0, 0.52]]}},
        }

    def report(self, wall_s: float) -> dict[str, Any]:
        return {"maneuver": getattr(self.maneuver, "name", "?"), "duration_s": self.t, "success": True}


def fake_runner(job: dict[str, Any]) -> dict[str, Any]:
    """A headless run that takes a moment and returns a report-shaped dict."""
    from server.simulations import worker_progress

    progress = worker_progress(job["id"])
    for k in range(3):
        if progress is not None:
            progress(0.1 * (k + 1), 0.3, 1.0)
        time.sleep(0.05)
    name = job["maneuver"]["name"] if job.get("maneuver") else "walk"
    return {
        "maneuver": name,
        "terrain": job["terrain"],
        "success": True,
        "pushes": job["pushes"],
        "duration_s": 0.3,
    }


def failing_runner(job: dict[str, Any]) -> dict[str, Any]:
    raise ValueError("the planner gave up")


def dying_runner(job: dict[str, Any]) -> dict[str, Any]:
    """Kills its worker process, as a segfault in MuJoCo would; a second job after it must still run."""
    if (job.get("maneuver") or {}).get("name") == "bow":
        os._exit(3)
    return fake_runner(job)


def slow_runner(job: dict[str, Any]) -> dict[str, Any]:
    time.sleep(1.0)
    return fake_runner(job)


def files_in(d: Path) -> list[str]:
    """Returns the file names in a directory (hidden temporaries and the lock file included), sorted."""
    return sorted(p.name for p in d.iterdir()) if d.is_dir() else []


def make_client(settings: Settings, **kw: Any) -> Iterator[TestClient]:
    """Yields a TestClient of an app built with `settings` (lifespan run: reaper started, services closed)."""
    app = create_app(settings, **kw)
    with TestClient(app, raise_server_exceptions=False) as c:
        yield c


def falling_runner(job: dict[str, Any]) -> dict[str, Any]:
    """A physics check whose robot falls after the first touchdown of the maneuver's events (a run report with the
    per-event margins of planning.maneuver.physics); other jobs as fake_runner."""
    if not job.get("physics_check"):
        return fake_runner(job)
    events = []
    for i, e in enumerate(job["maneuver"].get("events") or []):
        row = {"t": e["t"], "leg": e["leg"], "type": e["type"], "path": f"events[{i}]", "explicit": True,
               "reached": True, "phase": i, "peak_torque_use": 0.99, "peak_torque_joint": f"{e['leg']} knee",
               "friction_use": 0.4, "stability_margin_m": -0.1, "backup_ticks": 0}  # fmt: skip
        if e["type"] == "touchdown":
            row.update(time_window_s=0.05, place_window_m=0.0, timing_error_s=0.09, place_error_m=0.02,
                       within_window=True)  # fmt: skip
        events.append(row)
    return {"maneuver": job["maneuver"]["name"], "success": False, "fell": True, "fall_time_s": 2.0,
            "failure_reason": "fell: body dropped to 0.20 m at t=2.00 s", "duration_s": 2.0,
            "timing": {"wall_s": 0.5, "rtf": 4.0}, "events": events}  # fmt: skip
