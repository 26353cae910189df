"""The centroidal solver steering a trot (``footfall walk --solver centroidal``): each tick's work and status.

Reports per tick the ADMM iterations (the work, alike on any machine and load), the CPU time of the solving thread
(preemption by other processes excluded) and the wall time, the statuses, the velocity tracked and the real-time
factor of the whole run. Run: ``python -m benchmarks.centroidal_walk [--vx 0.5] [--duration 10]``.
"""

from __future__ import annotations

import argparse
import json
import os
import time
from typing import Any

import numpy as np

from planning.sim.run import RunOptions, WalkCommand, WalkSession


def run(vx: float = 0.5, vy: float = 0.0, yaw_rate: float = 0.0, duration_s: float = 10.0) -> dict[str, Any]:
    """Runs the walk headless and returns the solver's per-tick figures."""
    cmd = WalkCommand(vx, vy, yaw_rate, "trot", centroidal=True, terrain_aware=False)
    session = WalkSession(cmd, RunOptions(duration_s=duration_s))
    t0 = time.perf_counter()
    report = session.run(None)
    wall = time.perf_counter() - t0
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
        "load_average": [round(x, 1) for x in os.getloadavg()],
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--vx", type=float, default=0.5)
    ap.add_argument("--vy", type=float, default=0.0)
    ap.add_argument("--yaw-rate", type=float, default=0.0)
    ap.add_argument("--duration", type=float, default=10.0)
    a = ap.parse_args()
    print(json.dumps(run(a.vx, a.vy, a.yaw_rate, a.duration), indent=1))


if __name__ == "__main__":
    main()
