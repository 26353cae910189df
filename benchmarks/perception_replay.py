"""Record depth scans and the maps and regions perception builds from them; later, replay the scans and compare.

A change to the perception (voxels.py, memory.py, maps.py, regions.py) that should not change its output is checked
by recording with the code before it and comparing with the code after it:

    python -m benchmarks.perception_replay record /tmp/scans.npz      # the code before the change
    python -m benchmarks.perception_replay compare /tmp/scans.npz     # the code after: prints every difference

Scans are taken on each terrain with a stand-in body (as `footfall bench --only perception`) moved 0.1 m a scan,
swaying sideways, so the map shifts and sees new ground; the replay feeds the recorded clouds (noise included)
through a fresh voxel map, ground memory and map building, so the sensor's ray casting is not part of the check. The
steppable regions (`segment_regions` with its default parameters, no cover, as `footfall bench` runs it) of each
scan's maps are recorded and compared too (`--no-regions`: maps only, for recordings made without them). To record
with another checkout's planning code, run this file by path with that checkout on PYTHONPATH.
"""

from __future__ import annotations

import argparse
import sys
import time
from typing import Any

import numpy as np

MAP_FIELDS = (
    "ground_height", "observed", "body_obstacle", "step_obstacle", "sdf_body_m", "sdf_step_m", "grad_sdf_body",
    "grad_sdf_step", "clearance_m",
)  # fmt: skip
REGION_FIELDS = ("labels", "inset", "depth_m", "normals", "z0", "xy0", "roughness_m", "area_m2")
TERRAINS = ("stairs", "clutter", "stones", "under-table", "rough", "slope")


def record(path: str, scans: int = 10, terrains: tuple[str, ...] = TERRAINS) -> None:
    """Scans each terrain `scans` times and saves the clouds, body positions and the maps built from them."""
    import mujoco

    from planning.terrain.bench import _STAND_IN
    from planning.terrain.perception import Perception
    from planning.terrain.regions import RegionParams, segment_regions
    from planning.terrain.scenes import build_terrain

    out: dict[str, Any] = {}
    for terrain in terrains:
        scene = build_terrain(terrain)
        model = mujoco.MjModel.from_xml_string(scene.mjcf(_STAND_IN))
        data = mujoco.MjData(model)
        perception = Perception(model, "robot")
        for i in range(scans):
            x = 0.8 + 0.1 * i
            data.qpos[0] = x
            data.qpos[1] = 0.05 * np.sin(i)
            data.qpos[2] = 0.52 + float(scene.ground_height(x, 0.0))
            mujoco.mj_kinematics(model, data)
            maps = perception.scan_now(data)
            cloud = perception.last_cloud
            assert cloud is not None
            key = f"{terrain}/{i:03d}"
            out[f"{key}/points"] = cloud.p_world_points
            out[f"{key}/origins"] = cloud.p_world_origins
            out[f"{key}/t"] = np.float64(cloud.t_s)
            out[f"{key}/body"] = data.xpos[perception.sensor.body_id].copy()
            out[f"{key}/origin_xy"] = np.asarray(maps.origin_xy)
            for name in MAP_FIELDS:
                out[f"{key}/{name}"] = getattr(maps, name)
            regions = segment_regions(maps, RegionParams(), cover=False)
            for name in REGION_FIELDS:
                out[f"{key}/regions/{name}"] = getattr(regions, name)
    np.savez_compressed(path, **out)
    print(f"recorded {scans} scans of {len(terrains)} terrains into {path}")


def compare(path: str, regions: bool = True) -> int:
    """Replays the recorded scans and compares each map (and with regions, each scan's regions) with the recorded
    one; gives the number of differing arrays (0: every map and region array the same, bit for bit)."""
    from planning.terrain.maps import build_maps
    from planning.terrain.memory import GroundMemory
    from planning.terrain.perception import PerceptionParams
    from planning.terrain.regions import RegionParams, segment_regions
    from planning.terrain.sensor import PointCloud
    from planning.terrain.voxels import VoxelMap

    rec = np.load(path)
    keys = sorted({k.rsplit("/", 1)[0] for k in rec.files if "/regions/" not in k})
    if regions and not any("/regions/" in k for k in rec.files):
        print(f"{path} holds no regions (recorded without them): run with --no-regions")
        return 1
    params = PerceptionParams()
    state: dict[str, tuple[VoxelMap, GroundMemory]] = {}
    bad = 0
    times: list[float] = []
    for key in keys:
        terrain = key.split("/")[0]
        if terrain not in state:
            state[terrain] = (VoxelMap(params.voxels), GroundMemory())
        voxels, memory = state[terrain]
        body = rec[f"{key}/body"]
        ground_z = float(body[2] - params.body_height_m)
        cloud = PointCloud(rec[f"{key}/points"], rec[f"{key}/origins"], float(rec[f"{key}/t"]))
        t0 = time.process_time()
        voxels.integrate(cloud, (float(body[0]), float(body[1])), ground_z)
        maps = build_maps(
            memory.apply(voxels.classify()), params.maps, default_ground_z=ground_z, t_s=cloud.t_s
        )
        times.append((time.process_time() - t0) * 1e3)
        if not np.array_equal(np.asarray(maps.origin_xy), rec[f"{key}/origin_xy"]):
            print(f"{key}: the map's origin differs")
            bad += 1
        for name in MAP_FIELDS:
            want, got = rec[f"{key}/{name}"], getattr(maps, name)
            if not np.array_equal(want, got):
                bad += 1
                if want.dtype == bool:
                    print(f"{key} {name}: {int(np.count_nonzero(want != got))} cells differ")
                else:
                    d = np.abs(np.where(np.isfinite(want) & np.isfinite(got), want - got, 0.0))
                    print(f"{key} {name}: max difference {float(d.max()):.3g}; finite where not: "
                          f"{int(np.count_nonzero(np.isfinite(want) != np.isfinite(got)))} cells")  # fmt: skip
        if regions:
            seg = segment_regions(maps, RegionParams(), cover=False)
            for name in REGION_FIELDS:
                want, got = rec[f"{key}/regions/{name}"], getattr(seg, name)
                if want.shape != got.shape or not np.array_equal(want, got):
                    bad += 1
                    n_bad = int(np.count_nonzero(want != got)) if want.shape == got.shape else -1
                    print(f"{key} regions {name}: {n_bad} entries differ (-1: another shape)")
    what = "map and region" if regions else "map"
    print(
        f"{len(keys)} scans replayed, {bad} {what} arrays differ; voxels to maps {np.median(times):.2f} ms CPU p50"
    )
    return bad


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(
        prog="python -m benchmarks.perception_replay", description=__doc__.split("\n")[0]
    )
    sub = ap.add_subparsers(dest="cmd", required=True)
    r = sub.add_parser("record", help="scan the terrains and save the clouds and maps")
    r.add_argument("path")
    r.add_argument("--scans", type=int, default=10, help="scans per terrain (default 10)")
    c = sub.add_parser("compare", help="replay the saved clouds and compare the maps")
    c.add_argument("path")
    c.add_argument("--no-regions", action="store_true", help="compare the maps only")
    a = ap.parse_args(argv)
    if a.cmd == "record":
        record(a.path, a.scans)
        return 0
    return 1 if compare(a.path, regions=not a.no_regions) else 0


if __name__ == "__main__":
    sys.exit(main())
