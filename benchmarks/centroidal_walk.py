"""The centroidal solver steering a trot (``footfall walk --solver centroidal``): each tick's work and status.

Reports per tick the ADMM iterations (the work, alike on any machine and load), the CPU time of the solving thread
(preemption by other processes excluded) and the wall time, the statuses, the velocity tracked and the real-time
factor of the whole run. Run: ``python -m benchmarks.centroidal_walk [--vx 0.5] [--duration 10]``.

With ``--peer "COMMAND"`` it also runs a peer controller side by side in the same run (issue 29: the centroidal walk
at >= 3x a convex-MPC peer's real-time factor): the walk unprofiled (its real-time factor in this process's CPU
time), then with every loop stage timed (``benchmarks.loop_profile``: each stage's CPU ms per simulated second, the
centroidal stage beside its bare OSQP time), then the peer as a child process (its CPU time; when its last output
line has ``sim_per_cpu X``, its own loop's figure), then the walk again. docs/agility-notes.md ("Peer comparison")
says which peer and how it is run. ``--rate STAGE=HZ`` (repeatable) runs a loop stage at another rate, e.g.
``--rate step_plan=50 --rate swing=166.7``: an experiment on what the rates cost (the defaults are what the closed-loop
tests establish).
"""

from __future__ import annotations

import argparse
import json
import os
import re
import time
from dataclasses import replace
from typing import Any

import numpy as np

from benchmarks.loop_profile import profile_session
from benchmarks.peer_mpc import peer_side
from planning.sim.run import RunOptions, WalkCommand, WalkSession


def _session(
    vx: float,
    vy: float,
    yaw_rate: float,
    duration_s: float,
    rates: dict[str, float] | None = None,
    problem: dict[str, Any] | None = None,
) -> WalkSession:
    """The walk's session; ``rates`` (stage name → Hz) runs those loop stages at other rates, ``problem`` sets
    fields of the centroidal problem's WalkProblemParams (e.g. horizon_s, max_knots): experiments (the defaults are
    what the closed-loop tests establish)."""
    cmd = WalkCommand(vx, vy, yaw_rate, "trot", centroidal=True, terrain_aware=False)
    session = WalkSession(cmd, RunOptions(duration_s=duration_s))
    if problem:
        probs = session.controller.problems
        try:
            probs.params = replace(probs.params, **problem)
        except TypeError as e:
            raise ValueError(f"--problem: {e}") from None
    stages = {st.name: st for st in session.loop.stages}
    for name, hz in (rates or {}).items():
        if name not in stages:
            raise ValueError(f"--rate: no loop stage {name!r} (stages: {', '.join(stages)})")
        if not hz > 0.0:
            raise ValueError(f"--rate {name}: needs a rate above 0 Hz, got {hz}")
        stages[name].rate_hz = hz
    return session


def run(
    vx: float = 0.5,
    vy: float = 0.0,
    yaw_rate: float = 0.0,
    duration_s: float = 10.0,
    rates: dict[str, float] | None = None,
    problem: dict[str, Any] | None = None,
) -> dict[str, Any]:
    """Runs the walk headless and returns the solver's per-tick figures."""
    session = _session(vx, vy, yaw_rate, duration_s, rates, problem)
    t0, c0 = time.perf_counter(), time.thread_time()
    report = session.run(None)
    wall, cpu_s = time.perf_counter() - t0, time.thread_time() - c0
    driver = session.controller.driver
    stage = report["solver"]
    its = np.array(driver.qp_iterations[1:])  # the first tick is a cold start (not bounded)
    cpu = np.array(driver.tick_cpu_ms[1:])
    p50 = float(np.median(cpu))
    return {
        "command": [vx, vy, yaw_rate],
        "ticks": driver.solver_ticks,
        "statuses": driver.statuses,
        "fallback_ticks": driver.fallback_ticks,
        "iterations_p50_p99_max": [float(np.median(its)), float(np.percentile(its, 99)), int(its.max())],
        "tick_cpu_ms_p50_p99_max": [
            round(p50, 2),
            round(float(np.percentile(cpu, 99)), 2),
            round(float(cpu.max()), 2),
        ],
        "ticks_over_3x_p50_cpu": int(np.sum(cpu > 3.0 * p50)),
        "tick_wall_ms_p50_p99": [stage["tick_ms_p50"], stage["tick_ms_p99"]],
        "mean_velocity": report["mean_velocity"],
        "velocity_tracking_rms": report["velocity_tracking_rms"],
        "fell": report["fell"],
        "real_time_factor": round(duration_s / wall, 3),
        "real_time_factor_cpu": round(duration_s / cpu_s, 3),
        "load_average": [round(x, 1) for x in os.getloadavg()],
    }


_PEER_LOOP = re.compile(r"sim_per_cpu\s+([0-9.]+)")


def beside_peer(
    peer_cmd: str,
    peer_seconds: float,
    vx: float = 0.5,
    duration_s: float = 10.0,
    rates: dict[str, float] | None = None,
    problem: dict[str, Any] | None = None,
) -> dict[str, Any]:
    """The centroidal walk and a peer in one run: each one's real-time factor in CPU time (simulated seconds per
    CPU second), their ratio, and where the walk's CPU goes (each stage beside the bare solver's time)."""
    ours = run(vx, duration_s=duration_s, rates=rates, problem=problem)
    prof = profile_session(_session(vx, 0.0, 0.0, duration_s, rates, problem))
    prof.pop("report")
    peer = peer_side(peer_cmd, peer_seconds)
    m = _PEER_LOOP.search(peer["last_line"])
    peer_rtf = float(m.group(1)) if m else peer["real_time_factor_cpu"]
    ours2 = run(
        vx, duration_s=duration_s, rates=rates, problem=problem
    )  # again after the peer: the load may have changed meanwhile
    rtf = min(ours["real_time_factor_cpu"], ours2["real_time_factor_cpu"])
    parts = prof["cpu_ms_per_simulated_s"]
    return {
        "date_utc": time.strftime("%Y-%m-%d %H:%M", time.gmtime()),
        "footfall_real_time_factor_cpu": [ours["real_time_factor_cpu"], ours2["real_time_factor_cpu"]],
        "footfall_real_time_factor_wall": [ours["real_time_factor"], ours2["real_time_factor"]],
        "footfall_tick_cpu_ms_p50_p99_max": [
            ours["tick_cpu_ms_p50_p99_max"],
            ours2["tick_cpu_ms_p50_p99_max"],
        ],
        "footfall_statuses": ours["statuses"],
        "footfall_mean_velocity": ours["mean_velocity"],
        "peer_real_time_factor_cpu": peer_rtf,
        "peer_timed": "its loop (own timer)" if m else "whole child process",
        "peer": peer,
        "ratio_cpu": round(rtf / peer_rtf, 2) if peer["returncode"] == 0 else None,
        "goal_ratio": 3.0,
        "stage_cpu_ms_per_simulated_s": parts,
        # each stage that calls OSQP beside its bare solver time (the product's rule: overhead visible)
        "stage_over_bare_osqp": {
            k.removesuffix(".osqp"): round(parts[k.removesuffix(".osqp")] / v, 2)
            for k, v in parts.items()
            if k.endswith(".osqp") and v > 0.0
        },
        "load_average": [round(x, 1) for x in os.getloadavg()],
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--vx", type=float, default=0.5)
    ap.add_argument("--vy", type=float, default=0.0)
    ap.add_argument("--yaw-rate", type=float, default=0.0)
    ap.add_argument("--duration", type=float, default=10.0)
    ap.add_argument("--peer", default=None, help="a command that simulates --peer-seconds of the peer's trot")
    ap.add_argument("--peer-seconds", type=float, default=5.0)
    ap.add_argument(
        "--rate",
        action="append",
        default=[],
        metavar="STAGE=HZ",
        help="run a loop stage at another rate (step_plan, swing, balance, centroidal); an experiment",
    )
    ap.add_argument(
        "--problem",
        action="append",
        default=[],
        metavar="FIELD=VALUE",
        help="a field of the centroidal problem's WalkProblemParams, e.g. horizon_s=0.4 max_knots=10; an experiment",
    )
    a = ap.parse_args()
    problem: dict[str, Any] = {}
    for item in a.problem:
        name, _, val = item.partition("=")
        try:
            problem[name] = int(val) if name == "max_knots" else float(val)
        except ValueError:
            ap.error(f"--problem {item!r}: needs FIELD=NUMBER, e.g. horizon_s=0.4")
    rates: dict[str, float] = {}
    for item in a.rate:
        name, _, hz = item.partition("=")
        try:
            rates[name] = float(hz)
        except ValueError:
            ap.error(f"--rate {item!r}: needs STAGE=HZ, e.g. step_plan=50")
    if a.peer is not None:
        print(json.dumps(beside_peer(a.peer, a.peer_seconds, a.vx, a.duration, rates, problem), indent=1))
    else:
        print(json.dumps(run(a.vx, a.vy, a.yaw_rate, a.duration, rates, problem), indent=1))


if __name__ == "__main__":
    main()
