"""What `footfall bench` runs: every planning stage's time per call (p50, p99, beside the bare solver where there is
one) and the closed loop's real-time factor. A stage whose module is not in this build is absent, not zero.
"""

from __future__ import annotations

import importlib
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from planning.sim.metrics import percentiles

Progress = Callable[[str], None]


def bench_physics_step(n: int = 3000) -> dict[str, Any]:
    """Times one MuJoCo step of the robot standing on flat ground (state read and torque write excluded)."""
    from planning.robot import load_robot
    from planning.sim.world import World
    from planning.terrain.scenes import build_terrain

    robot = load_robot("spot")
    w = World(robot, build_terrain("flat"))
    tau = np.zeros((4, 3))
    times = []
    for _ in range(n):
        tau[:] = 80.0 * (robot.q_nominal - w.data.qpos[w.qpos_idx]) - 2.0 * w.data.qvel[w.dof_idx]
        w.set_torques(tau)
        t0 = time.perf_counter()
        w.step()
        times.append((time.perf_counter() - t0) * 1e3)
    return {**percentiles(times), "timestep_ms": w.dt * 1e3}


def bench_closed_loop_stand(duration_s: float = 5.0) -> dict[str, Any]:
    """Runs the `stand` maneuver headless; returns its real-time factor and per-stage times."""
    from planning.maneuver import find_maneuver, load_maneuver
    from planning.sim.run import RunOptions, run_maneuver

    m = load_maneuver(find_maneuver("stand"))
    rep = run_maneuver(m, RunOptions(duration_s=duration_s))
    return {"rtf": rep["timing"]["rtf"], "success": rep["success"], "stages": rep["stages"]}


def bench_maneuver(name: str) -> dict[str, Any]:
    """Runs a shipped maneuver headless; returns its report's headline numbers."""
    from planning.maneuver import find_maneuver, load_maneuver
    from planning.sim.run import RunOptions, run_maneuver

    rep = run_maneuver(load_maneuver(find_maneuver(name)), RunOptions())
    return {
        "success": rep["success"],
        "rtf": rep["timing"]["rtf"],
        "final_pose_error": rep["final_pose_error"],
        "foot_placement_error_m": rep["foot_placement_error_m"],
        "fallback_ticks": rep["solver"]["fallback_ticks"],
        "solver_tick_ms_p50": rep["solver"]["tick_ms_p50"],
        "airborne_s": rep["airborne_s"],
    }


def bench_walk(vx: float, vy: float, yaw_rate: float, duration_s: float = 8.0, **kw: Any) -> dict[str, Any]:
    """Trots on flat ground at a command; returns tracking (mean, RMS), success and the real-time factor."""
    from planning.sim.run import RunOptions, WalkCommand, run_walk

    rep = run_walk(WalkCommand(vx, vy, yaw_rate, **kw), RunOptions(duration_s=duration_s))
    return {
        "success": rep["success"],
        "mean_velocity": rep["mean_velocity"],
        "velocity_tracking_rms": rep["velocity_tracking_rms"],
        "rtf": rep["timing"]["rtf"],
    }


def stand_survives(impulse_ns: float, duration_s: float = 0.1, direction: str = "lateral") -> bool:
    """Returns whether `stand` survives a push of impulse_ns N·s (over duration_s) without a fall or a step."""
    from planning.maneuver import find_maneuver, load_maneuver
    from planning.sim.run import ManeuverSession, RunOptions
    from planning.sim.world import Push

    f = impulse_ns / duration_s
    force = (0.0, f, 0.0) if direction == "lateral" else (f, 0.0, 0.0)
    m = load_maneuver(find_maneuver("stand"))
    sess = ManeuverSession(m, RunOptions(pushes=[Push(0.5, force, duration_s)], duration_s=3.0))
    rep = sess.run()
    return not rep["fell"] and rep["final_pose_error"]["position_m"] < 0.15


def max_stand_impulse(lo: float = 10.0, hi: float = 60.0, tol: float = 1.0) -> float:
    """Returns the largest lateral impulse (N·s, 0.1 s push) that `stand` survives, by bisection."""
    if not stand_survives(lo):
        return 0.0
    while hi - lo > tol:
        mid = 0.5 * (lo + hi)
        if stand_survives(mid):
            lo = mid
        else:
            hi = mid
    return round(lo, 1)


def walk_survives_push(impulse_ns: float, capture_point_selection: bool = True) -> bool:
    """Returns whether a 0.5 m/s trot survives a lateral push of impulse_ns N·s (0.1 s) at t = 2 s."""
    from planning.sim.run import RunOptions, WalkCommand, run_walk
    from planning.sim.world import Push

    push = [Push(2.0, (0.0, impulse_ns / 0.1, 0.0), 0.1)]
    rep = run_walk(
        WalkCommand(vx=0.5, capture_point_selection=capture_point_selection),
        RunOptions(duration_s=5.0, pushes=push),
    )
    return bool(rep["success"])


def largest(survives: Callable[[float], bool], lo: float, hi: float, tol: float) -> float:
    """Returns the largest x in [lo, hi] with survives(x), by bisection (0 when lo already fails)."""
    if not survives(lo):
        return 0.0
    while hi - lo > tol:
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if survives(mid) else (lo, mid)
    return round(lo, 2)


def fastest_trot(speeds: tuple[float, ...] = (1.0, 1.2, 1.4, 1.6, 1.8, 2.0)) -> float:
    """Returns the highest forward command (m/s) trotted 6 s on flat ground without a fall (stops at the first)."""
    from planning.sim.run import RunOptions, WalkCommand, run_walk

    best = 0.0
    for v in speeds:
        rep = run_walk(WalkCommand(vx=v), RunOptions(duration_s=6.0))
        if rep["fell"]:
            break
        best = v
    return best


def _optional(module: str, fn: str) -> Callable[..., Any] | None:
    """Returns a bench function of a stage module, or None when the stage is not in this build."""
    try:
        return getattr(importlib.import_module(module), fn)  # type: ignore[no-any-return]
    except (ImportError, AttributeError):
        return None


def run_benchmarks(
    quick: bool = False, only: list[str] | None = None, progress: Progress | None = None
) -> dict[str, Any]:
    """Returns {"stages": {...}, "closed_loop": {...}, "robustness": {...}} as in CONTRACT.md."""
    say = progress or (lambda _m: None)
    stages: dict[str, Any] = {}
    n = 300 if quick else 2000

    def want(name: str) -> bool:
        return only is None or name in only

    if want("physics_step"):
        say("bench: physics_step")
        stages["physics_step"] = bench_physics_step(n)
    if want("stance_handler"):
        say("bench: stance_handler")
        from planning.bench_stance import bench_force_distribution, bench_stance_handler

        stages["stance_handler"] = bench_stance_handler(
            n=n // 4
        )  # the QP on every tick, beside the bare solve
        stages["stance_handler_in_loop"] = bench_stance_handler(n=n // 4, skip_feasible=True)
        stages["force_distribution"] = bench_force_distribution(n=n // 4)
    optional: list[tuple[str, str, str, dict[str, Any]]] = [
        ("swing_select", "planning.swing.bench", "bench_swing_select", {"calls": 100 if quick else 300}),
        ("step_selection_25", "planning.steps.bench", "bench_step_selection", {"n_candidates": 25}),
        ("step_selection_100", "planning.steps.bench", "bench_step_selection", {"n_candidates": 100}),
        ("step_qp", "planning.terrain.bench", "bench_step_qp", {"n": 100 if quick else 300}),
        (
            "step_qp_regions",
            "planning.terrain.bench",
            "bench_step_qp",
            {"n": 100 if quick else 300, "regions": True},
        ),
        (
            "centroidal_tick",
            "planning.centroidal.bench",
            "bench_centroidal_tick",
            {"n_ticks": 60 if quick else 300},
        ),
        ("perception", "planning.terrain.bench", "bench_perception", {"n": 10 if quick else 60}),
    ]
    for name, module, fn_name, kwargs in optional:
        fn = _optional(module, fn_name)
        if fn is not None and want(name):
            say(f"bench: {name}")
            stages[name] = fn(**kwargs)
    out: dict[str, Any] = {"stages": stages, "closed_loop": {}, "robustness": {}}
    if want("closed_loop"):
        say("bench: closed loop (stand, a maneuver, a trot)")
        stand = bench_closed_loop_stand(2.0 if quick else 5.0)
        out["closed_loop"]["stand_rtf"] = stand["rtf"]
        out["closed_loop"]["maneuver_rtf"] = bench_maneuver("trot-in-place")["rtf"]
        out["closed_loop"]["trot_flat_rtf"] = bench_walk(0.5, 0.0, 0.0, 3.0 if quick else 8.0)["rtf"]
    if want("tracking"):
        say("bench: velocity tracking on flat (trot)")
        d = 4.0 if quick else 8.0
        out["tracking"] = {
            "forward_0.5": bench_walk(0.5, 0.0, 0.0, d),
            "forward_1.0": bench_walk(1.0, 0.0, 0.0, d),
            "sideways_0.4": bench_walk(0.0, 0.4, 0.0, d),
            "turning_1.0": bench_walk(0.0, 0.0, 1.0, d),
        }
    if want("robustness") and not quick:
        say("bench: largest lateral impulse survived standing (bisection)")
        out["robustness"]["stand_max_lateral_impulse_ns"] = max_stand_impulse()
        say("bench: largest lateral impulse survived trotting at 0.5 m/s, capture-point selection on and off")
        out["robustness"]["trot_max_lateral_impulse_ns"] = largest(walk_survives_push, 20.0, 80.0, 2.0)
        out["robustness"]["trot_max_lateral_impulse_reference_only_ns"] = largest(
            lambda x: walk_survives_push(x, False), 20.0, 80.0, 2.0
        )
        say("bench: highest forward speed trotted without a fall")
        out["robustness"]["fastest_trot_mps"] = fastest_trot()
    if want("speed") and not quick:
        from benchmarks.speed import bench_speed

        out["speed"] = bench_speed(progress=say)
    # the same ramps steered by the centroidal solver instead of the balance QP (only when named)
    if only is not None and "speed_centroidal" in only and not quick:
        from benchmarks.speed import bench_speed

        out["speed_centroidal"] = bench_speed(centroidal=True, progress=say)
    if want("maneuvers") and not quick:
        say("bench: every shipped maneuver in MuJoCo")
        from planning.maneuver import list_library

        out["maneuvers"] = {e.name: bench_maneuver(e.name) for e in list_library() if not e.problems}
    if want("terrain") and not quick:
        say(
            "bench: terrain crossings toward (6, 0) with the depth sensor, and some on ground-truth maps (slow)"
        )
        from planning.terrain.bench import bench_terrain_crossings

        out["terrain"] = bench_terrain_crossings()
    # The variant stages are shipped sweep specs (sweeps/*-variants.yaml) run through `footfall sweep`'s code on
    # local worker processes; results are kept in sweep-results/NAME, so an interrupted bench goes on.
    # clutter_variants (and _shifted) and stones_variants run only when asked for by name: 24, 24 and 12 crossings
    for stage, by_name in (("stairs_variants", False), ("clutter_variants", True),
                           ("clutter_variants_shifted", True), ("stones_variants", True)):  # fmt: skip
        if quick or not (want(stage) if not by_name else only is not None and stage in only):
            continue
        say(f"bench: {stage} (sweeps/{stage.replace('_', '-')}.yaml; slow)")
        out[stage] = sweep_variants(stage.replace("_", "-"))
    return out


def sweep_variants(name: str, out_dir: str | None = None) -> dict[str, Any]:
    """Runs the shipped sweep `name` on local workers; gives {"runs", "crossed" (no fall, past the terrain),
    "success_rate", "by_variant": {label: {"crossed", "time_s", "no_step_touchdowns", "no_step_scuffs",
    "failure_reason"}}}, the labels naming the run and the axis values."""
    from pathlib import Path

    from planning.sweep import ResultStore, expand, load_spec, make_backend, run_sweep

    spec = load_spec(name)
    out = Path(out_dir or Path("sweep-results") / spec.name)
    summary = run_sweep(spec, make_backend("local"), out)
    store = ResultStore(out)
    by: dict[str, Any] = {}
    for case in expand(spec):
        rec = store.get(case["key"]) or {}
        r = rec.get("report") or {}
        label = " ".join(f"{v}" if a == "run" else f"{a}={v}" for a, v in case["axes"].items())
        by[label] = {
            "crossed": bool(r.get("crossed")),
            "time_s": r.get("time_to_cross_s"),
            "no_step_touchdowns": r.get("no_step_touchdowns"),
            "no_step_scuffs": r.get("no_step_scuffs"),
            "failure_reason": r.get("failure_reason") or rec.get("error"),
        }
    return {
        "runs": len(by),
        "crossed": sum(v["crossed"] for v in by.values()),
        "success_rate": summary["overall"]["success_rate"],
        "by_variant": by,
    }


def format_table(result: dict[str, Any]) -> str:
    """Returns the benchmark result as a plain-text table."""
    lines = [f"{'stage':24s} {'p50 ms':>9s} {'p99 ms':>9s} {'bare solver p50 ms':>19s}  notes"]
    for name, r in result["stages"].items():
        if isinstance(r, dict) and "p50_ms" in r:
            lines.append(_row(name, r))
        for sub, rr in (r or {}).items():  # cases inside a stage (e.g. swing selection: flat, box, crossing)
            if isinstance(rr, dict) and "p50_ms" in rr:
                lines.append(_row(f"{name}.{sub}", rr))
    for k, v in result.get("closed_loop", {}).items():
        if not isinstance(v, dict):
            lines.append(f"{'closed_loop.' + k:24s} {v}")
    for k, v in result.get("tracking", {}).items():
        m, r = v["mean_velocity"], v["velocity_tracking_rms"]
        lines.append(
            f"{'tracking.' + k:24s} mean vx {m['vx']:.3f} vy {m['vy']:.3f} wz {m['yaw_rate']:.3f}; "
            f"RMS {r['vx']} {r['vy']} {r['yaw_rate']}; rtf {v['rtf']}"
        )
    for k, v in result.get("robustness", {}).items():
        lines.append(f"{'robustness.' + k:24s} {v}")
    for k, v in result.get("maneuvers", {}).items():
        pose, feet = v["final_pose_error"], v["foot_placement_error_m"]
        lines.append(
            f"{'maneuver.' + k:24s} success {v['success']}; final pose error {pose.get('position_m')} m "
            f"{pose.get('yaw_rad')} rad; foot placement error median {feet.get('median')} max {feet.get('max')} m; "
            f"fallback ticks {v['fallback_ticks']}; rtf {v['rtf']}"
        )
    for k, v in result.get("terrain", {}).items():
        how = "crossed" if v["crossed"] else "not crossed"
        how += f" in {v['time_s']} s" if v["time_s"] is not None else ""
        lines.append(
            f"{'terrain.' + k:24s} {how}; fell {v['fell']}; no-step touchdowns {v['no_step_touchdowns']} "
            f"(scuffs {v.get('no_step_scuffs', 0)}); "
            f"body collisions {v['body_collisions']}; swing collisions per 100 steps "
            f"{v['swing_collisions_per_100_steps']}; rtf {v['rtf']}"
            + (f"; {v['failure_reason']}" if v["failure_reason"] else "")
        )
        qp, pe = v.get("step_qp_ms") or {}, v.get("perception_ms") or {}
        if qp.get("p50") is not None:
            lines.append(
                f"{'':24s} step QP in the loop: {qp['solves']} replans, p50 {qp['p50']} ms p99 {qp['p99']} ms "
                f"(bare OSQP p50 {qp['bare_solver_p50']} p99 {qp['bare_solver_p99']} ms)"
            )
        if pe.get("p50") is not None:
            lines.append(
                f"{'':24s} perception in the loop: p50 {pe['p50']} ms p99 {pe['p99']} ms, {pe['points']} points a scan"
            )
    for name in ("speed", "speed_centroidal"):
        if result.get(name):
            from benchmarks.speed import format_speed_table

            lines.append(f"{name} (top speed held: ramped until a fall or > 10 % tracking error)")
            lines.append(format_speed_table(result[name]))
    for name in ("stairs_variants", "clutter_variants", "clutter_variants_shifted", "stones_variants"):
        sv = result.get(name)
        if not sv:
            continue
        lines.append(f"{name:24s} crossed {sv['crossed']} of {sv['runs']}")
        for k, v in sv["by_variant"].items():
            how = f"crossed in {v['time_s']} s" if v["crossed"] else (v["failure_reason"] or "not crossed")
            if "no_step_touchdowns" in v:
                how += f"; no-step touchdowns {v['no_step_touchdowns']} (scuffs {v['no_step_scuffs']})"
            lines.append(f"{name + '.' + k:24s} {how}")
    return "\n".join(lines)


def _row(name: str, r: dict[str, Any]) -> str:
    bare = r.get("bare_solver_p50_ms")
    notes = ", ".join(
        f"{k}={v}"
        for k, v in r.items()
        if k not in ("p50_ms", "p99_ms", "bare_solver_p50_ms") and not isinstance(v, (dict, list))
    )
    bare_s = f"{bare:19.4f}" if isinstance(bare, (int, float)) else f"{'':19s}"
    return f"{name:24s} {r['p50_ms']:9.4f} {r['p99_ms']:9.4f} {bare_s}  {notes}"
