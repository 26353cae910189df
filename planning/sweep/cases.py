"""A sweep's cases: the expansion of a spec into cases, their keys, and `run_case`, one headless run.

A case is a plain dict (it crosses process and machine boundaries): {"params": what the run needs, self-contained
(the maneuver's document travels with it, so a remote worker needs no library files), "axes": the case's value on
each axis of the sweep, for grouping (in a repeated sweep, also its draw's number on the `draw` axis)}. Its key
hashes the params and the code version, so results stored under it stay valid until either changes.
"""

from __future__ import annotations

import dataclasses
import hashlib
import itertools
import json
import math
import os
import time
from collections.abc import Callable
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np

from planning.sweep.spec import DRAW, MAX_CASES, Range, SweepSpec, SweepSpecError

_ROOT = Path(__file__).resolve().parents[1]  # planning/
_REPO = _ROOT.parent


@lru_cache(maxsize=1)
def code_version() -> str:
    """A hash of the code and data a run depends on (planning/, the robot assets, the maneuver library); the
    sweep tool's own files other than this one are left out (a new summary format keeps old results valid)."""
    h = hashlib.sha256()
    files = [
        p
        for p in sorted(_ROOT.rglob("*"))
        if p.is_file()
        and p.suffix in (".py", ".xml", ".yaml", ".yml", ".json", ".stl", ".obj")
        and "__pycache__" not in p.parts
        and (p.parent.name != "sweep" or p.name == "cases.py")
    ]
    files += sorted((_REPO / "maneuvers").glob("*.y*ml"))
    for p in files:
        h.update(str(p.relative_to(_REPO)).encode())
        h.update(p.read_bytes())
    return h.hexdigest()[:16]


def case_key(params: dict[str, Any], version: str | None = None) -> str:
    """The key a case's result is stored under: a hash of its params and the code version."""
    text = json.dumps(params, sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(f"{version or code_version()}\n{text}".encode()).hexdigest()[:20]


# ---- expansion ------------------------------------------------------------------------------------------------
def _clean(v: Any) -> Any:
    """Rounds floats so range values print and hash the same everywhere (0.15, not 0.15000000000000002)."""
    if isinstance(v, float):
        return round(v, 10)
    if isinstance(v, list):
        return [_clean(x) for x in v]
    return v


def grid_values(axis: list[Any] | Range) -> list[Any]:
    """The values an axis takes in a grid: its list, or its range's evenly spaced values."""
    if not isinstance(axis, Range):
        return [_clean(v) for v in axis]
    if axis.count is None and axis.step is None:
        if axis.integer:
            return list(range(int(math.ceil(axis.min)), int(math.floor(axis.max)) + 1))
        raise ValueError("a range in a grid needs count or step (or integer: true)")
    if axis.count is not None:
        vals = [axis.min] if axis.count == 1 else list(np.linspace(axis.min, axis.max, axis.count))
    else:
        assert axis.step is not None
        n = int(math.floor((axis.max - axis.min) / axis.step + 1e-9)) + 1
        vals = [axis.min + k * axis.step for k in range(n)]
    if axis.integer:
        return list(dict.fromkeys(int(round(v)) for v in vals))
    return [_clean(float(v)) for v in vals]


def _sample(axis: list[Any] | Range, rng: np.random.Generator) -> Any:
    if isinstance(axis, Range):
        if axis.integer:
            return int(rng.integers(int(math.ceil(axis.min)), int(math.floor(axis.max)) + 1))
        return _clean(float(rng.uniform(axis.min, axis.max)))
    return _clean(axis[int(rng.integers(len(axis)))])


def _coordinates(spec: SweepSpec) -> list[dict[str, Any]]:
    """Each case's value on every axis (run labels on the `run` axis when the spec lists several runs; a run's own
    axes replace the sweep's of the same name). A repeated sweep's draws are drawn first, as without the repeat
    (the same draws), then each is taken at every combination of the repeat values, its number on the draw axis."""
    runs = spec.runs()
    per_run: list[dict[str, list[Any] | Range]] = []
    for r in runs:
        axes: dict[str, list[Any] | Range] = {**spec.axes, **r.axes}
        if len(runs) > 1:
            axes = {"run": [r.name()], **axes}
        per_run.append(axes)
    if spec.sampling == "grid":
        out: list[dict[str, Any]] = []
        for r, axes in zip(runs, per_run, strict=True):
            values = {}
            for n, ax in axes.items():
                where = f"run.{r.name()}.axes" if n in r.axes else "axes"
                try:
                    values[n] = grid_values(ax)
                except ValueError as e:
                    raise SweepSpecError([f"{where}.{n}: {e}"]) from None
            total = len(out) + math.prod(len(v) for v in values.values())
            if total > MAX_CASES:
                raise SweepSpecError([f"axes: the grid has over {MAX_CASES} cases, the most a sweep may run"])
            out += [dict(zip(values, combo, strict=True)) for combo in itertools.product(*values.values())]
        return out
    rng = np.random.default_rng(spec.sampling.seed)
    draws = []
    for _ in range(spec.sampling.random):
        axes = per_run[int(rng.integers(len(runs)))]
        draws.append({n: _sample(ax, rng) for n, ax in axes.items()})
    repeat = {n: grid_values(v) for n, v in spec.repeat().items()}
    if not repeat:
        return draws
    return [
        {**d, **dict(zip(repeat, combo, strict=True)), DRAW: i}
        for i, d in enumerate(draws)
        for combo in itertools.product(*repeat.values())
    ]


def _number(axis: str, v: Any) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise SweepSpecError([f"axes.{axis}: {v!r} is not a number"])
    return float(v)


def _terrain_params(terrain: str, params: dict[str, Any], where: str) -> dict[str, Any]:
    """Checks scene parameters against the terrain's Params (names, and whole numbers where it wants them)."""
    from planning.terrain.scenes import TERRAIN_NAMES, terrain_params

    if terrain not in TERRAIN_NAMES:
        raise SweepSpecError([f"{where}: unknown terrain {terrain!r} (one of: {', '.join(TERRAIN_NAMES)})"])
    try:
        defaults = terrain_params(terrain)
    except ValueError as e:
        raise SweepSpecError([f"{where}: {e}"]) from None
    out: dict[str, Any] = {}
    for k, v in params.items():
        if not hasattr(defaults, k):
            fields = ", ".join(f.name for f in dataclasses.fields(defaults))
            raise SweepSpecError(
                [f"{where}.{k}: terrain {terrain!r} has no parameter {k} (it has: {fields})"]
            )
        d = getattr(defaults, k)
        if isinstance(d, bool):
            if not isinstance(v, bool):
                raise SweepSpecError([f"{where}.{k}: {v!r} is not true or false"])
        elif isinstance(d, int):
            if isinstance(v, bool) or not isinstance(v, (int, float)) or float(v) != int(v):
                raise SweepSpecError([f"{where}.{k}: {v!r} is not a whole number"])
            v = int(v)
        elif isinstance(d, float):
            v = _number(f"{where}.{k}", v)
        elif isinstance(d, tuple):
            if not isinstance(v, list) or len(v) != len(d):
                raise SweepSpecError([f"{where}.{k}: expected a list of {len(d)} numbers like {list(d)}"])
        out[k] = v
    from planning.terrain.spec import spec_from_mapping

    try:  # the same check as the terrain's own structured form (types and ranges)
        spec_from_mapping({"name": terrain, "params": out})
        terrain_params(terrain, **{k: tuple(v) if isinstance(v, list) else v for k, v in out.items()})
    except (ValueError, TypeError) as e:
        raise SweepSpecError([f"{where}: {e}"]) from None
    return out


def maneuver_doc(
    name: str, library_dirs: tuple[str | Path, ...] | None = None, allow_paths: bool = True
) -> dict[str, Any]:
    """The document of a maneuver by library name (or path, if allowed), checked: it loads and validates."""
    from planning.maneuver import ManeuverError, find_maneuver
    from planning.maneuver.load import SHIPPED_LIBRARY

    try:
        path = find_maneuver(name, library_dirs or (SHIPPED_LIBRARY,), allow_paths=allow_paths)
        mtime = path.stat().st_mtime_ns
    except (ManeuverError, OSError) as e:
        raise SweepSpecError([f"run.maneuver: {e}"]) from None
    return json.loads(_checked_doc(str(path.resolve()), mtime, name))


@lru_cache(maxsize=64)
def _checked_doc(path: str, mtime_ns: int, name: str) -> str:
    from planning.maneuver import ManeuverError, load_maneuver, validate_maneuver
    from planning.maneuver.load import read_source

    try:
        data, _, _ = read_source(Path(path))
        m = load_maneuver(data)
    except ManeuverError as e:
        raise SweepSpecError([f"run.maneuver: {e}"]) from None
    result = validate_maneuver(m)
    if not result.ok:
        raise SweepSpecError([f"run.maneuver: {name} has failures: {'; '.join(map(str, result.failures))}"])
    return json.dumps(data, sort_keys=True)


@lru_cache(maxsize=16)
def _check_robot(name: str) -> None:
    from planning.robot import RobotDescriptionError, load_robot

    try:
        load_robot(name)
    except (RobotDescriptionError, OSError, ValueError) as e:
        raise SweepSpecError([f"robot: {e}"]) from None


ManeuverSource = Callable[[str], dict[str, Any]]


def _params(spec: SweepSpec, coords: dict[str, Any], index: int, maneuvers: ManeuverSource) -> dict[str, Any]:
    """The run parameters of the case at these axis coordinates."""
    d = spec.defaults
    runs = {r.name(): r for r in spec.runs()}
    run = runs[coords["run"]] if "run" in coords else spec.runs()[0]
    maneuver = coords.get("maneuver", run.maneuver)
    robot = str(coords.get("robot", d.robot))
    _check_robot(robot)
    terrain = str(coords.get("terrain", d.terrain))
    tparams = dict(d.terrain_params)
    tparams.update({k.removeprefix("terrain."): v for k, v in coords.items() if k.startswith("terrain.")})
    tparams = _terrain_params(terrain, tparams, "axes.terrain" if "terrain" in coords else "defaults.terrain")
    push = {
        "t_s": _number("push_t_s", coords.get("push_t_s", d.push.t_s)),
        "duration_s": _number("push_duration_s", coords.get("push_duration_s", d.push.duration_s)),
        "impulse_ns": _number("push_impulse_ns", coords.get("push_impulse_ns", d.push.impulse_ns)),
        "direction_deg": _number(
            "push_direction_deg", coords.get("push_direction_deg", d.push.direction_deg)
        ),
    }
    if push["duration_s"] <= 0 or push["t_s"] < 0 or push["impulse_ns"] < 0:
        raise SweepSpecError(["axes.push_*: push times must be ≥ 0, durations > 0, impulses ≥ 0"])
    if push["impulse_ns"] == 0:  # no push: the same run whatever its time and direction (and one key)
        push = {"t_s": 0.0, "duration_s": 0.1, "impulse_ns": 0.0, "direction_deg": 0.0}
    seed = coords.get("seed", d.seed)
    if isinstance(seed, bool) or not isinstance(seed, (int, float)) or seed < 0 or float(seed) != int(seed):
        raise SweepSpecError([f"axes.seed: {seed!r} is not a whole number ≥ 0"])
    friction = coords.get("friction", d.friction)
    if friction is not None and not (0 < _number("friction", friction) <= 3):
        raise SweepSpecError([f"axes.friction: {friction} must be in (0, 3]"])
    noise = coords.get("sensor_noise_m", d.sensor_noise_m)
    if noise is not None and not (0 <= _number("sensor_noise_m", noise) <= 1):
        raise SweepSpecError([f"axes.sensor_noise_m: {noise} must be in [0, 1] m"])
    p: dict[str, Any] = {
        "kind": "maneuver" if maneuver is not None and run.walk is None and run.probe is None else "walk",
        "robot": robot,
        "terrain": terrain,
        "terrain_params": tparams,
        "seed": int(seed),
        "duration_s": d.duration_s,
        "push": push,
        "start": [
            _number(a, coords.get(a, getattr(d, a))) for a in ("start_x_m", "start_y_m", "start_yaw_rad")
        ],
        "friction": None if friction is None else float(friction),
        "sensor_noise_m": None if noise is None else float(noise),
    }
    if run.probe is not None:
        p["kind"] = "probe"
        p["probe"] = {**run.probe.model_dump(), "index": index}
    elif p["kind"] == "maneuver":
        p["maneuver"] = maneuvers(str(maneuver))
    else:
        from planning.steps.gait import GAIT_NAMES

        assert run.walk is not None
        w = run.walk.model_dump()
        if w["speed_mps"] is None:
            del w["speed_mps"]  # (the default leaves the case's parameters, and so its key, as they were)
        else:
            from planning.sim.run import check_terrain_speed

            why = check_terrain_speed(float(w["speed_mps"]), terrain)
            if why is not None:
                raise SweepSpecError([f"run.walk.speed_mps: {why}"])
        if w["descend_backward"] is None:
            del w["descend_backward"]  # (as speed_mps: the cases of specs without it keep their keys)
        elif w["descend_backward"] and (w["goal"] is None or terrain == "flat"):
            raise SweepSpecError(["run.walk.descend_backward: needs a goal (run.walk.goal) and a terrain"])
        if w["gait"] not in GAIT_NAMES or w["gait"] == "stand":
            raise SweepSpecError([f"run.walk.gait: unknown gait {w['gait']!r}"])
        dx = _number("goal_dx_m", coords.get("goal_dx_m", d.goal_dx_m))
        dy = _number("goal_dy_m", coords.get("goal_dy_m", d.goal_dy_m))
        if w["goal"] == "terrain":
            w["goal_offset"] = [_clean(dx), _clean(dy)]  # the terrain's goal is known once it is built
        elif w["goal"] is not None:
            w["goal"] = [_clean(w["goal"][0] + dx), _clean(w["goal"][1] + dy)]
        elif dx or dy:
            raise SweepSpecError(["axes.goal_*: goal offsets need run.walk.goal"])
        p["walk"] = w
    return p


def expand(spec: SweepSpec, maneuvers: ManeuverSource | None = None) -> list[dict[str, Any]]:
    """The sweep's cases in order ({"key", "params", "axes"}). Cases at different coordinates may be the same run
    (no push in every direction; a random draw repeating an earlier one): they share a key, run once, and count
    once in any one cell of the summary. Raises SweepSpecError on a value no run can take.

    maneuvers: gives a maneuver's document by the name a run or axis gives (default: maneuver_doc, the shipped
    library or a path)."""
    out = []
    for i, coords in enumerate(_coordinates(spec)):
        params = _params(spec, coords, i, maneuvers or maneuver_doc)
        out.append({"key": case_key(params), "params": params, "axes": coords})
    return out


# ---- running --------------------------------------------------------------------------------------------------
def _probe(p: dict[str, Any]) -> dict[str, Any]:
    pr = p["probe"]
    t0 = time.perf_counter()
    if pr.get("mark_dir"):
        Path(pr["mark_dir"], str(os.getpid())).write_text(str(pr["index"]))
    if pr["sleep_s"] > 0:
        time.sleep(pr["sleep_s"])
    fail = pr["fail_every"] > 0 and (pr["index"] + 1) % pr["fail_every"] == 0
    wall = time.perf_counter() - t0
    return {
        "mode": "probe",
        "success": not fail,
        "failure_reason": f"probe case {pr['index']} fails by design (fail_every {pr['fail_every']})"
        if fail
        else None,
        "fell": False,
        "duration_s": 0.0,
        "timing": {"wall_s": round(wall, 4), "rtf": None},
        "pid": os.getpid(),
    }


def run_case(params: dict[str, Any]) -> dict[str, Any]:
    """Runs one case headless (the same path as `footfall run` and `footfall walk`) and returns its run report."""
    if params["kind"] == "probe":
        return _probe(params)
    if params["kind"] == "maneuver":
        from planning.maneuver import parse_maneuver
        from planning.sim.run import run_maneuver

        return run_maneuver(parse_maneuver(params["maneuver"]), _run_options(params))
    from planning.sim.run import run_walk

    return run_walk(*_walk_of(params))


def rerun_walk_case(params: dict[str, Any], trace_every_s: float | None = None) -> tuple[dict[str, Any], Any]:
    """Runs one walk case as run_case does, keeping a per-leg trace sampled every trace_every_s (None: none);
    gives its run report and the trace (planning.sim.trace.LegTrace, or None). `footfall sweep --rerun`."""
    if params.get("kind") != "walk":
        raise ValueError(f"a {params.get('kind')!r} case: only walk cases keep a trace")
    from planning.sim.run import WalkSession

    session = WalkSession(*_walk_of(params), trace_every_s=trace_every_s)
    return session.run(), session.trace


def _run_options(params: dict[str, Any]) -> Any:
    """The case's RunOptions: terrain, push, duration, robot, layout seed, start, friction."""
    from planning.sim.run import RunOptions
    from planning.sim.world import Push
    from planning.terrain.spec import spec_from_mapping

    pu = params["push"]
    pushes = []
    if pu["impulse_ns"] > 0:
        f = pu["impulse_ns"] / pu["duration_s"]
        a = math.radians(pu["direction_deg"])
        pushes.append(Push(pu["t_s"], (f * math.cos(a), f * math.sin(a), 0.0), pu["duration_s"]))
    terrain = spec_from_mapping({"name": params["terrain"], "params": params["terrain_params"]}).text()
    return RunOptions(
        terrain=terrain,
        pushes=pushes,
        duration_s=params["duration_s"],
        robot=params["robot"],
        seed=params["seed"],
        start_offset=(params["start"][0], params["start"][1], params["start"][2]),
        friction=params["friction"],
    )


def _walk_of(params: dict[str, Any]) -> tuple[Any, Any]:
    """A walk case's WalkCommand and RunOptions."""
    from planning.sim.run import WalkCommand

    opts = _run_options(params)
    w = params["walk"]
    goal = w["goal"]
    if goal == "terrain":
        from planning.terrain.spec import load_terrain

        gx, gy = load_terrain(opts.terrain, seed=params["seed"]).goal_xy
        dx, dy = w.get("goal_offset", (0.0, 0.0))
        goal = (gx + dx, gy + dy)
    cmd = WalkCommand(
        vx=w["vx"],
        vy=w["vy"],
        yaw_rate=w["yaw_rate"],
        gait=w["gait"],
        goal=None if goal is None else (goal[0], goal[1]),
        centroidal=w["solver"] == "centroidal",
        terrain_aware=False if w["maps"] == "off" else None,
        terrain_sensor=w["maps"] == "sensor",
        stop_at_goal=w["stop_at_goal"],
        sensor_noise_m=params["sensor_noise_m"],
        terrain_speed_mps=w.get("speed_mps"),
    )
    if w.get("descend_backward") is not None:  # (absent: WalkCommand's default)
        cmd = dataclasses.replace(cmd, descend_backward=bool(w["descend_backward"]))
    return cmd, opts
