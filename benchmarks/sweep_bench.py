"""Measurements of `footfall sweep` itself (README "Robustness sweeps"): run as

    python -m benchmarks.sweep_bench backends [--cases 40] [--duration 5]   local vs ray on the same sweep
    python -m benchmarks.sweep_bench cluster [--nodes 4] [--cases 64]        a multi-node Ray cluster on one machine
    python -m benchmarks.sweep_bench trivial [--cases 10000]                 scheduling cost of trivial cases

Each prints one JSON document. Results go to fresh temporary directories (nothing is resumed).
"""

from __future__ import annotations

import argparse
import json
import os
import tempfile
import time
from pathlib import Path
from typing import Any

from planning.sweep import LocalBackend, RayBackend, expand, parse_spec, run_sweep


def _stand_spec(cases: int, duration_s: float) -> Any:
    """`stand` for duration_s, pushed sideways at 1 s by `cases` different impulses from 0.5 to 20 N·s."""
    return parse_spec({"format": "footfall/sweep@1", "name": "bench-stand", "run": {"maneuver": "stand"},
                       "defaults": {"duration_s": duration_s, "push": {"t_s": 1.0}},
                       "axes": {"push_impulse_ns": {"min": 0.5, "max": 20, "count": cases}}})  # fmt: skip


def _probe_spec(cases: int, sleep_s: float) -> Any:
    return parse_spec({"format": "footfall/sweep@1", "name": "bench-probe", "run": {"probe": {"sleep_s": sleep_s}},
                       "axes": {"seed": {"min": 0, "max": cases - 1, "integer": True}}})  # fmt: skip


def _run(spec: Any, backend: Any, cases: list[dict[str, Any]]) -> dict[str, Any]:
    with tempfile.TemporaryDirectory(prefix="footfall-sweep-bench-") as d:
        t0 = time.perf_counter()
        s = run_sweep(spec, backend, Path(d), progress=False, cases=cases)
        wall = time.perf_counter() - t0
        records = [json.loads(p.read_text()) for p in (Path(d) / "cases").glob("*.json")]
    case_wall = sum(r["wall_s"] or 0.0 for r in records)
    return {"wall_s": round(wall, 2), "sum_case_wall_s": round(case_wall, 2), "done": s["overall"]["done"],
            "successes": s["overall"]["successes"], "crashed": s["overall"]["crashed"]}  # fmt: skip


def backends(n_cases: int, duration_s: float, workers: int, again: bool = False) -> dict[str, Any]:
    """The same sweep on local workers and on a local Ray with as many CPUs; overhead per case = (wall × workers −
    the cases' own run time) / cases, and the ratio of the two walls."""
    spec = _stand_spec(n_cases, duration_s)
    cases = expand(spec)
    out: dict[str, Any] = {
        "cases": n_cases,
        "duration_s": duration_s,
        "workers": workers,
        "cpus": os.cpu_count(),
    }
    ray_b = RayBackend(num_cpus=workers)
    t0 = time.perf_counter()
    ray_b.init()
    out["ray_init_s"] = round(time.perf_counter() - t0, 2)
    runs: list[tuple[str, Any]] = [("local", LocalBackend(workers)), ("ray", ray_b)]
    if again:  # local once more after ray: how much the machine's load moved meanwhile
        runs.append(("local_again", LocalBackend(workers)))
    for name, b in runs:
        r = _run(spec, b, cases)
        r["overhead_per_case_s"] = round((r["wall_s"] * workers - r["sum_case_wall_s"]) / n_cases, 3)
        out[name] = r
    if again:
        local_wall = (out["local"]["wall_s"] + out["local_again"]["wall_s"]) / 2
    else:
        local_wall = out["local"]["wall_s"]
    out["ray_over_local"] = round(out["ray"]["wall_s"] / local_wall, 3)
    return out


def cluster(max_nodes: int, n_cases: int, sleep_s: float) -> dict[str, Any]:
    """Throughput of sleep probes (no CPU used) on a Ray cluster of 1..max_nodes nodes of 1 CPU each, simulated on
    this machine with ray.cluster_utils.Cluster: what the scheduler gives per added node."""
    import ray
    from ray.cluster_utils import Cluster

    spec = _probe_spec(n_cases, sleep_s)
    cases = expand(spec)
    out: dict[str, Any] = {"cases": n_cases, "sleep_s": sleep_s, "by_nodes": {}}
    c = Cluster(initialize_head=True, head_node_args={"num_cpus": 1})
    try:
        for n in range(1, max_nodes + 1):
            if n > 1:
                c.add_node(num_cpus=1)
            c.wait_for_nodes()
            if ray.is_initialized():
                ray.shutdown()
            ray.init(address=c.address, include_dashboard=False, log_to_driver=False)
            deadline = time.time() + 60
            while ray.cluster_resources().get("CPU", 0) < n and time.time() < deadline:
                time.sleep(0.2)
            _run(spec, RayBackend(address=c.address), cases[: 2 * n])  # warm the workers up
            r = _run(spec, RayBackend(address=c.address), cases)
            r["cases_per_s"] = round(n_cases / r["wall_s"], 2)
            r["ideal_cases_per_s"] = round(n / sleep_s, 2)
            out["by_nodes"][n] = r
    finally:
        ray.shutdown()
        c.shutdown()
    return out


def trivial(n_cases: int, workers: int) -> dict[str, Any]:
    """Probes that do nothing, through both backends: the tool's own cost per case (dispatch, result, store)."""
    spec = _probe_spec(n_cases, 0.0)
    t0 = time.perf_counter()
    cases = expand(spec)
    out: dict[str, Any] = {
        "cases": n_cases,
        "workers": workers,
        "expand_s": round(time.perf_counter() - t0, 2),
    }
    for name, b in (("local", LocalBackend(workers)), ("ray", RayBackend(num_cpus=workers))):
        if name == "ray":
            b.init()  # type: ignore[union-attr]
        r = _run(spec, b, cases)
        r["ms_per_case"] = round(1e3 * r["wall_s"] / n_cases, 3)
        out[name] = r
    return out


def main() -> None:
    p = argparse.ArgumentParser(prog="python -m benchmarks.sweep_bench")
    sub = p.add_subparsers(dest="what", required=True)
    b = sub.add_parser("backends")
    b.add_argument("--cases", type=int, default=40)
    b.add_argument("--duration", type=float, default=5.0)
    b.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    b.add_argument("--again", action="store_true", help="run local once more after ray")
    c = sub.add_parser("cluster")
    c.add_argument("--nodes", type=int, default=4)
    c.add_argument("--cases", type=int, default=64)
    c.add_argument("--sleep", type=float, default=0.5)
    t = sub.add_parser("trivial")
    t.add_argument("--cases", type=int, default=10_000)
    t.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    a = p.parse_args()
    if a.what == "backends":
        out = backends(a.cases, a.duration, a.workers, a.again)
    elif a.what == "cluster":
        out = cluster(a.nodes, a.cases, a.sleep)
    else:
        out = trivial(a.cases, a.workers)
    print(json.dumps(out, indent=2))


if __name__ == "__main__":
    main()
