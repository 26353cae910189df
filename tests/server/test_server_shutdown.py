"""Issue 24, item 6: SIGTERM to a server running a simulation ends every process it started."""

from __future__ import annotations

import signal
import time
from pathlib import Path

import pytest
from served import served


@pytest.mark.skipif(not Path("/proc").is_dir(), reason="reads the process tree from /proc (Linux)")
def test_sigterm_leaves_no_child_running(tmp_path: Path) -> None:
    with served(tmp_path) as s:
        deadline = time.monotonic() + 60
        job = s.call("POST", "/simulations", {"maneuver": "stand", "duration": 60})["id"]
        while s.call("GET", f"/simulations/{job}")["status"] != "running" or not s.children():
            assert time.monotonic() < deadline, "the simulation did not start"
            time.sleep(0.2)
        time.sleep(1.0)  # the worker is importing or simulating
        kids = s.children()
        assert kids, "a simulation runs in a worker process"
        s.proc.send_signal(signal.SIGTERM)
        s.proc.wait(timeout=30)
        assert not s.wait_gone(kids), "a child of the server outlived it"
