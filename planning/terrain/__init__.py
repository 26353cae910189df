"""Terrain-aware step planning: scenes, perception (sensor → voxels → maps), body path, gait cadence, step QP."""

from planning.terrain.bodypath import BodyPath, BodyPathParams, plan_body_path
from planning.terrain.cadence import (
    CADENCES,
    Cadence,
    CadenceParams,
    CadenceScore,
    choose_cadence,
    make_request,
)
from planning.terrain.maps import MapParams, TerrainMaps, build_maps, maps_from_grids, maps_from_scene
from planning.terrain.perception import Perception, PerceptionParams
from planning.terrain.regions import (
    ConvexRegion,
    RegionParams,
    SteppableRegions,
    convex_around,
    segment_regions,
)
from planning.terrain.scenes import TERRAIN_NAMES, TerrainScene, build_terrain
from planning.terrain.sensor import DepthCamera, DepthSensor, PointCloud, SensorParams
from planning.terrain.stepqp import FAMILIES, StepPlan, StepQP, StepQPParams, StepRequest
from planning.terrain.voxels import Columns, VoxelMap, VoxelParams

__all__ = [
    "CADENCES", "FAMILIES", "TERRAIN_NAMES", "BodyPath", "BodyPathParams", "Cadence", "CadenceParams",
    "CadenceScore", "Columns", "ConvexRegion", "DepthCamera", "DepthSensor", "MapParams", "Perception",
    "PerceptionParams", "RegionParams", "SteppableRegions", "convex_around", "segment_regions",
    "PointCloud", "SensorParams", "StepPlan", "StepQP", "StepQPParams", "StepRequest", "TerrainMaps",
    "TerrainScene", "VoxelMap", "VoxelParams", "build_maps", "build_terrain", "choose_cadence", "make_request",
    "maps_from_grids", "maps_from_scene", "plan_body_path",
]  # fmt: skip
