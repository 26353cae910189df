"""The server's adapter to the planning stack: a live simulated robot, its visuals, its state and plan as JSON.

Everything the server and the studio need of `planning` goes through here, so the planning code never imports the
server and the server touches only the interface of ``planning.sim.run.ManeuverSession``:
``.loop.step()``, ``.world.model/.data``, ``.report(wall_s)``, ``.controller.f_des`` (and, when present,
``.schedule``, ``.body_ref`` and ``.controller.plan_overlays()``).

A plan is a dict of overlays, each ``{"kind": "points" | "polyline" | "segments", "points": [[x, y, z], ...],
"color": [r, g, b]}`` in the world frame (m); segments are consecutive point pairs. The studio draws any such dict,
so a planning module that lands later adds its overlays by returning more entries from
``controller.plan_overlays()``.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass
from functools import lru_cache
from typing import Any, Literal

import mujoco
import numpy as np

LEGS = ("FL", "FR", "RL", "RR")
GRAVITY_MPS2 = 9.81
FORCE_ARROW_M_PER_N = (
    0.0015  # contact force arrows: 1.5 mm per newton (a 32 kg robot's ~80 N per foot → 12 cm)
)
GeomKind = Literal["plane", "hfield", "sphere", "capsule", "ellipsoid", "cylinder", "box", "mesh"]
_GEOM_KINDS: dict[int, GeomKind] = {
    int(mujoco.mjtGeom.mjGEOM_PLANE): "plane",
    int(mujoco.mjtGeom.mjGEOM_HFIELD): "hfield",
    int(mujoco.mjtGeom.mjGEOM_SPHERE): "sphere",
    int(mujoco.mjtGeom.mjGEOM_CAPSULE): "capsule",
    int(mujoco.mjtGeom.mjGEOM_ELLIPSOID): "ellipsoid",
    int(mujoco.mjtGeom.mjGEOM_CYLINDER): "cylinder",
    int(mujoco.mjtGeom.mjGEOM_BOX): "box",
    int(mujoco.mjtGeom.mjGEOM_MESH): "mesh",
}


class SteeringUnavailable(Exception):
    """The steering backend (velocity commands → gait) is not part of this build."""

    def __init__(self, message: str = "steering not available") -> None:
        super().__init__(message)


class NotSteerable(Exception):
    """This simulation runs a maneuver; steering needs a walking one (the session switches)."""


@dataclass(frozen=True)
class WalkLabel:
    """What a walking simulation shows where a maneuver would be: a name and no fixed duration."""

    gait: str
    name: str = "walk"
    duration: float = 0.0


MAPS = ("truth", "sensor")  # what a live session's terrain walk plans on (see walk_command)


def walk_command(
    vx: float = 0.0, vy: float = 0.0, yaw_rate: float = 0.0, gait: str = "trot", maps: str = "truth"
) -> Any:
    """Returns the planning stack's steering command for a live session; SteeringUnavailable when the build has no
    steering, ValueError naming the choices for an unknown gait. maps: on a terrain, "truth" (the scene's own maps)
    or "sensor" (the simulated depth sensor's).

    On a terrain a live session walks on the scene's own maps (perfect perception) unless asked for the sensor: the
    depth sensor's scans (~26–33 ms each, 10 Hz) hold the loop under real time (a steered walk on the slope measured
    0.78× with the sensor against 1.09× on the scene's maps); headless runs, the CLI and the bench use the sensor."""
    try:
        from planning.sim.run import WalkCommand
        from planning.steps.gait import get_gait
    except ImportError:
        raise SteeringUnavailable() from None
    get_gait(gait)
    if maps not in MAPS:
        raise ValueError(f"maps: one of {', '.join(MAPS)}, got {maps!r}")
    return WalkCommand(vx=vx, vy=vy, yaw_rate=yaw_rate, gait=gait, terrain_sensor=maps == "sensor")


def _with_terrain_speed(command: Any, terrain: str) -> Any:
    """Gives a live session's walk command with its terrain speed at the terrain's limit (TERRAIN_SPEED_LIMITS_MPS,
    the same as `footfall walk --speed` and REST's terrain_speed may ask): the studio's sliders then set the speed,
    up to that limit, instead of the terrain pipeline's default cap. A command with its own terrain speed, flat ground
    and terrain files keep theirs."""
    import dataclasses

    from planning.sim.run import terrain_speed_limit
    from planning.terrain.spec import as_spec

    name = as_spec(terrain).name
    if command.terrain_speed_mps is not None or name is None or name == "flat":
        return command
    return dataclasses.replace(command, terrain_speed_mps=terrain_speed_limit(name))


def steering_gaits() -> tuple[str, ...]:
    """Returns the gaits steering mode can walk with (empty without a steering backend)."""
    try:
        from planning.steps.gait import GAIT_NAMES
    except ImportError:
        return ()
    return tuple(g for g in GAIT_NAMES if g != "stand")


# ---- visuals ----------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class GeomVisual:
    """One MuJoCo geom to draw: kind, MuJoCo size (3,), pose (in its body's frame for robot geoms, in the world
    frame for terrain geoms), color (4,), and for height fields the grid of heights (m) and its half extents."""

    name: str
    kind: GeomKind
    size: tuple[float, float, float]
    pos: tuple[float, float, float]
    wxyz: tuple[float, float, float, float]
    rgba: tuple[float, float, float, float]
    body: int  # index into Visuals.body_names for robot geoms, -1 for terrain
    hfield_z: np.ndarray | None = None  # (nrow, ncol) heights, m, world frame relative to the geom origin
    hfield_half_xy: tuple[float, float] | None = None
    mesh: tuple[np.ndarray, np.ndarray] | None = (
        None  # a mesh geom's vertices (V,3) and faces (F,3), geom frame
    )


@dataclass(frozen=True)
class Visuals:
    """What the studio draws: the robot's bodies (posed every frame) with their geoms, and the static terrain."""

    body_names: tuple[str, ...]
    robot_geoms: tuple[GeomVisual, ...]
    terrain_geoms: tuple[GeomVisual, ...]


def _rgba(model: mujoco.MjModel, g: int) -> tuple[float, float, float, float]:
    mat = int(model.geom_matid[g])
    rgba = model.mat_rgba[mat] if mat >= 0 else model.geom_rgba[g]
    return (float(rgba[0]), float(rgba[1]), float(rgba[2]), float(rgba[3]))


def _t3(a: Any) -> tuple[float, float, float]:
    return (float(a[0]), float(a[1]), float(a[2]))


def visuals_of(model: mujoco.MjModel, data: mujoco.MjData, root_body: int) -> Visuals:
    """Returns the visuals of a composed model: bodies under `root_body` are the robot, the rest is terrain."""
    from server.studio.meshes import drawn, mesh_of  # the studio's: a mesh robot looks like itself

    robot_bodies = [b for b in range(model.nbody) if int(model.body_rootid[b]) == root_body]
    index = {b: i for i, b in enumerate(robot_bodies)}
    names = tuple(mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, b) or f"body{b}" for b in robot_bodies)
    robot, terrain = [], []
    for g in range(model.ngeom):
        kind = _GEOM_KINDS.get(int(model.geom_type[g]))
        if kind is None or model.geom_rgba[g][3] == 0.0 and int(model.geom_matid[g]) < 0:
            continue
        name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, g) or f"geom{g}"
        b = int(model.geom_bodyid[g])
        if b in index:
            if not drawn(model, g):
                continue
            q = model.geom_quat[g]
            robot.append(
                GeomVisual(name, kind, _t3(model.geom_size[g]), _t3(model.geom_pos[g]),
                           (float(q[0]), float(q[1]), float(q[2]), float(q[3])), _rgba(model, g), index[b],
                           mesh=mesh_of(model, g))
            )  # fmt: skip
            continue
        q = np.zeros(4)
        mujoco.mju_mat2Quat(q, data.geom_xmat[g])
        hz, half = None, None
        if kind == "hfield":
            h = int(model.geom_dataid[g])
            nrow, ncol = int(model.hfield_nrow[h]), int(model.hfield_ncol[h])
            adr = int(model.hfield_adr[h])
            sx, sy, sz, _base = (float(v) for v in model.hfield_size[h])
            hz = np.asarray(model.hfield_data[adr : adr + nrow * ncol], dtype=float).reshape(nrow, ncol) * sz
            half = (sx, sy)
        terrain.append(
            GeomVisual(name, kind, _t3(model.geom_size[g]), _t3(data.geom_xpos[g]),
                       (float(q[0]), float(q[1]), float(q[2]), float(q[3])), _rgba(model, g), -1, hz, half)
        )  # fmt: skip
    return Visuals(names, tuple(robot), tuple(terrain))


# ---- the live simulation ----------------------------------------------------------------------------------------
def _rpy_deg(R: np.ndarray) -> list[float]:
    roll = math.atan2(R[2, 1], R[2, 2])
    pitch = math.asin(max(-1.0, min(1.0, -R[2, 0])))
    yaw = math.atan2(R[1, 0], R[0, 0])
    return [round(math.degrees(a), 3) for a in (roll, pitch, yaw)]


def _r(v: Any, nd: int = 4) -> Any:
    return np.round(np.asarray(v, dtype=float), nd).tolist()


@lru_cache(maxsize=4)
def _robot(name: str) -> Any:
    from planning.robot import load_robot

    return load_robot(name)


class LiveSim:
    """A robot on a terrain executing one maneuver, stepped by its owner; reads are taken by the same owner.

    Not thread-safe: the session that owns it steps it and takes snapshots from one thread at a time.
    """

    def __init__(self, spec: Any, terrain: str, robot: str = "spot") -> None:
        """spec: a Maneuver to execute, or a WalkCommand (planning.sim.run) to walk steered."""
        from planning.sim import run

        self.terrain = terrain
        options = run.RunOptions(terrain=terrain, robot=robot)
        walk_cls = getattr(run, "WalkCommand", None)
        self.walking = walk_cls is not None and isinstance(spec, walk_cls)
        if self.walking:
            spec = _with_terrain_speed(spec, terrain)
            self.maneuver: Any = WalkLabel(spec.gait)
            self.session: Any = run.WalkSession(spec, options, robot=_robot(robot))
        else:
            self.maneuver = spec
            self.session = run.ManeuverSession(spec, options, robot=_robot(robot))
        self.world = self.session.world
        self.model = self.world.model
        self.data = self.world.data
        self.dt = float(self.model.opt.timestep)
        self.root_body = int(self.world.body_id)
        self.robot_bodies = np.array(
            [b for b in range(self.model.nbody) if int(self.model.body_rootid[b]) == self.root_body]
        )
        self.t0 = float(self.data.time)
        self.state = self.session.loop.state
        self.body_path: deque[tuple[float, float, float]] = deque(maxlen=400)  # 10 Hz for 40 s
        self._next_path_t = 0.0
        offset = getattr(self.session, "_offset", None)
        self.offset = np.zeros(3) if offset is None else np.asarray(offset, dtype=float)

    # -- stepping --
    @property
    def t(self) -> float:
        """Seconds since this maneuver started."""
        return float(self.data.time) - self.t0

    @property
    def fell(self) -> bool:
        return bool(self.session.loop.fell)

    @property
    def failure_reason(self) -> str | None:
        return self.session.loop.failure_reason

    def step(self) -> None:
        """Advances one physics tick (2 ms); raises FloatingPointError when the simulation diverges. After a fall the
        controller stops and the robot goes limp (zero joint torques): it lies where it fell instead of thrashing."""
        loop = self.session.loop
        if loop.fell:
            self.world.set_torques(np.zeros((4, 3)))
            self.world.step()
            s = self.world.read_state(loop.state)
        else:
            s = loop.step()
        if not np.isfinite(s.p_world_body).all():
            raise FloatingPointError(
                f"the simulation diverged at t = {self.t:.3f} s (non-finite body position)"
            )
        if self.t >= self._next_path_t:
            self._next_path_t = self.t + 0.1
            self.body_path.append(_t3(s.p_world_body))

    def trim(self) -> None:
        """Bounds the per-tick lists the planning code keeps for its report (a live session runs for hours)."""
        for st in getattr(self.session.loop, "stages", []):
            times = getattr(st, "times_ms", None)
            if isinstance(times, list) and len(times) > 20_000:
                del times[:-5_000]
        rec = getattr(self.session, "recorder", None)
        for name in ("t", "p_body", "rpy_body", "v_body", "yaw_rate", "touchdowns"):
            lst = getattr(rec, name, None)
            if isinstance(lst, list) and len(lst) > 30_000:
                del lst[:-10_000]
        driver = getattr(getattr(self.session, "controller", None), "driver", None)
        for name in ("qp_ms", "linearization_errors"):
            lst = getattr(driver, name, None)
            if isinstance(lst, list) and len(lst) > 30_000:
                del lst[:-10_000]

    def push(self, force_n: tuple[float, float, float], duration_s: float) -> None:
        """Applies a force (N, world frame) at the body's center of mass from now for duration_s."""
        from planning.sim.world import Push

        self.world.pushes.append(Push(float(self.data.time), force_n, duration_s))

    def steer(self, vx: float, vy: float, yaw_rate: float, gait: str) -> None:
        """Sets the velocity command (m/s, m/s, rad/s) and gait of a walking simulation; NotSteerable for one
        that runs a maneuver (the session then switches to walking); ValueError for an unknown gait."""
        if not self.walking:
            raise NotSteerable()
        c = self.session.controller
        if c.terrain is not None:
            # on a terrain the pipeline's cadence switches gaits (the slow gait over gaps, the climb gaits): the asked
            # gait is the one it returns to where the terrain allows
            if gait != c.fast_gait:
                c.fast_gait = gait
                self.maneuver = WalkLabel(gait)
        elif gait != c.gait:
            c.set_gait(gait)
            self.maneuver = WalkLabel(gait)
        c.steer(vx, vy, yaw_rate)

    def set_weights(self, preset: str) -> None:
        """Sets the step-selection weights (Qp, Qr) of a walking simulation from a preset, while it walks."""
        if self.walking:
            self.session.controller.planner.set_weights(preset)

    # -- reading --
    def body_poses(self) -> tuple[np.ndarray, np.ndarray]:
        """Returns copies of (xpos (nb,3) m, xquat (nb,4) wxyz) of the robot's bodies, world frame."""
        return self.data.xpos[self.robot_bodies].copy(), self.data.xquat[self.robot_bodies].copy()

    def reference(self) -> tuple[np.ndarray, np.ndarray] | None:
        """Returns the body reference (p_world_body (3,) m, v_world_body (3,) m/s) now, or None."""
        ref = getattr(self.session, "body_ref", None)
        if ref is None:
            return None
        try:
            p, v, _rpy, _omega = ref.sample(self.t)
        except Exception:  # noqa: BLE001 - a reference that cannot be sampled just has no overlay
            return None
        return np.asarray(p, dtype=float) + self.offset, np.asarray(v, dtype=float)

    def tick_ms(self) -> float | None:
        """Returns the controller's latest per-tick compute time (sum over its stages), ms."""
        total, found = 0.0, False
        for st in getattr(self.session.loop, "stages", []):
            times = getattr(st, "times_ms", None)
            if times:
                total += float(times[-1])
                found = True
        return total if found else None

    def state_dict(self) -> dict[str, Any]:
        """Returns the measured state as JSON-ready data (m, m/s, degrees for angles, rad for joints)."""
        s = self.state
        return {
            "t": round(self.t, 4),
            "body": {
                "position": _r(s.p_world_body),
                "quat_wxyz": _r(s.quat_world_body, 5),
                "rpy_deg": _rpy_deg(s.R_world_body),
                "velocity": _r(s.v_world_body),
                "angular_velocity": _r(s.omega_world),
            },
            "com": {"position": _r(s.p_world_com), "velocity": _r(s.v_world_com)},
            "joints": {leg: _r(s.q[i]) for i, leg in enumerate(LEGS)},
            "joint_velocities": {leg: _r(s.qd[i]) for i, leg in enumerate(LEGS)},
            "feet": {leg: _r(s.p_world_foot[i]) for i, leg in enumerate(LEGS)},
            "contacts": {leg: bool(s.contact[i]) for i, leg in enumerate(LEGS)},
            "fell": self.fell,
            "failure_reason": self.failure_reason,
        }

    def plan_dict(self) -> dict[str, Any]:
        """Returns the overlays of what the controller is doing now (see the module docstring for the shape)."""
        s = self.state
        r_foot = float(getattr(self.session.robot, "foot_radius_m", 0.0))
        f_des = np.asarray(getattr(self.session.controller, "f_des", np.zeros((4, 3))), dtype=float)
        p_contact = s.p_world_foot - np.array([0.0, 0.0, r_foot])
        segs = []
        for i in range(4):
            if np.linalg.norm(f_des[i]) > 1e-6:
                segs += [p_contact[i], p_contact[i] + FORCE_ARROW_M_PER_N * f_des[i]]
        overlays: dict[str, Any] = {
            "contact_forces": {"kind": "segments", "points": _r(segs), "color": [1.0, 0.45, 0.1],
                               "forces_n": {leg: _r(f_des[i], 2) for i, leg in enumerate(LEGS)}},
            "body_path": {"kind": "polyline", "points": [list(p) for p in self.body_path], "color": [0.2, 0.6, 1.0]},
        }  # fmt: skip
        # The linear-inverted-pendulum capture point of the measured state: where a step would stop the body.
        z = max(float(s.p_world_com[2] - self.offset[2]), 0.05)
        cp = s.p_world_com[:2] + s.v_world_com[:2] * math.sqrt(z / GRAVITY_MPS2)
        overlays["capture_point"] = {"kind": "points", "points": [[*_r(cp), float(self.offset[2])]],
                                     "color": [0.9, 0.1, 0.6]}  # fmt: skip
        ref = self.reference()
        if ref is not None:
            overlays["body_target"] = {"kind": "points", "points": [_r(ref[0])], "color": [0.1, 0.9, 0.3]}
        if not self.walking:
            steps = self._upcoming_touchdowns()
            if steps is not None:
                overlays.update(steps)
        extra = getattr(self.session.controller, "plan_overlays", None)
        if callable(extra):
            # The controller draws its own plan (swings, forces, step paths, solver plan); ours stay as fallbacks.
            try:
                theirs = dict(extra())
            except Exception as e:  # noqa: BLE001 - a planner's overlay bug must not break the session's state
                theirs = {"plan_overlays_error": {"kind": "points", "points": [], "error": repr(e)[:200]}}
            if isinstance(theirs.get("contact_forces"), dict):
                theirs["contact_forces"] = {
                    **theirs["contact_forces"],
                    "forces_n": overlays["contact_forces"]["forces_n"],
                }
            overlays.update(theirs)
        else:
            overlays.update(self._fallback_overlays())
        return {"t": round(self.t, 4), "overlays": overlays}

    def _fallback_overlays(self) -> dict[str, Any]:
        """Overlays read off the controller's state when it does not draw its own plan."""
        out: dict[str, Any] = {}
        if self.walking:
            out.update(self._walk_steps() or {})
        swings = self._swing_trajectories()
        if swings is not None:
            out["swing_trajectories"] = swings
        sol = getattr(self.session.controller, "solution", None)
        p_sol = getattr(sol, "p_world", None)
        if p_sol is not None and getattr(sol, "ok", False) and np.ndim(p_sol) == 2 and len(p_sol) > 1:
            out["centroidal_plan"] = {"kind": "polyline", "points": _r(p_sol), "color": [0.6, 0.4, 1.0]}
        return out

    def _upcoming_touchdowns(self) -> dict[str, Any] | None:
        sched = getattr(self.session, "schedule", None)
        if sched is None or not hasattr(sched, "swings"):
            return None
        pts, labels = [], []
        for leg_swings in sched.swings:
            for sw in leg_swings:
                if sw.t_touchdown >= self.t:
                    pts.append(_r(np.asarray(sw.p_touchdown, dtype=float) + self.offset))
                    labels.append(f"{LEGS[sw.leg]} @ {sw.t_touchdown:.2f} s")
        return {"step_plan": {"kind": "points", "points": pts, "labels": labels, "color": [1.0, 0.85, 0.1]}}

    def _walk_steps(self) -> dict[str, Any] | None:
        """The steering planner's selected step path and its capture points at the touchdowns."""
        sel = getattr(getattr(self.session.controller, "plan", None), "selection", None)
        if sel is None:
            return None
        out: dict[str, Any] = {}
        p_td = np.asarray(getattr(sel.path, "p_world_touchdown", np.zeros((0, 3))), dtype=float).reshape(
            -1, 3
        )
        p_td = p_td[np.isfinite(p_td).all(axis=1)]
        out["step_plan"] = {"kind": "points", "points": _r(p_td), "color": [1.0, 0.85, 0.1]}
        xi = np.asarray(getattr(sel, "xi_td", np.zeros((0, 2))), dtype=float).reshape(-1, 2)
        if len(xi) and len(p_td) >= 1:
            z = float(np.mean(p_td[:, 2]))
            xi3 = np.column_stack([xi, np.full(len(xi), z)])
            out["capture_point_plan"] = {"kind": "polyline", "points": _r(xi3[np.isfinite(xi3).all(axis=1)]),
                                         "color": [0.9, 0.1, 0.6]}  # fmt: skip
        return out

    def _swing_trajectories(self) -> dict[str, Any] | None:
        """The swing planner's current foot trajectories (16 samples each) as segments."""
        plans = getattr(getattr(self.session.controller, "handler", None), "plans", None)
        if not plans:
            return None
        segs: list[np.ndarray] = []
        for plan in list(plans.values()):
            try:
                ts = np.linspace(plan.t_start, plan.t_touchdown, 16)
                pts = np.asarray(plan.positions(ts), dtype=float)
            except Exception:  # noqa: BLE001 - an odd plan draws nothing
                continue
            if pts.shape == (16, 3) and np.isfinite(pts).all():
                segs.extend(np.stack([pts[:-1], pts[1:]], axis=1).reshape(-1, 3))
        return {"kind": "segments", "points": _r(segs), "color": [0.3, 1.0, 0.8]} if segs else None

    def report(self, wall_s: float) -> dict[str, Any]:
        """Returns the run report (CONTRACT.md) of what has run so far."""
        return dict(self.session.report(wall_s))

    def visuals(self) -> Visuals:
        return visuals_of(self.model, self.data, self.root_body)


def default_maneuver(name: str = "stand") -> Any:
    """Returns a shipped maneuver by name (the entry state of every session is `stand`)."""
    from planning.maneuver import find_maneuver, load_maneuver

    return load_maneuver(find_maneuver(name, allow_paths=False))


def terrain_names() -> tuple[str, ...]:
    from planning.terrain.scenes import TERRAIN_NAMES

    return tuple(TERRAIN_NAMES)


def run_headless(job: dict[str, Any]) -> dict[str, Any]:
    """Runs one queued simulation in a worker process and returns its run report (top-level, so it pickles).

    `job` holds the maneuver document (or a walk command), the terrain, the pushes [(t, (fx, fy, fz), duration)],
    the duration and the robot; progress goes to the worker's progress queue when there is one.
    """
    from planning.maneuver import parse_maneuver
    from planning.sim.run import RunOptions, run_maneuver
    from planning.sim.world import Push
    from server import simulations

    pushes = [Push(float(t), (float(f[0]), float(f[1]), float(f[2])), float(d)) for t, f, d in job["pushes"]]
    opts = RunOptions(
        terrain=job["terrain"], pushes=pushes, duration_s=job.get("duration"), robot=job["robot"]
    )
    progress = simulations.worker_progress(job["id"])
    if job.get("walk") is not None:
        from planning.sim.run import WalkCommand, run_walk

        w = dict(job["walk"])
        goal = w.pop("goal", None)
        maps = w.pop("maps", "sensor")
        speed = w.pop("terrain_speed", None)
        w.pop("terrain_pipeline", None)  # one pipeline: "regions" is accepted and means it
        command = WalkCommand(
            **w,
            terrain_speed_mps=speed,
            goal=None if goal is None else (float(goal[0]), float(goal[1])),
            terrain_aware=False if maps == "off" else None,
            terrain_sensor=maps == "sensor",
        )
        return run_walk(command, opts, progress=progress)
    maneuver = parse_maneuver(job["maneuver"])
    if job.get("physics_check"):
        # validation's physics check: the same run, measured per event, stopped once its failure is certain
        from planning.maneuver.physics import run_physics

        return run_physics(maneuver, opts, progress=progress)
    return run_maneuver(maneuver, opts, progress=progress)
