"""Where the control loop's CPU goes: each stage's CPU time per simulated second, for a walk run headless.

Every stage of the loop, the actuation (stance handler and swing joint commands, every physics step), the state
read, the MuJoCo step and the monitors are timed by this thread's CPU time (``time.thread_time``), so the figures
hold on a shared machine where wall time includes waiting for a core. OSQP's solves and matrix updates are counted
apart inside the stage that calls them (``<stage>.osqp``); the perception stage's scan → maps pipeline by its own
stages (``perception.<stage>``). What is left of the run (the loop's bookkeeping, the recorder, the report) is
``other``.

Run: ``python -m benchmarks.loop_profile`` (every walk: ``footfall walk --vx 0.5 --solver centroidal`` on flat
for 5 s and ``footfall walk --terrain stairs --goal 6,0`` with the sensor for 10 s), ``--walk flat`` or
``--walk stairs`` for one,
``--duration S`` to change the simulated time. docs/agility-notes.md ("Where the loop's CPU goes") has the
figures measured.
"""

from __future__ import annotations

import argparse
import json
import os
import time
from collections import defaultdict
from collections.abc import Callable
from typing import Any

import osqp

from planning.sim.run import RunOptions, WalkCommand, WalkSession

_WALKS: dict[str, tuple[WalkCommand, str, float]] = {
    "flat": (WalkCommand(0.5, 0.0, 0.0, "trot", centroidal=True, terrain_aware=False), "flat", 5.0),
    "stairs": (WalkCommand(0.0, 0.0, 0.0, "trot", goal=(6.0, 0.0)), "stairs", 10.0),
}


class _Clock:
    """Accumulates CPU seconds by name; OSQP calls are charged to the stage running them."""

    def __init__(self) -> None:
        self.cpu_s: dict[str, float] = defaultdict(float)
        self.current = "other"

    def wrap(self, name: str, fn: Callable[..., Any]) -> Callable[..., Any]:
        def timed(*args: Any, **kwargs: Any) -> Any:
            outer = self.current
            self.current = name
            c0 = time.thread_time()
            try:
                return fn(*args, **kwargs)
            finally:
                self.cpu_s[name] += time.thread_time() - c0
                self.current = outer

        return timed


def profile_walk(walk: str, duration_s: float | None = None) -> dict[str, Any]:
    """Runs one walk headless with every loop part timed; returns CPU ms per simulated second by part."""
    cmd, terrain, default_s = _WALKS[walk]
    sim_s = duration_s or default_s
    session = WalkSession(cmd, RunOptions(terrain=terrain, duration_s=sim_s))
    return {"walk": walk, **profile_session(session)}


def profile_session(session: WalkSession) -> dict[str, Any]:
    """Runs a walk session headless with every loop part timed; returns CPU ms per simulated second by part (and
    the walk's report under ``report``)."""
    clock = _Clock()
    loop = session.loop
    for st in loop.stages:
        st.fn = clock.wrap(st.name, st.fn)
    loop.actuate = clock.wrap("actuate", loop.actuate)
    loop.monitors = [clock.wrap("monitors", m) for m in loop.monitors]
    world = loop.world
    world.read_state = clock.wrap("read_state", world.read_state)  # type: ignore[method-assign]
    world.step = clock.wrap("mujoco_step", world.step)  # type: ignore[method-assign]
    # OSQP time, charged to the stage calling it (a class-level wrapper: every solver instance of the run)
    solve0, update0 = osqp.OSQP.solve, osqp.OSQP.update
    osqp_cpu: dict[str, float] = defaultdict(float)

    def charged(fn: Callable[..., Any]) -> Callable[..., Any]:
        def timed(*args: Any, **kwargs: Any) -> Any:
            c0 = time.thread_time()
            try:
                return fn(*args, **kwargs)
            finally:
                osqp_cpu[clock.current] += time.thread_time() - c0

        return timed

    nav = session.pipeline
    perception_cpu: dict[str, float] = defaultdict(float)
    perception = getattr(nav, "perception", None)
    if perception is not None:
        scan_now = perception.scan_now

        def scan_timed(*args: Any, **kwargs: Any) -> Any:
            out = scan_now(*args, **kwargs)
            for k, v in perception.last_stage_cpu_ms.items():
                perception_cpu[k] += v / 1e3
            return out

        perception.scan_now = scan_timed
    osqp.OSQP.solve, osqp.OSQP.update = charged(solve0), charged(update0)  # type: ignore[method-assign]
    try:
        t0 = world.t
        c0 = time.thread_time()
        report = session.run(None)
        total = time.thread_time() - c0
    finally:
        osqp.OSQP.solve, osqp.OSQP.update = solve0, update0  # type: ignore[method-assign]
    t_end = world.t - t0
    parts = dict(clock.cpu_s)
    for stage, s in osqp_cpu.items():
        parts[f"{stage}.osqp"] = s
    for k, s in perception_cpu.items():
        parts[f"perception.{k}"] = s
    top = sum(v for k, v in clock.cpu_s.items() if k != "other")
    parts["other"] = total - top
    per_s = {k: round(1e3 * v / t_end, 1) for k, v in sorted(parts.items(), key=lambda kv: -kv[1])}
    return {
        "simulated_s": t_end,
        "cpu_s": round(total, 2),
        "simulated_s_per_cpu_s": round(t_end / total, 3),
        "cpu_ms_per_simulated_s": per_s,
        "fell": report["fell"],
        "load_average": round(os.getloadavg()[0], 1),
        "report": report,
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--walk", choices=sorted(_WALKS), action="append")
    ap.add_argument("--duration", type=float, default=None)
    a = ap.parse_args()
    for walk in a.walk or sorted(_WALKS):
        out = profile_walk(walk, a.duration)
        out.pop("report")
        print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
