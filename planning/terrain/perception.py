"""The perception stage: depth scan → voxel map → 2D maps, at its own (slower) rate.

``Perception.update(data)`` scans when a new scan is due (every 1/rate_hz of sim time) and returns the maps of the
moment (the previous ones when no scan was due), so the step planner can call it every tick.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import mujoco
import numpy as np

from planning.terrain.maps import MapParams, TerrainMaps, build_maps
from planning.terrain.memory import GroundMemory
from planning.terrain.sensor import DepthSensor, PointCloud, SensorParams
from planning.terrain.voxels import VoxelMap, VoxelParams


@dataclass(frozen=True)
class PerceptionParams:
    """Perception. body_height_m: height of the sensor body above its ground, to place the map vertically (m);
    remember_ground: cells a scan leaves unknown take their last observed ground height (memory.py)."""

    sensor: SensorParams = field(default_factory=SensorParams)
    voxels: VoxelParams = field(default_factory=VoxelParams)
    maps: MapParams = field(default_factory=MapParams)
    body_height_m: float = 0.52
    remember_ground: bool = True


class Perception:
    """Holds the sensor, the voxel map and the last maps; `update` every tick, it scans at sensor.rate_hz."""

    def __init__(
        self, model: mujoco.MjModel, body: str | int, params: PerceptionParams | None = None
    ) -> None:
        self.params = params or PerceptionParams()
        self.sensor = DepthSensor(model, body, self.params.sensor)
        self.voxels = VoxelMap(self.params.voxels)
        self.memory = GroundMemory() if self.params.remember_ground else None
        self.maps: TerrainMaps | None = None
        self.last_cloud: PointCloud | None = None
        self._t_next = -np.inf
        self.timings_ms: list[float] = []
        # The last scan's stages (ms): scan (of which raycast: MuJoCo's ray casting alone), voxels (integration),
        # classify (columns and the ground memory), maps.
        self.last_stage_ms: dict[str, float] = {}
        self.last_stage_cpu_ms: dict[str, float] = {}

    def ground_under_body(self, data: mujoco.MjData) -> float:
        """Gives the ground height (m) under the body: from the last maps, else from the body height."""
        p_body = data.xpos[self.sensor.body_id]
        if self.maps is not None and bool(self.maps.in_map(p_body[0], p_body[1])):
            return float(self.maps.height_at(p_body[0], p_body[1]))
        return float(p_body[2] - self.params.body_height_m)

    def scan_now(self, data: mujoco.MjData, map_params: MapParams | None = None) -> TerrainMaps:
        """Scans, integrates and rebuilds the maps now (with map_params, default params.maps); gives them."""
        clock, cpu = time.perf_counter, time.thread_time
        t0, c0 = clock(), cpu()
        cloud = self.sensor.scan(data)
        t1, c1 = clock(), cpu()
        p_body = data.xpos[self.sensor.body_id]
        ground_z = float(p_body[2] - self.params.body_height_m)
        self.voxels.integrate(cloud, (float(p_body[0]), float(p_body[1])), ground_z)
        t2, c2 = clock(), cpu()
        columns = self.voxels.classify()
        if self.memory is not None:
            columns = self.memory.apply(columns)
        t3, c3 = clock(), cpu()
        self.maps = build_maps(
            columns, map_params or self.params.maps, default_ground_z=ground_z, t_s=float(data.time)
        )
        t4, c4 = clock(), cpu()
        self.last_cloud = cloud
        self.timings_ms.append((t4 - t0) * 1e3)
        self.last_stage_ms = {
            "scan": (t1 - t0) * 1e3, "raycast": self.sensor.raycast_ms, "voxels": (t2 - t1) * 1e3,
            "classify": (t3 - t2) * 1e3, "maps": (t4 - t3) * 1e3,
        }  # fmt: skip
        # The same in this thread's CPU time, which other processes on a shared machine do not inflate.
        self.last_stage_cpu_ms = {
            "scan": (c1 - c0) * 1e3, "raycast": self.sensor.raycast_cpu_ms, "voxels": (c2 - c1) * 1e3,
            "classify": (c3 - c2) * 1e3, "maps": (c4 - c3) * 1e3,
        }  # fmt: skip
        return self.maps

    def update(self, data: mujoco.MjData) -> TerrainMaps:
        """Gives the maps of the moment, scanning first when a scan is due."""
        if self.maps is None or data.time >= self._t_next:
            self._t_next = float(data.time) + 1.0 / self.params.sensor.rate_hz
            return self.scan_now(data)
        return self.maps
