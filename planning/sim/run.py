"""Headless (or paced) runs of a maneuver in MuJoCo, ending in the JSON run report of CONTRACT.md."""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from planning.balance import BodyTarget
from planning.controller import Controller, ControllerParams
from planning.geometry import rpy_to_R
from planning.maneuver import BodyReference, Maneuver, build_schedule
from planning.maneuver.frame import PlanFrame
from planning.maneuver.generator import ProblemGenerator
from planning.maneuver.hints import HintedBody, load_hints
from planning.maneuver.scale import scale_to_robot
from planning.robot import LEGS, RobotModel, load_robot
from planning.sim.loop import Loop, ProgressFn, Stage
from planning.sim.metrics import Recorder, match_touchdowns, percentiles
from planning.sim.trace import LegTrace
from planning.sim.world import Push, RobotState, World
from planning.swing.types import TripKind
from planning.terrain.decision import BACK_DROP_FRAC, PipelineParams, TerrainPipeline
from planning.terrain.spec import load_terrain

POSITION_TOLERANCE_M = 0.15  # CONTRACT.md: final pose within 0.15 m and 0.2 rad
YAW_TOLERANCE_RAD = 0.2

# A terrain walk's speed (WalkCommand.terrain_speed_mps; `footfall walk --speed`, REST walk `terrain_speed`): the
# terrain pipeline's speed to a goal and its cap on a steered command, m/s (DecisionParams.max_speed_mps). The
# default is the pipeline's own (0.5); a walk may ask for up to its terrain's limit, raised only where a faster walk
# was measured to hold with the depth sensor (slope and rough: 1.0 m/s). The pipeline's own caps still apply under
# it (the footholds' moves off their nominal places, the stride, the trailing legs); TERRAIN_SPEED_MIN_MPS is its
# min_speed_mps.
TERRAIN_SPEED_DEFAULT_MPS = 0.5
TERRAIN_SPEED_MIN_MPS = 0.2
TERRAIN_SPEED_LIMITS_MPS: dict[str, float] = {"slope": 1.0, "rough": 1.0}


def terrain_speed_limit(terrain: str) -> float:
    """Gives the highest terrain speed a walk on this terrain (a scene name; any other: a user's) may ask, m/s."""
    return TERRAIN_SPEED_LIMITS_MPS.get(terrain, TERRAIN_SPEED_DEFAULT_MPS)


def check_terrain_speed(speed: float, terrain: str) -> str | None:
    """Gives why a terrain speed (m/s) cannot be walked on this terrain, or None when it can."""
    top = terrain_speed_limit(terrain)
    if not (TERRAIN_SPEED_MIN_MPS <= speed <= top):
        return f"{speed} m/s is outside [{TERRAIN_SPEED_MIN_MPS}, {top}] m/s, the speed range on {terrain!r}"
    return None


@dataclass(frozen=True)
class RunOptions:
    """How to run: terrain, disturbances, length, pacing."""

    terrain: str = "flat"  # a name, a name with overrides, or a file (planning.terrain.spec)
    pushes: Sequence[Push] = ()
    duration_s: float | None = None  # None: the maneuver's duration
    realtime: bool = False
    robot: str = "spot"
    seed: int = 0
    controller: ControllerParams = field(default_factory=ControllerParams)
    start_offset: tuple[float, float, float] = (0.0, 0.0, 0.0)  # start pose off the origin: x m, y m, yaw rad
    friction: float | None = None  # foot-ground sliding friction (None: the robot's and the scene's own)


@dataclass(frozen=True)
class _WorldSwing:
    leg: int
    t_liftoff: float
    t_touchdown: float
    p_touchdown: np.ndarray
    waypoints: np.ndarray | None


class _WorldPlan:
    """A maneuver's schedule seen in the world: the maneuver frame sits on the ground under the start pose."""

    def __init__(self, schedule: Any, frame: PlanFrame) -> None:
        self.schedule = schedule
        self.frame = frame
        self._cache: dict[int, _WorldSwing] = {}

    def swing_at(self, leg: int, t: float) -> _WorldSwing | None:
        sw = self.schedule.swing_at(leg, t)
        if sw is None:
            return None
        w = self._cache.get(id(sw))
        if w is None:
            wp = None
            if sw.waypoints is not None:
                wp = sw.waypoints.copy()
                wp[:, 1:4] = self.frame.point(wp[:, 1:4])
            w = _WorldSwing(sw.leg, sw.t_liftoff, sw.t_touchdown, self.frame.point(sw.p_touchdown), wp)
            self._cache[id(sw)] = w
        return w


class _WaypointMonitor:
    """Records where each swing waypoint's foot actually was at the waypoint's time."""

    def __init__(self, schedule: Any, frame: PlanFrame, foot_radius_m: float) -> None:
        self.todo = sorted(
            (float(w[0]), sw.leg, frame.point(w[1:4]))
            for sw in schedule.all_swings()
            if sw.waypoints is not None
            for w in sw.waypoints
        )
        self.r = foot_radius_m
        self.rows: list[dict[str, Any]] = []

    def __call__(self, s: RobotState) -> None:
        while self.todo and s.t >= self.todo[0][0]:
            t, leg, p = self.todo.pop(0)
            actual = s.p_world_foot[leg] - (0.0, 0.0, self.r)
            self.rows.append(
                {
                    "leg": LEGS[leg],
                    "t": round(t, 4),
                    "planned_at": np.round(p, 4).tolist(),
                    "actual_at": np.round(actual, 4).tolist(),
                    "error_m": round(float(np.linalg.norm(actual - p)), 4),
                }
            )


class _Session:
    """What every run shares: robot, terrain, world, loop, recorder, and the report fields they give."""

    mode = "maneuver"
    options: RunOptions
    robot: RobotModel
    world: World
    loop: Loop
    recorder: Recorder
    stages: list[Stage]

    def _setup(self, options: RunOptions, robot: RobotModel | None) -> None:
        self.options = options
        self.robot = robot or load_robot(options.robot)
        self.scene = load_terrain(options.terrain, seed=options.seed)
        self.world = World(self.robot, self.scene)
        if options.friction is not None:
            self.world.set_friction(options.friction)
        if any(options.start_offset):
            self.world.place(*options.start_offset)
        self.world.pushes = list(options.pushes)
        self.recorder = Recorder(self.robot.foot_radius_m)

    def _start_loop(
        self,
        stages: list[Stage],
        actuate: Callable[[RobotState], np.ndarray],
        monitors: Sequence[Callable[[RobotState], None]] = (),
    ) -> None:
        self.stages = stages
        self.loop = Loop(self.world, stages, actuate, monitors=[self.recorder, *monitors])

    def _duration(self) -> float:
        raise NotImplementedError

    def _handler(self) -> Any:
        return self.controller.handler  # type: ignore[attr-defined]

    def _done(self) -> bool:
        """Whether the run may end before its duration (checked every 50 ticks)."""
        return False

    def run(self, progress: ProgressFn | None = None) -> dict[str, Any]:
        """Runs to the end (or a fall) and returns the run report."""
        duration = self.options.duration_s if self.options.duration_s is not None else self._duration()
        t0 = time.perf_counter()
        self.loop.run(duration, realtime=self.options.realtime, progress=progress, should_stop=self._done)
        wall = time.perf_counter() - t0
        return self.report(wall)

    def report(self, wall_s: float) -> dict[str, Any]:
        raise NotImplementedError

    def _fall_contact(self) -> dict[str, Any] | None:
        """A fall by touch: the robot's part and what it is (trunk, upper leg, lower leg), the world geom it touched
        and where (None: no such fall)."""
        fc = self.loop.fall_contact
        if fc is None:
            return None
        part, kind, touched, point = fc
        return {"part": part, "kind": kind, "touched": touched, "point_m": [round(v, 4) for v in point]}

    def _slips_report(self) -> dict[str, Any]:
        """The stance feet that slid (planning.handler: HandlerParams.slip_*): how many slips, per leg, each one's
        start and duration (the first 100), and the lowest share of the nominal friction the forces assumed."""
        h = self._handler()
        log = getattr(h, "slip_log", [])
        return {
            "count": len(log),
            "per_leg": {name: sum(1 for e in log if e[0] == i) for i, name in enumerate(LEGS)},
            "events": [
                {"leg": LEGS[leg], "t": round(t, 4), "duration_s": round(d, 4)} for leg, t, d in log[:100]
            ],
            "friction_scale_min": round(float(getattr(h, "friction_scale_min", 1.0)), 4),
        }

    def _common_report(self, wall_s: float) -> dict[str, Any]:
        t_end = self.world.t
        rec = self.recorder
        drift = 0.0
        if rec.p_body:
            P = np.array(rec.p_body)
            drift = float(np.max(np.linalg.norm(P[:, :2] - P[0, :2], axis=1)))
        stage_times = {st.name: percentiles(st.times_ms) for st in self.stages}
        return {
            "mode": self.mode,
            "robot": self.robot.name,
            "terrain": self.options.terrain,
            "seed": self.options.seed,  # the terrain scene's layout (--seed)
            "duration_s": round(t_end, 4),
            "fell": bool(self.loop.fell),
            "fall_time_s": None if self.loop.fall_time is None else round(self.loop.fall_time, 4),
            "fall_contact": self._fall_contact(),
            "no_step_touchdowns": 0,
            "no_step_scuffs": 0,
            "body_collisions": 0 if not self.loop.fell else 1,
            "max_horizontal_drift_m": round(drift, 4),
            "max_foot_slip_m": round(rec.max_foot_slip_m, 4),
            "airborne_s": round(rec.airborne_s, 4),
            "max_body_height_m": round(rec.max_body_height_m, 4),
            "pushes": [
                {
                    "t": p.t_s,
                    "force_n": list(p.force_n),
                    "duration_s": p.duration_s,
                    "impulse_ns": p.impulse_ns,
                }
                for p in self.world.pushes
            ],
            "foot_slips": self._slips_report(),
            "trips": [
                {"leg": LEGS[leg], "t": round(tr.t_s, 4), "kind": tr.kind.name.lower()}
                for leg, tr in self._handler().trip_log
            ],
            # Swing feet or lower legs hitting terrain before their touchdown window (trips; self-collisions,
            # measured geometrically between the robot's own legs, are not terrain), per 100 touchdowns.
            "swing_collisions_per_100_steps": round(
                100.0
                * sum(1 for _, tr in self._handler().trip_log if tr.kind in _TERRAIN_TRIPS)
                / max(rec.landings, 1),
                2,
            ),
            "stages": stage_times,
            "timing": {"wall_s": round(wall_s, 3), "rtf": round(t_end / wall_s, 3) if wall_s > 0 else None},
        }


class ManeuverSession(_Session):
    """A robot in a world executing one maneuver: the loop plus what the report needs. Usable step by step."""

    def __init__(self, maneuver: Maneuver, options: RunOptions, robot: RobotModel | None = None) -> None:
        self._setup(options, robot)
        # lengths are written for the reference robot: on another robot they scale to its height and stance
        self.maneuver = maneuver = scale_to_robot(maneuver, self.robot)
        self.schedule = build_schedule(maneuver, self.robot)
        base = BodyReference.from_maneuver(maneuver, self.robot, self.schedule)
        self.body_ref = HintedBody(base, load_hints(maneuver, self.robot), maneuver)
        # the plan is relative to the start pose: its frame sits on the ground under it, along its heading
        x0, y0, yaw0 = options.start_offset
        self.frame = PlanFrame(x0, y0, float(self.scene.ground_height(x0, y0)), yaw0)
        self._offset = self.frame.t
        self.generator = ProblemGenerator(maneuver, self.schedule, self.body_ref, self.robot, self.frame)
        self.controller = Controller(
            self.robot,
            self._target,
            options.controller,
            contact_plan=_WorldPlan(self.schedule, self.frame),
            generator=self.generator,
        )
        self.waypoints = _WaypointMonitor(self.schedule, self.frame, self.robot.foot_radius_m)
        self._start_loop(self.controller.stages, self.controller.actuate, [self.waypoints])
        self._tgt = BodyTarget(np.zeros(3), np.zeros(3), np.eye(3), np.zeros(3))

    def _target(self, t: float) -> BodyTarget:
        p, v, rpy, omega = self.body_ref.sample(t)
        f = self.frame
        self._tgt.p_world_body = f.point(p)
        self._tgt.v_world_body = f.vector(v)
        self._tgt.R_world_body = f.rotation(rpy_to_R(rpy))
        self._tgt.omega_world = f.vector(omega)
        return self._tgt

    def _duration(self) -> float:
        return float(self.maneuver.duration)

    def _solver_report(self, stage_times: dict[str, Any]) -> dict[str, Any]:
        return _solver_section(self.controller, stage_times)

    def _velocity_rms(self) -> dict[str, float | None]:
        rec = self.recorder
        err = np.zeros((len(rec.t), 3))
        for k, t in enumerate(rec.t):
            _, v_ref, rpy_ref, w_ref = self.body_ref.sample(t)
            v_ref = self.frame.vector(v_ref)
            yaw = rec.rpy_body[k][2]
            c, sn = np.cos(yaw), np.sin(yaw)
            v_ref_h = np.array([c * v_ref[0] + sn * v_ref[1], -sn * v_ref[0] + c * v_ref[1]])
            err[k, :2] = rec.v_body[k] - v_ref_h
            err[k, 2] = rec.yaw_rate[k] - w_ref[2]
        return velocity_rms(err)

    def report(self, wall_s: float) -> dict[str, Any]:
        """Returns the JSON-ready run report of what has run so far."""
        s = self.loop.state
        m = self.maneuver
        t_end = self.world.t
        # final pose against the last keyframe (or the held start pose)
        p_goal, _, rpy_goal, _ = self.body_ref.sample(t_end)
        p_goal = self.frame.point(p_goal)
        pos_err = float(np.linalg.norm(s.p_world_body - p_goal))
        dyaw = float((s.yaw - rpy_goal[2] - self.frame.yaw + np.pi) % (2 * np.pi) - np.pi)
        planned = [
            (
                sw.leg,
                sw.t_touchdown,
                self.frame.point(sw.p_touchdown),
                sw.adjust.time_s,
                sw.adjust.radius_m or 0.0,
            )
            for sw in self.schedule.all_swings()
            if sw.t_touchdown <= t_end
        ]
        tds = match_touchdowns(planned, self.recorder.touchdowns)
        errs = [r["error_m"] for r in tds if r["error_m"] is not None]
        events_ok = all(r["within_window"] for r in tds)
        fell = self.loop.fell
        pose_ok = pos_err <= POSITION_TOLERANCE_M and abs(dyaw) <= YAW_TOLERANCE_RAD
        base = self._common_report(wall_s)
        solver = self._solver_report(base["stages"])
        backup = backup_share(solver)
        carried_out = backup <= MAX_BACKUP_SHARE
        success = (not fell) and events_ok and pose_ok and carried_out
        reason = self.loop.failure_reason
        if reason is None and not carried_out:
            reason = (
                f"the backup controller drove {backup:.0%} of the ticks ({solver['fallback_ticks']} of "
                f"{solver['balance_ticks']}; more than {MAX_BACKUP_SHARE:.0%} means the maneuver was not carried "
                f"out): the solver found no usable plan (statuses {solver['statuses']})"
            )
        if reason is None and not events_ok:
            missed = next(r for r in tds if not r["within_window"])
            reason = f"touchdown of {missed['leg']} planned at {missed['planned_t']} s missed its window"
        if reason is None and not pose_ok:
            reason = f"final pose off by {pos_err:.3f} m and {dyaw:.3f} rad"
        return {
            "maneuver": m.name,
            **base,
            "success": bool(success),
            "failure_reason": None if success else reason,
            "final_pose_error": {"position_m": round(pos_err, 4), "yaw_rad": round(abs(dyaw), 4)},
            "touchdowns": tds,
            "foot_placement_error_m": {
                "median": round(float(np.median(errs)), 4) if errs else None,
                "max": round(float(np.max(errs)), 4) if errs else None,
            },
            "velocity_tracking_rms": self._velocity_rms(),
            "waypoints": self.waypoints.rows,
            "solver": solver,
        }


MAX_BACKUP_SHARE = 0.05  # a maneuver run where the backup (balance) controller drove more of the ticks failed


def backup_share(solver: dict[str, Any]) -> float:
    """Returns the share of force ticks the backup controller drove (fallback ticks / balance ticks)."""
    ticks = int(solver.get("balance_ticks") or 0)
    return float(solver.get("fallback_ticks") or 0) / ticks if ticks > 0 else 0.0


def _solver_section(controller: Any, stage_times: dict[str, Any]) -> dict[str, Any]:
    """Returns the report's "solver" section: the centroidal solver's numbers, or the balance controller's ticks."""
    balance = len(next((st.times_ms for st in controller.stages if st.name == "balance"), []))
    driver = getattr(controller, "driver", None)
    if driver is not None:
        return driver.report(stage_times, balance)  # type: ignore[no-any-return]
    bal = stage_times.get("balance", {})
    return {
        "tick_ms_p50": bal.get("p50_ms"),
        "tick_ms_p99": bal.get("p99_ms"),
        "qp_ms_p50": None,
        "fallback_ticks": 0,
        "balance_ticks": balance,
        "solver_ticks": 0,
        "statuses": {},
        "linearization_error_p50": None,
        "linearization_error_first4": [],
        "forces_from": "balance QP (no centroidal solver in this mode)",
    }


def velocity_rms(err: np.ndarray) -> dict[str, float | None]:
    """Returns {"vx", "vy", "yaw_rate"} RMS of an (N,3) array of tracking errors (m/s, m/s, rad/s)."""
    if len(err) == 0:
        return {"vx": None, "vy": None, "yaw_rate": None}
    rms = np.sqrt(np.mean(np.square(err), axis=0))
    return {"vx": round(float(rms[0]), 4), "vy": round(float(rms[1]), 4), "yaw_rate": round(float(rms[2]), 4)}


def run_maneuver(
    maneuver: Maneuver, options: RunOptions | None = None, progress: ProgressFn | None = None
) -> dict[str, Any]:
    """Simulates a maneuver and returns its run report (CONTRACT.md)."""
    return ManeuverSession(maneuver, options or RunOptions()).run(progress)


@dataclass(frozen=True)
class WalkCommand:
    """Steering mode: a velocity command (m/s, m/s, rad/s) or a goal (x, y in m) to reach."""

    vx: float = 0.0
    vy: float = 0.0
    yaw_rate: float = 0.0
    gait: str = "trot"
    goal: tuple[float, float] | None = None
    weights: str = "default"
    capture_point_selection: bool = True  # False: walk the reference step path only
    centroidal: bool = (
        False  # True: the centroidal solver turns the step plan into forces (balance QP otherwise)
    )
    settle_s: float = 1.5  # velocity tracking is measured after this much time (s)
    # Terrain-aware walking (the terrain pipeline, planning.terrain.decision: steppable regions, footholds by the
    # step QP inside them), to the goal or steered: None = on every terrain other than flat. terrain_sensor: maps
    # from the simulated depth sensor (False: the scene's ground truth).
    terrain_aware: bool | None = None
    terrain_sensor: bool = True
    stop_at_goal: bool = False  # end the run once the body has held within half the goal tolerance for 1 s
    sensor_noise_m: float | None = None  # the depth sensor's range noise floor (1σ, m; None: SensorParams')
    # on a terrain: the speed to a goal and the cap on a steered command (m/s; None: TERRAIN_SPEED_DEFAULT_MPS; at
    # most terrain_speed_limit(terrain))
    terrain_speed_mps: float | None = None
    # a walk to a goal on a terrain goes down descents backward where it has room to turn round
    # (DecisionParams.back_drop_frac; on by default: the stairs family measured 33 of 50 clean against 28
    # forward, 5 gains and no loss; False: forward, as before)
    descend_backward: bool = True


def pipeline_params(command: WalkCommand, terrain: str) -> PipelineParams:
    """Gives the terrain pipeline's parameters for a walk: maps from the sensor or the scene, the walk's terrain
    speed (checked against the terrain's limit) and the sensor's noise floor."""
    params = PipelineParams(use_sensor=command.terrain_sensor)
    speed = command.terrain_speed_mps
    if speed is not None:
        why = check_terrain_speed(speed, terrain)
        if why is not None:
            raise ValueError(f"WalkCommand.terrain_speed_mps: {why}")
        params = dataclasses.replace(
            params, decision=dataclasses.replace(params.decision, max_speed_mps=speed)
        )
    if command.descend_backward:
        params = dataclasses.replace(
            params, decision=dataclasses.replace(params.decision, back_drop_frac=BACK_DROP_FRAC)
        )
    if command.sensor_noise_m is not None:
        perception = params.perception
        sensor = dataclasses.replace(perception.sensor, noise_m=command.sensor_noise_m)
        params = dataclasses.replace(params, perception=dataclasses.replace(perception, sensor=sensor))
    return params


class WalkSession(_Session):
    """A robot steered by velocity commands or sent to a goal; usable step by step."""

    mode = "walk"

    def __init__(
        self,
        command: WalkCommand,
        options: RunOptions,
        robot: RobotModel | None = None,
        trace_every_s: float | None = None,
    ) -> None:
        """trace_every_s: keep a per-leg trace (planning.sim.trace.LegTrace, `self.trace`) sampled this often in
        simulated seconds (None: none)."""
        from planning.walk import WalkController, WalkParams

        self.command = command
        self._setup(options, robot)
        self.controller = WalkController(
            self.robot,
            WalkParams(use_centroidal=command.centroidal),
            gait=command.gait,
            weights=command.weights,
            reference_only=not command.capture_point_selection,
        )
        if command.goal is not None:
            self.controller.set_goal(*command.goal)
        else:
            self.controller.steer(command.vx, command.vy, command.yaw_rate)
        self.pipeline: TerrainPipeline | None = None
        self.collisions: Any = None
        self.near_misses: Any = None
        monitors: list[Callable[[RobotState], None]] = []
        aware = command.terrain_aware
        if aware is None:
            aware = self.scene.name != "flat"
        if aware:
            from planning.terrain.crossing import BodyCollisionMonitor, NearMissMonitor

            self.pipeline = TerrainPipeline(
                self.robot,
                self.world.model,
                self.world.data,
                command.goal,
                self.scene,
                pipeline_params(command, self.scene.name),
            )
            self.controller.use_terrain(self.pipeline)
            self.collisions = BodyCollisionMonitor(self.world)
            self.near_misses = NearMissMonitor(self.world)
            monitors += [self.collisions, self.near_misses]
        self.trace: LegTrace | None = None
        if trace_every_s is not None:
            self.trace = LegTrace(self.controller, self.pipeline, trace_every_s)
            monitors.append(self.trace)
        self._t_at_goal: float | None = None
        self._start_loop(self.controller.stages, self.controller.actuate, monitors)

    def _duration(self) -> float:
        return 30.0 if self.command.goal is not None else 10.0

    def _done(self) -> bool:
        c = self.command
        if not c.stop_at_goal or c.goal is None:
            return False
        s = self.loop.state
        if float(np.linalg.norm(s.p_world_body[:2] - np.asarray(c.goal))) > POSITION_TOLERANCE_M / 2:
            self._t_at_goal = None
            return False
        if self._t_at_goal is None:
            self._t_at_goal = s.t
        return s.t - self._t_at_goal >= 1.0

    def _velocity_rms(self) -> dict[str, float | None]:
        rec = self.recorder
        c = self.command
        keep = [k for k, t in enumerate(rec.t) if t >= c.settle_s]
        if c.goal is not None or not keep:
            return velocity_rms(np.zeros((0, 3)))
        err = np.array([[*(rec.v_body[k] - (c.vx, c.vy)), rec.yaw_rate[k] - c.yaw_rate] for k in keep])
        return velocity_rms(err)

    def report(self, wall_s: float) -> dict[str, Any]:
        base = self._common_report(wall_s)
        s = self.loop.state
        c = self.command
        fell = self.loop.fell
        reason = self.loop.failure_reason
        if c.goal is not None:
            d = s.p_world_body[:2] - np.asarray(c.goal)
            dist = float(np.linalg.norm(d))
            pos_err: float | None = dist
            ok = dist <= POSITION_TOLERANCE_M
            if reason is None and not ok:
                reason = f"ended {dist:.2f} m from the goal {list(c.goal)}"
        else:
            pos_err, ok = None, True
        success = not fell and ok
        rms = self._velocity_rms()
        rec = self.recorder
        keep = [k for k, t in enumerate(rec.t) if t >= c.settle_s]
        mean_v = np.mean([rec.v_body[k] for k in keep], axis=0) if keep else np.full(2, np.nan)
        mean_w = float(np.mean([rec.yaw_rate[k] for k in keep])) if keep else float("nan")
        base.update(self._terrain_report())
        return {
            "maneuver": None,
            **base,
            "success": bool(success),
            "failure_reason": None if success else reason,
            "command": {
                "vx": c.vx,
                "vy": c.vy,
                "yaw_rate": c.yaw_rate,
                "gait": c.gait,
                "goal": c.goal,
                "weights": c.weights,
                "capture_point_selection": c.capture_point_selection,
                "centroidal": c.centroidal,
                "terrain_speed_mps": c.terrain_speed_mps,
                "descend_backward": c.descend_backward,
            },
            "final_pose_error": {
                "position_m": None if pos_err is None else round(pos_err, 4),
                "yaw_rad": None,
            },
            "touchdowns": [],
            "foot_placement_error_m": {"median": None, "max": None},
            "velocity_tracking_rms": rms,
            # the fraction of the time after settle_s with no foot on the ground (the gait's flight phases)
            "flight_fraction": None if (ff := rec.flight_fraction(c.settle_s)) is None else round(ff, 4),
            "mean_velocity": {
                "vx": round(float(mean_v[0]), 4),
                "vy": round(float(mean_v[1]), 4),
                "yaw_rate": round(mean_w, 4),
            },
            "steps_taken": rec.landings,
            "solver": _solver_section(self.controller, base["stages"]),
        }

    def _terrain_report(self) -> dict[str, Any]:
        """Ground-truth terrain fields: no-step touchdowns, body collisions, crossed, time taken, the pipeline's stats."""
        from planning.terrain.crossing import NEAR_EDGE_M, edge_distance, no_step_details, terrain_span_x

        rec = self.recorder
        landings = [td for td in rec.touchdowns if td.landing]
        scuffs = [td for td in rec.touchdowns if not td.landing]
        flags, spread, gap = no_step_details(self.scene, [td.p_world for td in landings])
        # how near an edge of the true ground the other landings came down: the sole within NEAR_EDGE_M of one
        edge = edge_distance(self.scene, [td.p_world for td in landings])
        near_edge = int(np.count_nonzero(~flags & (edge <= self.robot.foot_radius_m + NEAR_EDGE_M + 1e-9)))
        n_landed = len(landings)
        out: dict[str, Any] = {
            "near_edge_landings": near_edge,
            "near_edge_landings_per_100_steps": round(100.0 * near_edge / n_landed, 2) if n_landed else None,
            # the nearest edge to any landing but a no-step one (None: none within the largest ring, 10 cm)
            "landing_edge_min_m": (
                None if not np.isfinite(m := float(np.min(edge[~flags], initial=np.inf))) else round(m, 3)
            ),
            "no_step_touchdowns": int(np.count_nonzero(flags)),
            "no_step_scuffs": int(
                np.count_nonzero(no_step_details(self.scene, [td.p_world for td in scuffs])[0])
            ),
            # the first NO_STEP_EVENTS no-step landings: when, which leg, where, and why (the true ground's height
            # spread around the contact point: an edge; the contact point's height above it: on an obstacle)
            "no_step_events": [
                {
                    "t_s": round(td.t, 3),
                    "leg": LEGS[td.leg],
                    "point_m": [round(float(v), 4) for v in td.p_world],
                    "spread_m": round(float(sp), 4),
                    "gap_m": round(float(gp), 4),
                }
                for td, f, sp, gp in zip(landings, flags, spread, gap, strict=True)
                if f
            ][:NO_STEP_EVENTS],
        }
        x_end = terrain_span_x(self.scene)[1]
        crossed_at = next(
            (t for t, p in zip(rec.t, rec.p_body, strict=True) if p[0] > x_end + CROSSED_BEYOND_M), None
        )
        reached_at = None
        if self.command.goal is not None:
            goal = np.asarray(self.command.goal)
            reached_at = next(
                (
                    t
                    for t, p in zip(rec.t, rec.p_body, strict=True)
                    if np.linalg.norm(np.asarray(p)[:2] - goal) <= POSITION_TOLERANCE_M
                ),
                None,
            )
        out["crossed"] = bool(crossed_at is not None and not self.loop.fell)
        out["time_to_cross_s"] = None if crossed_at is None else round(float(crossed_at), 3)
        out["time_to_goal_s"] = None if reached_at is None else round(float(reached_at), 3)
        if self.collisions is not None:
            out["body_collisions"] = int(self.collisions.body_collisions) + (
                1 if self.loop.fell and self.collisions.body_collisions == 0 else 0
            )
            out["foot_obstacle_contacts"] = int(self.collisions.foot_on_obstacle)
        if self.near_misses is not None:
            # a non-foot part within NEAR_MISS_M of the terrain, not touching it: per approach, and per 100 steps
            nm = self.near_misses
            nm.finish(self.loop.fell)
            out["near_misses"] = int(nm.near_misses)
            steps = max(int(rec.landings), 1)
            out["near_misses_per_100_steps"] = round(100.0 * nm.near_misses / steps, 2)
            out["link_clearance_min_m"] = None if math.isinf(nm.least_m) else round(float(nm.least_m), 4)
            out["near_miss_events"] = [
                {"t_s": round(t, 3), "part": part, "gap_m": gap}
                for t, part, gap in nm.events[:NEAR_MISS_EVENTS]
            ]
        if self.pipeline is not None:
            out["navigator"] = self.pipeline.stats.summary()
        return out


_TERRAIN_TRIPS = (TripKind.NORMAL, TripKind.KNEE)  # trips against terrain (not another leg of the robot)
NEAR_MISS_EVENTS = 20  # the run report lists the first this many near misses (when, which part, how close)
NO_STEP_EVENTS = 20  # ... and the first this many no-step landings (when, which leg, where, why)
CROSSED_BEYOND_M = 0.5  # "crossed": the body center got this far past the terrain's end (m)


def run_walk(
    command: WalkCommand, options: RunOptions | None = None, progress: ProgressFn | None = None
) -> dict[str, Any]:
    """Simulates steering mode and returns its run report (CONTRACT.md)."""
    return WalkSession(command, options or RunOptions()).run(progress)
