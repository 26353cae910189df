"""A real `footfall serve` process for the tests that need one (signals, worker processes, RSS): started on a free
port, waited for, and cleaned up with every process it started, whatever the test did to it."""

from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
import time
import urllib.request
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any


def children(pid: int) -> set[int]:
    """Returns every descendant process of pid (from /proc)."""
    parents: dict[int, int] = {}
    for d in Path("/proc").iterdir():
        if d.name.isdigit():
            try:
                stat = (d / "stat").read_text()
            except OSError:
                continue
            parents[int(d.name)] = int(stat.rsplit(")", 1)[1].split()[1])
    out: set[int] = set()
    todo = [pid]
    while todo:
        p = todo.pop()
        kids = {c for c, pp in parents.items() if pp == p}
        out |= kids
        todo += list(kids)
    return out


def alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state != "Z"


def call(port: int, method: str, path: str, body: dict | None = None) -> Any:
    req = urllib.request.Request(
        f"http://127.0.0.1:{port}{path}",
        data=None if body is None else json.dumps(body).encode(),
        method=method,
        headers={"Content-Type": "application/json"},
    )
    with urllib.request.urlopen(req, timeout=10) as r:
        return json.loads(r.read())


class Served:
    """The server process: its port, its Popen, and the descendants seen so far (killed at the end if alive)."""

    def __init__(self, port: int, proc: subprocess.Popen[bytes]) -> None:
        self.port = port
        self.proc = proc
        self.seen: set[int] = set()

    def children(self) -> set[int]:
        kids = children(self.proc.pid)
        self.seen |= kids
        return kids

    def call(self, method: str, path: str, body: dict | None = None) -> Any:
        return call(self.port, method, path, body)

    def wait_gone(self, pids: set[int], timeout_s: float = 10.0) -> list[int]:
        """Waits up to timeout_s for pids to exit; returns those still alive."""
        deadline = time.monotonic() + timeout_s
        while any(alive(c) for c in pids) and time.monotonic() < deadline:
            time.sleep(0.1)
        return [c for c in pids if alive(c)]


@contextmanager
def served(data_dir: Path, **env: str) -> Iterator[Served]:
    """Runs `python -m server.cli serve` (studio off, data in data_dir, env added) until it answers /health."""
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        port = sock.getsockname()[1]
    full_env = {**os.environ, "FOOTFALL_STUDIO": "0", "FOOTFALL_DATA_DIR": str(data_dir), **env}
    proc = subprocess.Popen([sys.executable, "-m", "server.cli", "serve", "--port", str(port)], env=full_env,
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)  # fmt: skip
    s = Served(port, proc)
    try:
        deadline = time.monotonic() + 60
        while True:
            try:
                s.call("GET", "/health")
                break
            except OSError:
                assert proc.poll() is None and time.monotonic() < deadline, "the server did not start"
                time.sleep(0.2)
        yield s
    finally:
        if proc.poll() is None:
            s.children()
            proc.terminate()
            try:
                proc.wait(timeout=30)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()
        for c in s.seen:
            if alive(c):
                os.kill(c, signal.SIGKILL)
