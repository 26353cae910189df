"""Live sessions in worker processes (issue 25): the REST session tests again with every session in a child process,
a worker killed with SIGKILL reported and revived, stopped sessions and a killed server leaving no process behind."""

from __future__ import annotations

import os
import signal
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
from fastapi.testclient import TestClient
from served import alive, served
from server_fakes import FakeSim, fake_runner, make_client

# The API's session tests, collected here a second time with this module's `client`: sessions in worker processes.
from test_server_sessions import (  # noqa: F401 - collected by pytest
    _new,
    test_crash_is_reported_and_isolated,
    test_idle_sessions_are_reaped,
    test_session_cap,
    test_session_lifecycle,
    test_start_maneuver_push_reset_control,
    test_steer_without_a_steering_backend_is_409,
    wait_for,
)

from server.settings import Settings

pytestmark = pytest.mark.skipif(not Path("/proc").is_dir(), reason="reads processes from /proc (Linux)")


@pytest.fixture
def settings(tmp_path: Path) -> Settings:
    return Settings(data_dir=tmp_path, session_workers="process", reaper_period_s=0.2, validate_physics=False)


@pytest.fixture
def client(settings: Settings) -> Iterator[TestClient]:
    yield from make_client(settings, sim_factory=FakeSim, sim_runner=fake_runner)


def test_each_session_has_a_worker_of_its_own_and_stopping_reaps_it(client: TestClient) -> None:
    manager = client.app.state.services.sessions  # type: ignore[attr-defined]
    a, b = _new(client), _new(client)
    pids = {manager.get(a).pid, manager.get(b).pid}
    assert len(pids) == 2 and os.getpid() not in pids and all(alive(p) for p in pids)
    assert wait_for(lambda: client.get(f"/sessions/{a}/state").json()["t"] > 0.1, 10.0)
    pa = manager.get(a).pid
    assert client.delete(f"/sessions/{a}").status_code == 204
    assert not alive(pa), "a deleted session's worker is gone (reaped: not even a zombie)"
    assert client.get(f"/sessions/{b}/state").json()["status"] == "running"


def test_a_killed_worker_is_reported_and_never_hangs_a_request(client: TestClient) -> None:
    manager = client.app.state.services.sessions  # type: ignore[attr-defined]
    sid = _new(client)
    s = manager.get(sid)
    old = s.pid
    os.kill(old, signal.SIGKILL)  # as a segfault in MuJoCo would end it
    assert wait_for(lambda: client.get(f"/sessions/{sid}/state").json()["status"] == "crashed", 5.0)
    st = client.get(f"/sessions/{sid}/state").json()
    assert "WorkerDied" in st["error"] and "signal 9" in st["error"]
    for method, path, body in [("post", f"/sessions/{sid}/push", {"force": [10, 0, 0]}),
                               ("get", f"/sessions/{sid}/plan", None), ("post", f"/sessions/{sid}/control", {"action": "pause"})]:  # fmt: skip
        t0 = time.monotonic()
        r = getattr(client, method)(path, **({"json": body} if body is not None else {}))
        assert time.monotonic() - t0 < 2.0, path
        assert r.status_code == 409 and "crashed" in r.json()["detail"], (path, r.text)
    assert client.get("/health").status_code == 200
    assert not alive(old), "the dead worker was reaped"
    # a reset starts a new worker
    assert client.post(f"/sessions/{sid}/reset").json()["status"] == "running"
    assert s.pid != old and alive(s.pid)
    t1 = client.get(f"/sessions/{sid}/state").json()["t"]
    assert wait_for(lambda: client.get(f"/sessions/{sid}/state").json()["t"] > t1 + 0.05, 10.0)


def test_a_killed_server_leaves_no_session_worker(tmp_path: Path) -> None:
    with served(tmp_path, FOOTFALL_SESSION_WORKERS="process") as s:
        for _ in range(2):
            s.call("POST", "/sessions", {"terrain": "flat"})
        kids = s.children()
        assert len(kids) >= 3, "two session workers and the fork server they start from"
        s.proc.send_signal(signal.SIGKILL)  # no shutdown, no exit handlers: the workers see their pipes close
        s.proc.wait(timeout=30)
        assert not s.wait_gone(kids), "a session worker outlived the server"
