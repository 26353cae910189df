"""The regions climb's step-QP replans, recorded and replayed through two versions of the step QP call by call.

Runs ``footfall walk --terrain stairs --goal 6,0`` headless for ``--duration`` s,
records every ``StepQP.solve`` call, then replays them through the step QP of another checkout (``--before``: the
path of a ``planning/terrain/stepqp.py``, e.g. from ``git archive``) and through this tree's, alternating call by
call in one process, in this thread's CPU time: the load of a shared machine falls on both alike. Prints p50, p99
and the total per version and the largest foothold difference between them.

Run: ``python -m benchmarks.stepqp_replay --before /tmp/old/planning/terrain/stepqp.py --duration 6``.
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import os
import sys
import time
from typing import Any

import numpy as np

import planning.terrain.stepqp as current
from benchmarks.loop_profile import _WALKS
from planning.sim.run import RunOptions, WalkSession


def _load(path: str) -> Any:
    spec = importlib.util.spec_from_file_location("stepqp_before", path)
    if spec is None or spec.loader is None:
        raise SystemExit(f"--before: cannot load {path}")
    mod = importlib.util.module_from_spec(spec)
    sys.modules["stepqp_before"] = mod  # (its dataclasses look their module up)
    spec.loader.exec_module(mod)
    return mod


def replay(before_path: str, duration_s: float) -> dict[str, Any]:
    """Records the regions climb's step-QP calls and replays them through both versions; CPU ms per call."""
    before = _load(before_path)
    calls: list[tuple[Any, ...]] = []
    solve0 = current.StepQP.solve

    def recording(self: current.StepQP, req: Any, maps: Any, regions: Any = None) -> current.StepPlan:
        calls.append((self.params, req, maps, regions))
        return solve0(self, req, maps, regions)

    current.StepQP.solve = recording  # type: ignore[method-assign]
    try:
        cmd, terrain, _ = _WALKS["stairs"]
        WalkSession(cmd, RunOptions(terrain=terrain, duration_s=duration_s)).run(None)
    finally:
        current.StepQP.solve = solve0  # type: ignore[method-assign]
    if not calls:
        raise SystemExit("the walk made no step-QP call")
    params = calls[0][0]
    qp_before, qp_now = before.StepQP(params), current.StepQP(params)
    t_before, t_now = [], []
    diff = 0.0
    for _, req, maps, regions in calls:
        c0 = time.thread_time()
        a = qp_before.solve(req, maps, regions)
        t_before.append(time.thread_time() - c0)
        c0 = time.thread_time()
        b = qp_now.solve(req, maps, regions)
        t_now.append(time.thread_time() - c0)
        diff = max(diff, float(np.max(np.abs(a.footholds - b.footholds))))

    def stats(t: list[float]) -> dict[str, float]:
        ms = np.asarray(t) * 1e3
        return {
            "cpu_p50_ms": round(float(np.percentile(ms, 50)), 3),
            "cpu_p99_ms": round(float(np.percentile(ms, 99)), 3),
            "cpu_total_ms": round(float(ms.sum()), 1),
        }

    return {
        "solves": len(calls),
        "simulated_s": duration_s,
        "before": stats(t_before),
        "now": stats(t_now),
        "max_foothold_difference_m": diff,
        "load_average": round(os.getloadavg()[0], 1),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--before", required=True, help="path of the other version's planning/terrain/stepqp.py")
    ap.add_argument("--duration", type=float, default=6.0)
    a = ap.parse_args()
    print(json.dumps(replay(a.before, a.duration), indent=1))


if __name__ == "__main__":
    main()
