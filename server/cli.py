"""The `footfall` command line: run, walk, validate, terrains, bench, serve.

Exit codes: 0 success, 1 the run failed (fell, missed an event, ended off its final pose), 2 invalid input.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path
from typing import Any

EXIT_OK, EXIT_FAILED, EXIT_INVALID = 0, 1, 2

DESCRIPTION = """\
footfall: author legged-robot maneuvers and run them through a planning and control stack on a MuJoCo
simulation of a Spot-class quadruped.

examples:
  footfall terrains                                   list the terrains
  footfall validate bow                               check a library maneuver (or a path to a .yaml file)
  footfall run stand --push 1.0:0,150,0:0.1 --report out.json
                                                      stand, take a 15 N·s sideways push, write the run report
  footfall run maneuvers/crouch.yaml --realtime       run a file, paced to the wall clock
  footfall walk --vx 0.5 --duration 10                trot forward at 0.5 m/s
  footfall walk --goal 3,1 --push 4:0,200,0:0.1       walk to a goal, taking a push on the way
  footfall bench --json bench.json                    time every stage and the closed loop
  footfall sweep sweeps/push-stand.yaml               success rate of `stand` over a grid of pushes
  footfall serve                                      REST API on :8000 and the 3D studio on :8080
"""


class UsageError(Exception):
    """Invalid input from the command line: printed as one line, exit code 2."""


def _err(msg: str) -> None:
    print(f"footfall: error: {msg}", file=sys.stderr)


class _Progress:
    """A single updating progress line on a terminal (silent when stderr is not a terminal)."""

    def __init__(self, label: str) -> None:
        self.label = label
        self.active = sys.stderr.isatty()
        self.shown = False

    def __call__(self, t: float, duration: float, rtf: float) -> None:
        if not self.active:
            return
        self.shown = True
        sys.stderr.write(f"\r{self.label}: t = {t:6.2f} / {duration:.2f} s   real-time factor {rtf:5.2f}×   ")
        sys.stderr.flush()

    def done(self) -> None:
        if self.shown:
            sys.stderr.write("\n")


def _parse_pushes(specs: list[str] | None) -> list[Any]:
    from planning.sim.world import PushSpecError, parse_push

    out = []
    for spec in specs or []:
        try:
            out.append(parse_push(spec))
        except PushSpecError as e:
            raise UsageError(str(e)) from None
    return out


def _check_terrain(text: str, seed: int) -> str:
    """Builds the terrain once (a name, a name with parameters, or a file) so that a bad one is a usage error;
    gives the scene's name."""
    from planning.terrain.spec import TerrainSpecError, load_terrain

    if not 0 <= seed < 2**32:
        raise UsageError(f"--seed {seed}: must be within 0 to 2^32 - 1")
    try:
        return str(load_terrain(text, seed).name)
    except TerrainSpecError as e:
        raise UsageError(f"--terrain {text!r}: {e}") from None


def _load(name_or_path: str) -> Any:
    from planning.maneuver import ManeuverError, find_maneuver, load_maneuver

    try:
        return load_maneuver(find_maneuver(name_or_path))
    except ManeuverError as e:
        if len(e.problems) == 1:
            head = f"{e.source}: " if e.source else ""
            raise UsageError(f"{head}{e.problems[0].located()}") from None
        raise UsageError(str(e)) from None


def _write_report(report: dict[str, Any], path: str | None) -> None:
    if path:
        try:
            Path(path).write_text(json.dumps(report, indent=2) + "\n")
        except OSError as e:
            raise UsageError(f"--report {path}: cannot write: {e.strerror}") from None


def _summary(report: dict[str, Any]) -> str:
    verdict = "success" if report["success"] else f"FAILED ({report['failure_reason']})"
    fc = report.get("fall_contact")
    if fc and fc.get("touched"):  # what the part touched, and where
        x, y, z = fc["point_m"]
        verdict += f" on {fc['touched']} at ({x:.2f}, {y:.2f}, {z:.2f}) m"
    fpe = report["final_pose_error"]
    line = (
        f"{report.get('maneuver') or report.get('mode')} on {report['terrain']}: {verdict}; "
        f"{report['duration_s']:.2f} s simulated in {report['timing']['wall_s']:.2f} s "
        f"({report['timing']['rtf']:.2f}× real time)"
    )
    if fpe.get("position_m") is not None:
        line += f"; final pose error {fpe['position_m']:.3f} m"
        if fpe.get("yaw_rad") is not None:
            line += f", {fpe['yaw_rad']:.3f} rad"
    mv = report.get("mean_velocity")
    if mv:
        rms = report["velocity_tracking_rms"]
        line += (
            f"; mean velocity vx {mv['vx']:.3f} m/s, vy {mv['vy']:.3f} m/s, yaw rate {mv['yaw_rate']:.3f} rad/s"
            f" (RMS error {rms['vx']}, {rms['vy']}, {rms['yaw_rate']})"
        )
        if report.get("flight_fraction") is not None:  # time with no foot on the ground, after settle_s
            line += f"; in flight {100 * report['flight_fraction']:.1f} % of the time"
    if "crossed" in report:
        line += (
            f"; crossed {report['crossed']} (t={report['time_to_cross_s']} s), no-step touchdowns "
            f"{report['no_step_touchdowns']} (scuffs {report.get('no_step_scuffs', 0)}), "
            f"body collisions {report['body_collisions']}, swing collisions "
            f"{report['swing_collisions_per_100_steps']} per 100 steps"
        )
        if report.get("near_misses") is not None:
            least = report.get("link_clearance_min_m")
            from planning.terrain.crossing import NEAR_MISS_M

            line += (
                f", near misses {report['near_misses']} (a leg or the body within {100 * NEAR_MISS_M:g} cm"
            )
            line += (
                " of the terrain)" if least is None else f" of the terrain; closest {1000 * least:.0f} mm)"
            )
    nav = report.get("navigator") or {}
    perception = (report.get("stages") or {}).get("perception") or {}
    if nav.get("cloud_points_p50") and perception.get("p50_ms") is not None:
        line += f"; perception p50 {perception['p50_ms']:.1f} ms ({nav['cloud_points_p50']} points a scan)"
    if nav.get("step_qp_ms_p50") is not None:
        line += (
            f"; step QP {nav['step_qp_solves']} replans, p50 {nav['step_qp_ms_p50']:.2f} ms "
            f"(bare OSQP {nav['step_qp_bare_solver_ms_p50']:.2f} ms)"
        )
    return line


# ---- commands ------------------------------------------------------------------------------------------------
def cmd_run(a: argparse.Namespace) -> int:
    from planning.maneuver import check_maneuver
    from planning.sim.run import RunOptions, run_maneuver

    _check_terrain(a.terrain, a.seed)
    pushes = _parse_pushes(a.push)
    if a.duration is not None and not (0 < a.duration <= 600):
        raise UsageError(f"--duration {a.duration}: must be in (0, 600] s")
    robot = _robot(a.robot)
    maneuver = _load(a.maneuver)
    result = check_maneuver(maneuver, robot)
    if not result.ok:
        raise UsageError(
            f"maneuver {maneuver.name} has failures:\n" + "\n".join(f"  {p}" for p in result.failures)
        )
    progress = _Progress(maneuver.name)
    opts = RunOptions(
        terrain=a.terrain,
        pushes=pushes,
        duration_s=a.duration,
        realtime=a.realtime,
        robot=a.robot,
        seed=a.seed,
    )
    report = run_maneuver(maneuver, opts, progress=progress)
    progress.done()
    _write_report(report, a.report)
    print(_summary(report))
    return EXIT_OK if report["success"] else EXIT_FAILED


def cmd_robot_check(a: argparse.Namespace) -> int:
    from planning.robot.check import check_robot

    ok, text = check_robot(a.robot)
    print(text)
    return EXIT_OK if ok else EXIT_INVALID


def _robot(name: str) -> Any:
    from planning.robot import RobotDescriptionError, load_robot

    try:
        return load_robot(name)
    except RobotDescriptionError as e:
        raise UsageError(str(e)) from None


def _parse_goal(text: str | None) -> tuple[float, float] | None:
    if text is None:
        return None
    parts = text.split(",")
    try:
        x, y = (float(v) for v in parts)
    except ValueError:
        raise UsageError(f"--goal {text!r}: expected X,Y in meters, e.g. 6,0") from None
    if not all(map(lambda v: abs(v) < 1e4, (x, y))):
        raise UsageError(f"--goal {text!r}: coordinates must be finite and within 10 km")
    return (x, y)


def cmd_walk(a: argparse.Namespace) -> int:
    from planning.sim.run import RunOptions, WalkCommand, WalkSession
    from planning.steps.gait import GAIT_NAMES

    scene = _check_terrain(a.terrain, a.seed)
    pushes = _parse_pushes(a.push)
    goal = _parse_goal(a.goal)
    if a.gait not in GAIT_NAMES or a.gait == "stand":
        raise UsageError(
            f"--gait {a.gait!r}: unknown gait (one of: {', '.join(g for g in GAIT_NAMES if g != 'stand')})"
        )
    for name in ("vx", "vy", "yaw_rate"):
        v = getattr(a, name)
        if not (abs(v) <= 5.0):
            raise UsageError(f"--{name.replace('_', '-')} {v}: must be within ±5")
    if a.duration is not None and not (0 < a.duration <= 600):
        raise UsageError(f"--duration {a.duration}: must be in (0, 600] s")
    if a.maps not in ("sensor", "truth", "off"):
        raise UsageError(f"--maps {a.maps!r}: one of sensor, truth, off")
    if a.terrain_pipeline is not None:
        from planning.terrain.spec import check_terrain_pipeline

        why = check_terrain_pipeline(a.terrain_pipeline)
        if why is not None:
            raise UsageError(f"--terrain-pipeline {why}")
    if a.speed is not None:
        from planning.sim.run import check_terrain_speed

        if scene == "flat":
            raise UsageError(
                "--speed: only on a terrain (on flat ground --vx and the gait's limits set the speed)"
            )
        why = check_terrain_speed(a.speed, scene)
        if why is not None:
            raise UsageError(f"--speed {why}")
    from planning.sim.trace import trace_args_error

    why = trace_args_error(a.trace, a.trace_every)
    if why is not None:
        raise UsageError(why)
    if getattr(a, "descend_backward", False) and (goal is None or scene == "flat"):
        raise UsageError("--descend-backward: only walking to a --goal on a terrain")
    if getattr(a, "descend_backward", False) and getattr(a, "descend_forward", False):
        raise UsageError("--descend-forward: not with --descend-backward (one way down)")
    _robot(a.robot)
    cmd = WalkCommand(
        a.vx,
        a.vy,
        a.yaw_rate,
        a.gait,
        goal,
        a.weights,
        not a.reference_only,
        centroidal=a.solver == "centroidal",
        terrain_aware=False if a.maps == "off" else None,
        terrain_sensor=a.maps == "sensor",
        terrain_speed_mps=a.speed,
        descend_backward=not getattr(a, "descend_forward", False),
    )
    opts = RunOptions(
        terrain=a.terrain,
        pushes=pushes,
        duration_s=a.duration,
        realtime=a.realtime,
        robot=a.robot,
        seed=a.seed,
    )
    if scene != "flat" and a.maps != "off" and goal is None:
        from planning.sim.run import TERRAIN_SPEED_DEFAULT_MPS, terrain_speed_limit

        cap = TERRAIN_SPEED_DEFAULT_MPS if a.speed is None else a.speed
        if math.hypot(a.vx, a.vy) > cap + 1e-9:
            more = (
                "" if cap >= terrain_speed_limit(scene) else f"; --speed up to {terrain_speed_limit(scene)}"
            )
            print(f"note: on {scene} the terrain speed caps --vx/--vy at {cap} m/s{more}", file=sys.stderr)
    progress = _Progress("walk")
    from planning.sim.trace import DEFAULT_TRACE_EVERY_S

    every = DEFAULT_TRACE_EVERY_S if a.trace_every is None else a.trace_every
    session = WalkSession(cmd, opts, trace_every_s=None if a.trace is None else every)
    report = session.run(progress)
    progress.done()
    _write_report(report, a.report)
    if a.trace is not None and (trace := session.trace) is not None:
        out = trace.write_csv(a.trace)
        cut = (
            f" ({trace.dropped // 4} later samples dropped past {len(trace.rows)} rows)"
            if trace.dropped
            else ""
        )
        print(f"trace: {len(trace.rows)} rows to {out}{cut}", file=sys.stderr)
    print(_summary(report))
    return EXIT_OK if report["success"] else EXIT_FAILED


def _lines_of(path: Path) -> dict[str, int] | None:
    from planning.maneuver import ManeuverError
    from planning.maneuver.load import read_source

    try:
        return read_source(path)[1]
    except ManeuverError:
        return None


def cmd_validate(a: argparse.Namespace) -> int:
    from planning.maneuver import ManeuverError, check_maneuver, find_maneuver

    try:
        path = find_maneuver(a.maneuver)
    except ManeuverError as e:
        raise UsageError(str(e.problems[0])) from None
    # the file itself, not a parsed maneuver: a shape problem does not hide the rules' findings on the rest
    robot = _robot(a.robot)
    result = check_maneuver(path, robot, dry_solve=not a.no_solve)
    if result.ok and not a.no_physics:
        from planning.maneuver import load_maneuver
        from planning.maneuver.physics import run_physics, with_physics
        from planning.sim.run import RunOptions

        print("physics check: simulating the maneuver headless ...", file=sys.stderr)
        report = run_physics(load_maneuver(path), RunOptions(robot=a.robot), robot_model=robot)
        result = with_physics(result, report, _lines_of(path))
        ph = result.physics or {}
        print(f"physics check: {'succeeded' if ph.get('success') else 'FAILED'}; {ph.get('simulated_s')} s "
              f"simulated in {ph.get('wall_s')} s", file=sys.stderr)  # fmt: skip
    name = result.maneuver.name if result.maneuver is not None else path.stem
    for p in result.failures:
        print(f"failure: {p.located() if hasattr(p, 'located') else p}")
    for p in result.warnings:
        print(f"warning: {p.located() if hasattr(p, 'located') else p}")
    n_f, n_w = len(result.failures), len(result.warnings)
    print(f"{name}: {'valid' if result.ok else 'invalid'} ({n_f} failures, {n_w} warnings)")
    return EXIT_OK if result.ok else EXIT_INVALID


def cmd_terrains(a: argparse.Namespace) -> int:
    from planning.terrain.scenes import TERRAIN_NAMES, build_terrain, param_info

    for name in TERRAIN_NAMES:
        print(f"{name:12s} {build_terrain(name).description}")
        if a.params:
            for info in param_info(name):
                print(f"{'':14s}{info.describe()}")
    return EXIT_OK


_TERRAIN_HELP = (
    "a terrain name (footfall terrains lists them), a name with parameters (stairs:riser_m=0.18,tread_m=0.28; "
    "footfall terrains --params lists them), or a file: an MJCF scene (.xml) or a heightmap (.npy or .png, "
    "e.g. heightmap.npy:cell_m=0.05)"
)


def cmd_bench(a: argparse.Namespace) -> int:
    from benchmarks.run import run_benchmarks

    result = run_benchmarks(quick=a.quick, only=a.only, progress=lambda msg: print(msg, file=sys.stderr))
    if a.json:
        Path(a.json).write_text(json.dumps(result, indent=2) + "\n")
    from benchmarks.run import format_table

    print(format_table(result))
    return EXIT_OK


def cmd_serve(a: argparse.Namespace) -> int:
    try:
        from server.app import serve
    except ImportError as e:  # the service lands with its issue
        raise UsageError(f"serve is not available in this build: {e}") from None
    overrides: dict[str, Any] = {} if a.data_dir is None else {"data_dir": Path(a.data_dir).expanduser()}
    if a.robot is not None:
        _robot(a.robot)  # a robot that does not load is a usage error now, not a failing service later
        p = Path(a.robot).expanduser()
        overrides["robot"] = str(p.resolve()) if p.suffix.lower() in (".xml", ".yaml", ".yml") else a.robot
    if a.address and a.backend != "ray":
        raise UsageError("--address is for --backend ray")
    overrides.update(backend=a.backend, ray_address=a.address)
    serve(host=a.host, port=a.port, viewer_port=a.viewer_port, **overrides)
    return EXIT_OK


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="footfall", description=DESCRIPTION, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    sub = p.add_subparsers(dest="command", metavar="COMMAND")

    r = sub.add_parser("run", help="simulate a maneuver in MuJoCo (headless unless --realtime)")
    r.add_argument("maneuver", metavar="MANEUVER", help="a library name (footfall run stand) or a .yaml path")
    r.add_argument("--terrain", default="flat", metavar="TERRAIN", help=_TERRAIN_HELP)
    r.add_argument("--seed", type=int, default=0, help="the terrain scene's random layout (default 0)")
    r.add_argument(
        "--push",
        action="append",
        metavar="SPEC",
        help="T:FX,FY,FZ[:DURATION]: at T s a force in N on the body's center of mass for DURATION s "
        "(default 0.1); repeatable",
    )
    r.add_argument("--duration", type=float, metavar="S", help="simulated seconds (default: the maneuver's)")
    r.add_argument("--report", metavar="FILE", help="write the JSON run report here")
    r.add_argument("--realtime", action="store_true", help="pace the simulation to the wall clock")
    r.add_argument(
        "--robot",
        default="spot",
        help="robot: spot (default), go1, an MJCF file (PATH.xml) or a .yaml description",
    )
    r.set_defaults(fn=cmd_run)

    w = sub.add_parser("walk", help="steering mode: velocity commands, or a goal to reach through terrain")
    w.add_argument("--vx", type=float, default=0.0, metavar="V", help="forward speed, m/s")
    w.add_argument("--vy", type=float, default=0.0, metavar="V", help="sideways speed (left), m/s")
    w.add_argument("--yaw-rate", type=float, default=0.0, metavar="W", help="turning rate (left), rad/s")
    w.add_argument(
        "--gait", default="trot", metavar="NAME", help="trot (default), walk, pace, bound or gallop"
    )
    w.add_argument("--goal", metavar="X,Y", help="walk to this point (m, start frame) instead of a velocity")
    w.add_argument(
        "--weights",
        default="default",
        metavar="PRESET",
        help="step selection weights: default, precise_footing or stable_body",
    )
    w.add_argument(
        "--reference-only",
        action="store_true",
        help="walk the reference step path only (capture-point selection off), for comparison",
    )
    w.add_argument(
        "--solver",
        choices=("balance", "centroidal"),
        default="balance",
        help="what turns the step plan into contact forces: the balance QP (default) or the centroidal solver",
    )
    w.add_argument(
        "--duration", type=float, metavar="S", help="simulated seconds (default 10, 30 with --goal)"
    )
    w.add_argument("--terrain", default="flat", metavar="TERRAIN", help=_TERRAIN_HELP)
    w.add_argument("--seed", type=int, default=0, help="the terrain scene's random layout (default 0)")
    w.add_argument(
        "--speed",
        type=float,
        metavar="V",
        help="on a terrain: the speed to the goal and the cap on --vx/--vy, m/s (default 0.5; up to 1.0 on slope "
        "and rough, 0.5 elsewhere; the terrain's own caps still apply)",
    )
    w.add_argument(
        "--descend-backward",
        action="store_true",
        help="on a terrain, to a goal: go down descents (a fall of 0.2 of the leg's length or more) backward where "
        "there is room to turn round (the default; README, Terrain)",
    )
    w.add_argument(
        "--descend-forward",
        action="store_true",
        help="on a terrain, to a goal: go down descents facing the way the walk goes (no turn round)",
    )
    w.add_argument(
        "--maps",
        default="sensor",
        metavar="SOURCE",
        help="on a terrain: sensor (the simulated depth sensor, default), truth (the scene's own maps: perfect "
        "perception) or off (walk blind)",
    )
    w.add_argument(
        "--terrain-pipeline",
        default=None,
        metavar="NAME",
        help="removed: there is one terrain pipeline (steppable regions, footholds by the step QP inside them; "
        "the README's Terrain section); 'regions' is still accepted",
    )
    w.add_argument("--push", action="append", metavar="SPEC", help="T:FX,FY,FZ[:DURATION], repeatable")
    w.add_argument("--report", metavar="FILE", help="write the JSON run report here")
    w.add_argument(
        "--trace",
        metavar="FILE",
        help="write a per-leg trace here (CSV: body pose, phase, foot, swing plan, terrain foothold; README, "
        "Tracing a walk)",
    )
    w.add_argument(
        "--trace-every",
        type=float,
        metavar="S",
        help="the trace's sampling period, simulated seconds (default 0.01, at least 0.002)",
    )
    w.add_argument("--realtime", action="store_true", help="pace the simulation to the wall clock")
    w.add_argument("--robot", default="spot", help="robot: spot (default), go1 or an MJCF file (PATH.xml)")
    w.set_defaults(fn=cmd_walk)

    v = sub.add_parser(
        "validate",
        help="check a maneuver: rules, dry solve, and a headless physics check (warnings, failures)",
    )
    v.add_argument("maneuver", metavar="MANEUVER", help="a library name or a .yaml path")
    v.add_argument("--robot", default="spot", help="robot to check reach against (a name or PATH.xml)")
    v.add_argument(
        "--no-solve",
        action="store_true",
        help="skip the dry solve (the centroidal solver run along the plan)",
    )
    v.add_argument(
        "--no-physics",
        action="store_true",
        help="skip the physics check (the whole maneuver simulated headless in MuJoCo, measured per event)",
    )
    v.set_defaults(fn=cmd_validate)

    rb = sub.add_parser("robot", help="robots: check what footfall detects in an MJCF")
    rbs = rb.add_subparsers(dest="robot_cmd", metavar="COMMAND", required=True)
    rc = rbs.add_parser(
        "check", help="print what was detected, compare the kinematics with MuJoCo, list problems"
    )
    rc.add_argument(
        "robot", metavar="PATH", help="an MJCF file (.xml), a description (.yaml) or a shipped name"
    )
    rc.set_defaults(fn=cmd_robot_check)

    t = sub.add_parser("terrains", help="list the terrain names")
    t.add_argument("--params", action="store_true", help="list each terrain's parameters with their ranges")
    t.set_defaults(fn=cmd_terrains)

    b = sub.add_parser("bench", help="time every planning stage and the closed loop (p50 / p99)")
    b.add_argument("--json", metavar="FILE", help="also write the results as JSON")
    b.add_argument("--quick", action="store_true", help="fewer samples (for a smoke test)")
    b.add_argument(
        "--only",
        action="append",
        metavar="STAGE",
        help="run only this stage (repeatable): physics_step, stance_handler, swing_select, step_selection_25, "
        "step_selection_100, step_qp, centroidal_tick, perception, closed_loop, tracking, robustness, speed (top "
        "speed per gait and direction: the command ramped until a fall or > 10 %% tracking error), "
        "speed_centroidal (the same steered by the centroidal solver; only when named), maneuvers "
        "(every shipped maneuver), terrain (every terrain crossing), stairs_variants (the stairs with the goal "
        "moved sideways by −8 to +8 cm, every centimetre, with the sensor and on ground-truth maps), clutter_variants "
        "(twelve clutter layouts with the sensor, twelve on ground-truth maps; only when named), "
        "clutter_variants_shifted (the same with the goal moved 1 mm sideways: which outcomes are chance; only "
        "when named), stones_variants "
        "(eight stepping-stone layouts with the sensor, four on ground-truth maps; only when named)",
    )
    b.set_defaults(fn=cmd_bench)

    from planning.sweep.cli import add_parser as add_sweep
    from planning.sweep.cli import main as cmd_sweep

    add_sweep(sub).set_defaults(fn=cmd_sweep)

    s = sub.add_parser("serve", help="REST API and browser studio")
    s.add_argument(
        "--host", help="bind address (default 127.0.0.1, or FOOTFALL_HOST); elsewhere needs a token"
    )
    s.add_argument("--port", type=int, help="REST API port (default 8000, or FOOTFALL_PORT)")
    s.add_argument("--viewer-port", type=int, help="studio port (default 8080, or FOOTFALL_VIEWER_PORT)")
    s.add_argument(
        "--data-dir", help="where user maneuvers live (default ~/.local/share/footfall, or FOOTFALL_DATA_DIR)"
    )
    s.add_argument(
        "--robot",
        help="the robot of the sessions and simulations: spot, go1 or an MJCF file (or FOOTFALL_ROBOT)",
    )
    s.add_argument("--backend", choices=("local", "ray"), help="where queued simulations and sweeps run: local "
                   "worker processes (default, or FOOTFALL_BACKEND) or Ray tasks")  # fmt: skip
    s.add_argument("--address", metavar="ADDR", help="with --backend ray: the cluster (default: a local Ray)")
    s.set_defaults(fn=cmd_serve)
    return p


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    a = parser.parse_args(argv)
    if not getattr(a, "fn", None):
        parser.print_help()
        return EXIT_INVALID
    try:
        return int(a.fn(a))
    except UsageError as e:
        _err(str(e))
        return EXIT_INVALID
    except KeyboardInterrupt:
        return 130


if __name__ == "__main__":
    sys.exit(main())
