"""Timings of the terrain stages, for `footfall bench`.

bench_perception(): one depth scan + voxel integration + map building per call, on a scene with a box standing in
for the robot, walked forward between scans.
bench_terrain_crossings(): terrain-aware walks to (6, 0) across each terrain in MuJoCo (slow: ~15 s of simulation each).
bench_step_qp(): replans of the step QP (8 footholds) at 300 Hz while a trot walks the body path across a terrain's
ground-truth maps: the feet land where the last plan put them, so replans see what a controller would give them.
"""

from __future__ import annotations

import time

import mujoco
import numpy as np

from planning.terrain.bodypath import plan_body_path
from planning.terrain.cadence import CADENCES, CadenceParams, make_request
from planning.terrain.maps import maps_from_scene
from planning.terrain.perception import Perception, PerceptionParams
from planning.terrain.scenes import build_terrain
from planning.terrain.stepqp import StepQP, StepQPParams

_STAND_IN = (
    '<body name="robot" pos="0 0 0.52"><freejoint/>'
    '<geom name="robot_body" type="box" size="0.45 0.13 0.08" mass="32" group="3"/></body>'
)


def _percentiles(ms: list[float]) -> tuple[float, float]:
    a = np.asarray(ms)
    return float(np.percentile(a, 50)), float(np.percentile(a, 99))


def bench_perception(n: int = 60, terrain: str = "stairs", params: PerceptionParams | None = None) -> dict:
    """Gives {"p50_ms", "p99_ms", "bare_solver_p50_ms", "bare_solver_p99_ms", "cpu_p50_ms", "points", "voxels",
    "terrain", "scan", "voxels_integrate", "classify", "maps", "regions", "with_regions"} of n perception updates
    (scan → voxels → maps; bare solver: MuJoCo's ray casting alone in them; cpu: this process's CPU time, which other
    processes on a shared machine do not inflate). Each stage is {"p50_ms", "p99_ms", "cpu_p50_ms"} (the scan's also
    its bare ray casting); the totals (p50_ms, cpu_p50_ms) include the step SDF, which the maps compute when it is
    first read (step_sdf; the default navigator reads it); regions is segment_regions on the maps as the loop runs it
    (no polygon cover); with_regions is what the unified pipeline computes: scan → maps without the step SDF (it never
    reads it) and the regions."""
    from planning.terrain.regions import RegionParams, segment_regions

    scene = build_terrain(terrain)
    model = mujoco.MjModel.from_xml_string(scene.mjcf(_STAND_IN))
    data = mujoco.MjData(model)
    perception = Perception(model, "robot", params)
    points: list[int] = []
    times: list[float] = []
    cpu: list[float] = []
    stages: dict[str, list[float]] = {}
    stages_cpu: dict[str, list[float]] = {}
    region_ms: list[float] = []
    region_cpu: list[float] = []
    unread_ms: list[float] = []  # scan → maps without the step SDF (the regions pipeline never reads it)
    unread_cpu: list[float] = []
    region_params = RegionParams()
    for i in range(n + 3):
        x = 0.02 * i
        data.qpos[0] = x
        data.qpos[2] = 0.52 + float(scene.ground_height(x, 0.0))
        mujoco.mj_kinematics(model, data)
        c0 = time.thread_time()
        t0 = time.perf_counter()
        maps = perception.scan_now(data)
        t1 = time.perf_counter()
        c1 = time.thread_time()
        segment_regions(maps, region_params, cover=False)
        t2 = time.perf_counter()
        c2 = time.thread_time()
        # the step SDF and its gradient (computed on first read; see maps._StepSDFOnUse)
        _ = maps.grad_sdf_step
        t3 = time.perf_counter()
        c3 = time.thread_time()
        if i >= 3:  # the first scans warm caches up
            times.append((t1 - t0 + t3 - t2) * 1e3)
            cpu.append((c1 - c0 + c3 - c2) * 1e3)
            region_ms.append((t2 - t1) * 1e3)
            region_cpu.append((c2 - c1) * 1e3)
            unread_ms.append((t1 - t0) * 1e3)
            unread_cpu.append((c1 - c0) * 1e3)
            for k, v in perception.last_stage_ms.items():
                stages.setdefault(k, []).append(v)
            for k, v in perception.last_stage_cpu_ms.items():
                stages_cpu.setdefault(k, []).append(v)
            stages.setdefault("step_sdf", []).append((t3 - t2) * 1e3)
            stages_cpu.setdefault("step_sdf", []).append((c3 - c2) * 1e3)
            assert perception.last_cloud is not None
            points.append(perception.last_cloud.size)
    p50, p99 = _percentiles(times)
    r50, r99 = _percentiles(stages["raycast"])

    def stage(name: str) -> dict:
        a, b = _percentiles(stages[name])
        return {"p50_ms": a, "p99_ms": b, "cpu_p50_ms": float(np.percentile(stages_cpu[name], 50))}

    whole = [a + b for a, b in zip(unread_ms, region_ms, strict=True)]
    whole_cpu = [a + b for a, b in zip(unread_cpu, region_cpu, strict=True)]
    return {
        "p50_ms": p50, "p99_ms": p99, "bare_solver_p50_ms": r50, "bare_solver_p99_ms": r99,
        "cpu_p50_ms": float(np.percentile(cpu, 50)), "points": int(np.median(points)),
        "voxels": int(perception.voxels.hits.size), "terrain": terrain,
        "scan": {**stage("scan"), "bare_solver_p50_ms": r50, "bare_solver_p99_ms": r99,
                 "bare_solver_cpu_p50_ms": float(np.percentile(stages_cpu["raycast"], 50))},
        "voxels_integrate": stage("voxels"), "classify": stage("classify"), "maps": stage("maps"),
        "step_sdf": stage("step_sdf"),
        "regions": {**dict(zip(("p50_ms", "p99_ms"), _percentiles(region_ms), strict=True)),
                    "cpu_p50_ms": float(np.percentile(region_cpu, 50))},
        "with_regions": {**dict(zip(("p50_ms", "p99_ms"), _percentiles(whole), strict=True)),
                         "cpu_p50_ms": float(np.percentile(whole_cpu, 50))},
    }  # fmt: skip


def bench_step_qp(n: int = 300, terrain: str = "stones", cadence: str = "medium",
                  params: StepQPParams | None = None, start_s_m: float = 0.7, regions: bool = False) -> dict:  # fmt: skip
    """Gives {"p50_ms", "p99_ms", "bare_solver_p50_ms", "bare_solver_p99_ms", "cpu_p50_ms", "cpu_p99_ms" (this
    thread's CPU time, which other processes on a shared machine do not inflate), "footholds", "rounds_mean",
    "hard_softened", "hard_softened_by_family", "in_no_step", "terrain"} of n replans (300 Hz) of the step QP along a
    walk that starts start_s_m along the body path (so the horizon reaches the terrain at once).

    regions: as the unified pipeline runs it (decision.py): each foothold inside a convex polygon of the steppable
    region nearest its nominal place (hard), one solve, the pipeline's QP parameters (unless params); the polygons
    come from a cache as in the loop (their growth is the region stage's cost, not the QP's)."""
    scene = build_terrain(terrain)
    maps = maps_from_scene(scene, center_xy=(2.0, 0.0), half_extent_m=2.5)
    path = plan_body_path(maps, (0.0, 0.0), 0.0, scene.goal_xy)
    cp = CadenceParams()
    cad = next(c for c in CADENCES if c.name == cadence)
    polygon_of = None
    if regions:
        from planning.terrain.decision import DecisionParams, PipelineParams
        from planning.terrain.regions import convex_around, segment_regions

        dp = DecisionParams()
        params = params or PipelineParams().step_qp
        seg = segment_regions(maps, dp.regions, cover=False)
        cache: dict = {}

        def polygon_of(xy: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
            """The polygon of the region with an inset cell nearest xy (within search_m), grown around xy."""
            key = (int(round(float(xy[0]) / seg.resolution_m)), int(round(float(xy[1]) / seg.resolution_m)))
            if key not in cache:
                fx, fy = (np.asarray(xy) - np.asarray(seg.origin_xy)) / seg.resolution_m
                ii, jj = np.nonzero(seg.inset)
                d2 = (ii - fx) ** 2 + (jj - fy) ** 2
                k = int(np.argmin(d2)) if d2.size else -1
                poly = None
                if k >= 0 and np.sqrt(d2[k]) * seg.resolution_m <= dp.search_m:
                    poly = convex_around(seg, int(seg.labels[ii[k], jj[k]]), xy, dp.window_m)
                cache[key] = None if poly is None else (poly.A, poly.b)
            return cache[key]

    qp = StepQP(params)
    K = qp.K
    dt = 1.0 / 300.0
    xy0, _ = path.pose_at(start_s_m)
    stance_xy = np.asarray(cp.feet_body_xy, dtype=np.float64) + xy0  # where each foot last landed
    target_xy = stance_xy.copy()  # where each foot is headed (the last plan's next foothold of its leg)
    n_groups = len(cad.groups)
    total: list[float] = []
    cpu: list[float] = []
    bare: list[float] = []
    rounds = 0
    softened: dict[str, int] = {}
    in_no_step = 0
    for i in range(n):
        t = i * dt
        g_now = int(t // cad.step_period_s)
        phase = t - g_now * cad.step_period_s
        # Feet now: a leg whose group lands next is in swing (after its liftoff), moving straight to its target.
        feet = stance_xy.copy()
        v_feet = np.zeros((4, 2))
        t_to_td = cad.step_period_s - phase
        if t_to_td < cad.swing_s:
            s = 1.0 - t_to_td / cad.swing_s
            for leg in cad.groups[g_now % n_groups]:
                feet[leg] = stance_xy[leg] + s * (target_xy[leg] - stance_xy[leg])
                v_feet[leg] = (target_xy[leg] - stance_xy[leg]) / cad.swing_s
        req = make_request(cad, path, cp, K, feet, v_feet, s_now_m=start_s_m + cad.speed_mps * t, phase_s=phase,
                           first_group=g_now % n_groups)  # fmt: skip
        polys = (
            None if polygon_of is None else [polygon_of(req.p_nominal[k]) for k in range(K)]
        )  # (the cache's)
        c0 = time.thread_time()
        plan = qp.solve(req, maps) if polys is None else qp.solve(req, maps, polys)
        cpu.append((time.thread_time() - c0) * 1e3)
        total.append(plan.solve_ms)
        bare.append(plan.bare_solver_ms / max(plan.rounds, 1))
        rounds += plan.rounds
        for fam in plan.hard_softened:
            softened[fam] = softened.get(fam, 0) + 1
        in_no_step += int(plan.in_no_step.sum())
        for k in range(len(cad.groups[g_now % n_groups])):
            target_xy[plan.legs[k]] = plan.footholds[k, :2]
        if t + dt >= (g_now + 1) * cad.step_period_s:  # the group lands before the next replan
            for leg in cad.groups[g_now % n_groups]:
                stance_xy[leg] = target_xy[leg]
    p50, p99 = _percentiles(total)
    b50, b99 = _percentiles(bare)
    c50, c99 = _percentiles(cpu)
    return {
        "p50_ms": p50, "p99_ms": p99, "bare_solver_p50_ms": b50, "bare_solver_p99_ms": b99,
        "cpu_p50_ms": c50, "cpu_p99_ms": c99, "footholds": K,
        "rounds_mean": rounds / n, "hard_softened": sum(softened.values()), "hard_softened_by_family": softened, "in_no_step": in_no_step, "terrain": terrain,
    }  # fmt: skip


def bench_terrain_crossings(
    terrains: tuple[str, ...] = ("slope", "rough", "clutter", "stairs", "stones", "under-table"),
    goal_xy: tuple[float, float] = (6.0, 0.0),
    duration_s: float = 30.0,
    sensor: bool = True,
    truth_terrains: tuple[str, ...] = ("clutter", "stairs", "stones"),
) -> dict:
    """Gives, per terrain, {"crossed", "fell", "no_step_touchdowns", "no_step_scuffs", "body_collisions",
    "swing_collisions_per_100_steps", "time_s", "rtf", "reached_goal", "failure_reason",
    "step_qp_ms", "perception_ms"} of a terrain-aware walk to goal_xy in MuJoCo (time_s: simulated seconds until
    the body got past the terrain's end, None when it did not), with the depth sensor's maps (sensor=True) or the
    scene's ground truth; plus "<terrain>/truth" for each of truth_terrains on ground-truth maps (perfect perception:
    what the planning and control do on their own). step_qp_ms: the step QP's replans in that walk, {"p50", "p99",
    "bare_solver_p50", "bare_solver_p99", "solves"} (ms; bare: OSQP's own solves, all rounds of a replan);
    perception_ms: its perception stage (scan → voxels → maps → regions), {"p50", "p99", "points"}. Slow: a
    crossing simulates ~15 s each."""
    from planning.sim.run import RunOptions, WalkCommand, run_walk

    runs = [(name, sensor) for name in terrains]
    runs += [(name, False) for name in truth_terrains if sensor]
    out: dict = {}
    for name, use_sensor in runs:
        cmd = WalkCommand(goal=goal_xy, terrain_aware=True, terrain_sensor=use_sensor, stop_at_goal=True)
        r = run_walk(cmd, RunOptions(terrain=name, duration_s=duration_s))
        key = name if use_sensor == sensor else f"{name}/truth"
        nav = r.get("navigator", {})
        perception = r.get("stages", {}).get("perception", {})
        out[key] = {
            "crossed": r["crossed"],
            "fell": r["fell"],
            "no_step_touchdowns": r["no_step_touchdowns"],
            "no_step_scuffs": r["no_step_scuffs"],
            "body_collisions": r["body_collisions"],
            "swing_collisions_per_100_steps": r["swing_collisions_per_100_steps"],
            "time_s": r["time_to_cross_s"],
            "rtf": r["timing"]["rtf"],
            "reached_goal": r["success"],
            "failure_reason": r["failure_reason"],
            "step_qp_ms": {
                "p50": nav.get("step_qp_ms_p50"), "p99": nav.get("step_qp_ms_p99"),
                "bare_solver_p50": nav.get("step_qp_bare_solver_ms_p50"),
                "bare_solver_p99": nav.get("step_qp_bare_solver_ms_p99"), "solves": nav.get("step_qp_solves"),
            },
            "perception_ms": None if not use_sensor else {
                "p50": perception.get("p50_ms"), "p99": perception.get("p99_ms"), "points": nav.get("cloud_points_p50"),
            },
        }  # fmt: skip
    return out
