"""Live sessions at once: each session's real-time factor and the API's latency while they run.

    python -m benchmarks.live_sessions                         # 1 and 4 sessions, worker processes and threads
    python -m benchmarks.live_sessions --sessions 4 --workers process --duration 20 --json out.json

For each (workers, sessions) it starts its own server (REST only, `FOOTFALL_SESSION_WORKERS` = process or thread),
opens the sessions on flat ground in steer mode, steers each to a trot at 0.5 m/s, lets them settle, then for
`--duration` seconds polls GET /health and GET /sessions/{id}/state (round robin, `--hz` requests per second) and
measures: each session's real-time factor (simulated seconds advanced per wall second over the window), the
simulated time it dropped because it fell behind, and the API's p50/p99 latency. The rtf is bounded by 1 (sessions
step in real time, not faster). Also the CPU the server and its descendants (the session workers) used per simulated
second (Linux: /proc), which depends far less on what else the machine runs: 2 cores / that figure is how many
sessions the machine could keep at real time. `--repeat N` alternates the designs N times (the machine's load drifts).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path
from typing import Any

import httpx
import numpy as np

from benchmarks.load_api import local_server

SETTLE_S = 4.0  # after steering: the gait starts and the sessions reach their steady pace, s


def tree_cpu_s(pid: int) -> float | None:
    """CPU seconds (user + system) used so far by process pid and its living descendants (None off Linux)."""
    proc = Path("/proc")
    if not proc.is_dir():
        return None
    stats: dict[int, tuple[int, float]] = {}
    for d in proc.iterdir():
        if d.name.isdigit():
            try:
                f = (d / "stat").read_text().rsplit(")", 1)[1].split()
            except OSError:
                continue
            stats[int(d.name)] = (int(f[1]), (int(f[11]) + int(f[12])) / os.sysconf("SC_CLK_TCK"))
    total, todo = 0.0, [pid]
    while todo:
        p = todo.pop()
        total += stats.get(p, (0, 0.0))[1]
        todo += [c for c, (pp, _) in stats.items() if pp == p]
    return total


def measure(workers: str, n: int, duration_s: float, hz: float) -> dict[str, Any]:
    """Runs one configuration; returns {"workers", "sessions", "rtf": [per session], "dropped_s", "latency_ms"}."""
    env = {"FOOTFALL_SESSION_WORKERS": workers, "FOOTFALL_MAX_SESSIONS": str(max(n, 1))}
    info: dict[str, Any] = {}
    with (
        local_server(startup_timeout_s=120.0, extra_env=env, info=info) as url,
        httpx.Client(base_url=url, timeout=30.0) as c,
    ):
        ids = []
        for _ in range(n):
            r = c.post("/sessions", json={"terrain": "flat", "mode": "steer"})
            r.raise_for_status()
            ids.append(r.json()["id"])
        for sid in ids:
            c.post(f"/sessions/{sid}/steer", json={"vx": 0.5, "gait": "trot"}).raise_for_status()
        time.sleep(SETTLE_S)

        def states() -> list[dict[str, Any]]:
            return [c.get(f"/sessions/{sid}/state").json() for sid in ids]

        before, w0, cpu0 = states(), time.monotonic(), tree_cpu_s(info["pid"])
        lat: dict[str, list[float]] = {"health": [], "state": []}
        errors = 0
        period = 1.0 / hz
        k = 0
        end = w0 + duration_s
        while time.monotonic() < end:
            t0 = time.perf_counter()
            path = "/health" if k % 2 == 0 else f"/sessions/{ids[(k // 2) % n]}/state"
            try:
                ok = c.get(path).status_code == 200
            except httpx.HTTPError:
                ok = False
            dt = (time.perf_counter() - t0) * 1000.0
            errors += 0 if ok else 1
            lat["health" if k % 2 == 0 else "state"].append(dt)
            k += 1
            time.sleep(max(0.0, period - (time.perf_counter() - t0)))
        after, w1, cpu1 = states(), time.monotonic(), tree_cpu_s(info["pid"])
        rtf = [(a["t"] - b["t"]) / (w1 - w0) for a, b in zip(after, before, strict=True)]
        fell = [bool(a.get("fell")) for a in after]
        dropped = [
            a.get("dropped_s", 0.0) - b.get("dropped_s", 0.0) for a, b in zip(after, before, strict=True)
        ]
        sim_s = sum(a["t"] - b["t"] for a, b in zip(after, before, strict=True))
        cpu = None if cpu0 is None or cpu1 is None or sim_s <= 0 else (cpu1 - cpu0) / sim_s
    both = lat["health"] + lat["state"]

    def pct(xs: list[float]) -> dict[str, float]:
        return {"p50": round(float(np.percentile(xs, 50)), 1), "p99": round(float(np.percentile(xs, 99)), 1)}

    return {
        "workers": workers,
        "sessions": n,
        "rtf": [round(x, 3) for x in rtf],
        "rtf_min": round(min(rtf), 3),
        "dropped_s": [round(x, 2) for x in dropped],
        "fell": fell,
        "latency_ms": {"health": pct(lat["health"]), "state": pct(lat["state"]), "all": pct(both)},
        "cpu_s_per_sim_s": None if cpu is None else round(cpu, 3),
        "load_average": round(os.getloadavg()[0], 2),
        "requests": len(both),
        "errors": errors,
    }


def format_rows(rows: list[dict[str, Any]]) -> str:
    out = [f"{'workers':8s} {'sessions':>8s} {'rtf each (min)':>28s} {'API p50 ms':>10s} {'API p99 ms':>10s}  "
           "health p99 / state p99   CPU s per sim s   load"]  # fmt: skip
    for r in rows:
        each = " ".join(f"{x:.2f}" for x in r["rtf"])
        lat = r["latency_ms"]
        out.append(
            f"{r['workers']:8s} {r['sessions']:8d} {each + ' (' + format(r['rtf_min'], '.2f') + ')':>28s} "
            f"{lat['all']['p50']:10.1f} {lat['all']['p99']:10.1f}  {lat['health']['p99']:.1f} / "
            f"{lat['state']['p99']:.1f}   {r['cpu_s_per_sim_s']}   {r['load_average']}"
            + (f"  errors {r['errors']}" if r["errors"] else "")
        )
    return "\n".join(out)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(
        prog="python -m benchmarks.live_sessions", description=__doc__.split("\n")[0]
    )
    ap.add_argument("--sessions", type=int, nargs="+", default=[1, 4])
    ap.add_argument("--workers", nargs="+", choices=["process", "thread"], default=["process", "thread"])
    ap.add_argument("--duration", type=float, default=20.0, help="measuring window per configuration, s")
    ap.add_argument("--hz", type=float, default=20.0, help="API requests per second while measuring")
    ap.add_argument("--repeat", type=int, default=1, help="alternate the designs this many times")
    ap.add_argument("--json", help="write the results here")
    a = ap.parse_args(argv)
    rows = []
    for n in a.sessions:
        for w in a.workers * a.repeat:  # side by side: the designs alternate under the same (drifting) load
            print(f"live sessions: {n} x {w} ...", file=sys.stderr, flush=True)
            rows.append(measure(w, n, a.duration, a.hz))
    print(f"machine: {os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.2f} at the end")
    print(format_rows(rows))
    if a.json:
        with open(a.json, "w") as f:
            json.dump(rows, f, indent=2)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
