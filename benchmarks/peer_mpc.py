"""footfall's centroidal walk beside a peer convex-MPC quadruped controller, in one run on one machine.

The footfall side: ``footfall walk --vx V --solver centroidal`` headless for D seconds (in this process). The peer
side: any command that simulates D seconds of its own trot headless (``--peer-cmd``, run as a child process, its
simulated seconds given by ``--peer-seconds``). Both are timed by wall clock and by CPU time (this process's, the
child's), so the ratio can be read on a shared machine, where wall time includes waiting for the CPU.
Run: ``python -m benchmarks.peer_mpc --peer-cmd "PYTHON RUNNER.py" --peer-seconds 5`` (docs/agility-notes.md says
which peer, and how its example was run headless).
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import shlex
import subprocess
import time
from typing import Any

from planning.sim.run import RunOptions, WalkCommand, WalkSession


def _timing(simulated_s: float, wall: float, cpu: float) -> dict[str, float]:
    """Simulated seconds with the wall and CPU seconds they took, and the real-time factor against each."""
    return {
        "simulated_s": simulated_s,
        "wall_s": round(wall, 2),
        "cpu_s": round(cpu, 2),
        "real_time_factor_wall": round(simulated_s / max(wall, 1e-9), 3),
        "real_time_factor_cpu": round(simulated_s / max(cpu, 1e-9), 3),
    }


def footfall_side(vx: float, duration_s: float) -> dict[str, Any]:
    cmd = WalkCommand(vx, 0.0, 0.0, "trot", centroidal=True, terrain_aware=False)
    session = WalkSession(cmd, RunOptions(duration_s=duration_s))
    w0, c0 = time.perf_counter(), time.process_time()
    report = session.run(None)
    wall, cpu = time.perf_counter() - w0, time.process_time() - c0
    return {
        **_timing(duration_s, wall, cpu),
        "mean_vx": report["mean_velocity"]["vx"],
        "fell": report["fell"],
        "solver_statuses": report["solver"]["statuses"],
    }


def peer_side(command: str, simulated_s: float) -> dict[str, Any]:
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    w0 = time.perf_counter()
    out = subprocess.run(shlex.split(command), capture_output=True, text=True, check=False)
    wall = time.perf_counter() - w0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return {
        **_timing(simulated_s, wall, cpu),
        "returncode": out.returncode,
        "last_line": (out.stdout.strip().splitlines() or [""])[-1][-300:],
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--vx", type=float, default=0.8)
    ap.add_argument("--duration", type=float, default=5.0)
    ap.add_argument("--peer-cmd", required=True)
    ap.add_argument("--peer-seconds", type=float, default=5.0)
    a = ap.parse_args()
    load0 = os.getloadavg()
    ours = footfall_side(a.vx, a.duration)
    peer = peer_side(a.peer_cmd, a.peer_seconds)
    ours2 = footfall_side(a.vx, a.duration)  # again after the peer: the load may have changed meanwhile
    out = {
        "date_utc": time.strftime("%Y-%m-%d %H:%M", time.gmtime()),
        "load_average_before_after": [round(load0[0], 1), round(os.getloadavg()[0], 1)],
        "footfall": [ours, ours2],
        "peer": peer,
        "ratio_cpu": round(
            min(ours["real_time_factor_cpu"], ours2["real_time_factor_cpu"]) / peer["real_time_factor_cpu"], 2
        ),
        "ratio_wall": round(
            min(ours["real_time_factor_wall"], ours2["real_time_factor_wall"])
            / peer["real_time_factor_wall"],
            2,
        ),
    }
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
