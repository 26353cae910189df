"""Load on the REST API: N clients polling a live session's state while it runs a maneuver in real time.

    python -m benchmarks.load_api                      # starts its own server (a subprocess), 20 clients, 30 s
    python -m benchmarks.load_api --url http://host:8000 --token T --clients 20 --duration 30 --hz 10

Measures the requests answered, errors (any non-200 or transport failure), latency percentiles, and whether the
session kept real time: simulated seconds advanced per wall second, and the simulated time it had to drop because
it fell behind (`dropped_s`, 0 when it kept up).
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import socket
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

import httpx
import numpy as np


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


@contextmanager
def local_server(
    startup_timeout_s: float = 60.0,
    extra_env: dict[str, str] | None = None,
    info: dict[str, Any] | None = None,
) -> Iterator[str]:
    """Runs `footfall serve` (REST only, a temporary data dir) in a subprocess; yields its base URL (and puts the
    server's process id in `info["pid"]` when given a dict)."""
    port = _free_port()
    env = {**os.environ, "FOOTFALL_STUDIO": "0", "FOOTFALL_DATA_DIR": tempfile.mkdtemp(prefix="footfall-load-"),
           "FOOTFALL_HOST": "127.0.0.1", "FOOTFALL_MAX_SESSIONS": "2", **(extra_env or {})}  # fmt: skip
    code = "from server.app import serve; import sys; serve(host='127.0.0.1', port=int(sys.argv[1]))"
    proc = subprocess.Popen([sys.executable, "-c", code, str(port)], env=env, stdout=subprocess.DEVNULL,
                            stderr=subprocess.PIPE, text=True)  # fmt: skip
    url = f"http://127.0.0.1:{port}"
    if info is not None:
        info["pid"] = proc.pid
    try:
        end = time.monotonic() + startup_timeout_s
        while True:
            if proc.poll() is not None:
                raise RuntimeError(f"the server exited at start: {proc.stderr.read() if proc.stderr else ''}")
            try:
                if httpx.get(f"{url}/health", timeout=1.0).status_code == 200:
                    break
            except httpx.HTTPError:
                pass
            if time.monotonic() > end:
                raise RuntimeError("the server did not answer /health in time")
            time.sleep(0.2)
        yield url
    finally:
        proc.terminate()
        try:
            proc.wait(10)
        except subprocess.TimeoutExpired:
            proc.kill()


# The polling clients stand in for browsers and scripts on other machines: on the server's own cores they run at
# this nice value (Linux, per thread), so that what they cost is not what slows the session they measure.
POLLER_NICE = 10


def _lower_priority(nice: int) -> None:
    """Lowers the calling thread's scheduling priority by `nice` where the OS has per-thread priorities (Linux)."""
    if nice > 0 and sys.platform.startswith("linux"):
        with contextlib.suppress(OSError):
            os.setpriority(os.PRIO_PROCESS, threading.get_native_id(), nice)


def _poller(
    url: str, sid: str, hz: float, stop: threading.Event, out: dict[str, Any], headers: dict[str, str]
) -> None:
    lat: list[float] = []
    errors: list[str] = []
    period = 1.0 / hz if hz > 0 else 0.0
    _lower_priority(POLLER_NICE)
    with httpx.Client(base_url=url, timeout=5.0, headers=headers) as c:
        while not stop.is_set():
            t0 = time.perf_counter()
            try:
                r = c.get(f"/sessions/{sid}/state")
                if r.status_code != 200:
                    errors.append(f"{r.status_code}: {r.text[:120]}")
                else:
                    r.json()
            except (httpx.HTTPError, ValueError) as e:
                errors.append(f"{type(e).__name__}: {e}")
            dt = time.perf_counter() - t0
            lat.append(dt * 1e3)
            if period:
                time.sleep(max(0.0, period - dt))
    out["latency_ms"] = lat
    out["errors"] = errors


def run_load(
    url: str | None = None,
    *,
    clients: int = 20,
    duration_s: float = 30.0,
    hz: float = 10.0,
    maneuver: str = "bow",
    token: str | None = None,
) -> dict[str, Any]:
    """Returns the load measurements (see the module docstring); starts a local server when `url` is None."""
    if url is None:
        with local_server() as local:
            return run_load(
                local, clients=clients, duration_s=duration_s, hz=hz, maneuver=maneuver, token=token
            )
    headers = {"X-Footfall-Token": token} if token else {}
    with httpx.Client(base_url=url, timeout=30.0, headers=headers) as c:
        r = c.post("/sessions", json={"terrain": "flat", "mode": "maneuver"})
        r.raise_for_status()
        sid = r.json()["id"]
        try:
            c.post(f"/sessions/{sid}/maneuver", json={"maneuver": maneuver}).raise_for_status()
            time.sleep(0.5)  # past the start transient
            s0 = c.get(f"/sessions/{sid}/state").json()
            w0 = time.monotonic()
            stop = threading.Event()
            outs: list[dict[str, Any]] = [{} for _ in range(clients)]
            threads = [threading.Thread(target=_poller, args=(url, sid, hz, stop, outs[i], headers), daemon=True)
                       for i in range(clients)]  # fmt: skip
            for t in threads:
                t.start()
            time.sleep(duration_s)
            stop.set()
            for t in threads:
                t.join(10.0)
            s1 = c.get(f"/sessions/{sid}/state").json()
            wall = time.monotonic() - w0
        finally:
            c.delete(f"/sessions/{sid}")
    lat = (
        np.concatenate([np.asarray(o.get("latency_ms", []), dtype=float) for o in outs])
        if outs
        else np.zeros(0)
    )
    errors = [e for o in outs for e in o.get("errors", [])]
    sim_advanced = float(s1["t"]) - float(s0["t"])
    return {
        "clients": clients,
        "duration_s": round(wall, 2),
        "poll_hz_per_client": hz,
        "requests": int(lat.size),
        "requests_per_s": round(lat.size / wall, 1) if wall > 0 else None,
        "errors": len(errors),
        "error_samples": errors[:5],
        "latency_ms": {
            "p50": round(float(np.percentile(lat, 50)), 2) if lat.size else None,
            "p99": round(float(np.percentile(lat, 99)), 2) if lat.size else None,
            "max": round(float(lat.max()), 2) if lat.size else None,
        },
        "session": {
            "sim_advanced_s": round(sim_advanced, 3),
            "realtime_ratio": round(sim_advanced / wall, 4) if wall > 0 else None,
            "dropped_s": round(float(s1.get("dropped_s", 0.0)) - float(s0.get("dropped_s", 0.0)), 3),
            "status": s1.get("status"),
            "fell": s1.get("fell"),
        },
    }


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--url", help="a running server (default: start one)")
    p.add_argument("--token", help="API token (X-Footfall-Token) if the server needs one")
    p.add_argument("--clients", type=int, default=20)
    p.add_argument("--duration", type=float, default=30.0, help="seconds of polling")
    p.add_argument(
        "--hz", type=float, default=10.0, help="polls per second per client (0: as fast as possible)"
    )
    p.add_argument("--maneuver", default="bow")
    a = p.parse_args(argv)
    result = run_load(
        a.url, clients=a.clients, duration_s=a.duration, hz=a.hz, maneuver=a.maneuver, token=a.token
    )
    print(json.dumps(result, indent=2))
    ok = result["errors"] == 0 and result["session"]["realtime_ratio"] >= 0.97
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
