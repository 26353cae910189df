"""Live sessions over REST (on a fake simulation): lifecycle, driving, bad input, cap, reaper, crash isolation."""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

import pytest
from fastapi.testclient import TestClient

from server.settings import Settings


def wait_for(pred: Callable[[], bool], timeout_s: float = 3.0) -> bool:
    end = time.monotonic() + timeout_s
    while time.monotonic() < end:
        if pred():
            return True
        time.sleep(0.02)
    return False


def _new(client: TestClient, **body: Any) -> str:
    r = client.post("/sessions", json=body or {"terrain": "flat", "mode": "maneuver"})
    assert r.status_code == 201, r.text
    return str(r.json()["id"])


def test_session_lifecycle(client: TestClient) -> None:
    sid = _new(client)
    assert any(s["id"] == sid for s in client.get("/sessions").json())
    st = client.get(f"/sessions/{sid}/state").json()
    assert st["status"] == "running" and st["maneuver"] == "stand" and st["terrain"] == "flat"
    assert wait_for(lambda: client.get(f"/sessions/{sid}/state").json()["t"] > 0.1), (
        "the session does not step"
    )
    plan = client.get(f"/sessions/{sid}/plan").json()
    assert plan["overlays"]["body_path"]["kind"] == "polyline"
    assert client.delete(f"/sessions/{sid}").status_code == 204
    assert client.get(f"/sessions/{sid}/state").status_code == 404
    assert client.delete(f"/sessions/{sid}").status_code == 404


def test_session_steps_in_real_time(client: TestClient) -> None:
    sid = _new(client)
    t0 = client.get(f"/sessions/{sid}/state").json()["t"]
    w0 = time.monotonic()
    time.sleep(1.0)
    t1 = client.get(f"/sessions/{sid}/state").json()["t"]
    dw = time.monotonic() - w0
    assert 0.8 * dw <= t1 - t0 <= 1.1 * dw + 0.05


def test_start_maneuver_push_reset_control(client: TestClient) -> None:
    sid = _new(client)
    r = client.post(f"/sessions/{sid}/maneuver", json={"maneuver": "bow", "speed": 2.0})
    assert r.status_code == 200 and r.json()["maneuver"] == "bow" and r.json()["speed"] == 2.0
    r = client.post(f"/sessions/{sid}/push", json={"force": [0.0, 150.0, 0.0], "duration": 0.1})
    assert r.status_code == 200 and r.json()["impulse_ns"] == pytest.approx(15.0)
    assert client.post(f"/sessions/{sid}/control", json={"action": "pause"}).json()["status"] == "paused"
    t_paused = client.get(f"/sessions/{sid}/state").json()["t"]
    time.sleep(0.2)
    assert client.get(f"/sessions/{sid}/state").json()["t"] == t_paused
    assert client.post(f"/sessions/{sid}/control", json={"action": "play"}).json()["status"] == "running"
    r = client.post(f"/sessions/{sid}/reset", json={"terrain": "stairs"})
    assert r.status_code == 200 and r.json()["terrain"] == "stairs" and r.json()["maneuver"] == "stand"
    assert client.post(f"/sessions/{sid}/reset").status_code == 200  # no body: same terrain


def test_a_session_plans_its_walks_on_the_maps_asked_for(client: TestClient) -> None:
    """The scene's own maps by default (a live view keeps real time); the depth sensor's on request, at creation or
    on a reset; the state says which."""
    sid = _new(client, terrain="stones", mode="steer")
    assert client.get(f"/sessions/{sid}/state").json()["maps"] == "truth"
    r = client.post("/sessions", json={"terrain": "stones", "mode": "steer", "maps": "sensor"})
    assert r.status_code == 201 and r.json()["maps"] == "sensor"
    assert client.get(f"/sessions/{r.json()['id']}/state").json()["maps"] == "sensor"
    r = client.post(f"/sessions/{sid}/reset", json={"maps": "sensor"})
    assert r.status_code == 200 and r.json()["maps"] == "sensor" and r.json()["terrain"] == "stones"
    assert (
        client.post(f"/sessions/{sid}/reset", json={"terrain": "clutter"}).json()["maps"] == "sensor"
    )  # kept


def test_steer_without_a_steering_backend_is_409(client: TestClient) -> None:
    sid = _new(client, terrain="flat", mode="steer")
    r = client.post(f"/sessions/{sid}/steer", json={"vx": 0.3, "vy": 0.0, "yaw_rate": 0.1, "gait": "trot"})
    assert r.status_code == 409 and r.json()["detail"] == "steering not available"


@pytest.mark.parametrize(
    "path,body",
    [
        ("/sessions", {"terrain": "lava"}),
        ("/sessions", {"terrain": "flat", "mode": "fly"}),
        ("/sessions", {"terrain": 3}),
        ("/sessions", {"terrain": "flat", "extra": 1}),
        ("/sessions/{sid}/steer", {"vx": "fast"}),
        ("/sessions/{sid}/steer", {"vx": 99.0}),
        ("/sessions/{sid}/steer", {"vx": 0.1, "gait": "moonwalk"}),
        ("/sessions/{sid}/push", {"force": [1.0, 2.0]}),
        ("/sessions/{sid}/push", {"force": [1.0, 2.0, 1e9]}),
        ("/sessions/{sid}/push", {"force": [0, 0, 0], "duration": -1}),
        ("/sessions/{sid}/push", {"force": "strong"}),
        ("/sessions/{sid}/maneuver", {"maneuver": "no-such-maneuver"}),
        ("/sessions/{sid}/maneuver", {"maneuver": "../../etc/passwd"}),
        ("/sessions/{sid}/maneuver", {"maneuver": {"format": "footfall/maneuver@1", "name": "x"}}),
        ("/sessions/{sid}/maneuver", {"maneuver": 42}),
        ("/sessions/{sid}/control", {"action": "rewind"}),
        ("/sessions/{sid}/control", {"speed": 0}),
        ("/sessions/{sid}/reset", {"terrain": "moon"}),
        ("/sessions", {"terrain": "stones", "maps": "lidar"}),
        ("/sessions/{sid}/reset", {"maps": "perfect"}),
    ],
)
def test_bad_session_input_is_4xx_with_the_field(client: TestClient, path: str, body: Any) -> None:
    sid = _new(client)
    before = client.get(f"/sessions/{sid}/state").json()
    r = client.post(path.format(sid=sid), json=body)
    assert 400 <= r.status_code < 500, (path, body, r.status_code, r.text)
    j = r.json()
    assert j["detail"] and all(e.get("reason") for e in j["errors"])
    after = client.get(f"/sessions/{sid}/state").json()
    assert after["maneuver"] == before["maneuver"] and after["terrain"] == before["terrain"]


def test_unknown_session_is_404(client: TestClient) -> None:
    for method, path in [("get", "/sessions/deadbeef/state"), ("get", "/sessions/x/plan"),
                         ("post", "/sessions/nope/push"), ("delete", "/sessions/nope")]:  # fmt: skip
        kw = {"json": {"force": [0, 0, 0]}} if method == "post" else {}
        r = getattr(client, method)(path, **kw)
        assert r.status_code == 404, path


def test_session_cap(client: TestClient, settings: Settings) -> None:
    ids = [_new(client) for _ in range(settings.max_sessions)]
    r = client.post("/sessions", json={"terrain": "flat"})
    assert r.status_code == 429 and "cap" in r.json()["detail"]
    client.delete(f"/sessions/{ids[0]}")
    assert client.post("/sessions", json={"terrain": "flat"}).status_code == 201


def test_crash_is_reported_and_isolated(client: TestClient) -> None:
    bad, good = _new(client), _new(client)
    services = client.app.state.services  # type: ignore[attr-defined]
    services.sessions.get(bad).sim.crash = True
    assert wait_for(lambda: client.get(f"/sessions/{bad}/state").json()["status"] == "crashed")
    st = client.get(f"/sessions/{bad}/state").json()
    assert "boom" in st["error"]
    assert client.post(f"/sessions/{bad}/push", json={"force": [0, 0, 0]}).status_code == 409
    # the other session and the server carry on
    t0 = client.get(f"/sessions/{good}/state").json()["t"]
    assert wait_for(lambda: client.get(f"/sessions/{good}/state").json()["t"] > t0 + 0.1)
    assert client.get("/health").status_code == 200
    # a reset revives the crashed one
    assert client.post(f"/sessions/{bad}/reset").json()["status"] == "running"
    t1 = client.get(f"/sessions/{bad}/state").json()["t"]
    assert wait_for(lambda: client.get(f"/sessions/{bad}/state").json()["t"] > t1 + 0.05)


def test_idle_sessions_are_reaped(client: TestClient) -> None:
    services = client.app.state.services  # type: ignore[attr-defined]
    sid = _new(client)
    s = services.sessions.get(sid)
    s.last_access -= (
        services.settings.session_idle_s + 1.0
    )  # as if nobody had looked for longer than the limit
    # (asking for its state would touch it, so watch the manager instead)
    # (a loaded machine delays the reaper's thread and a worker's exit: seconds, not the 3 s default)
    assert wait_for(lambda: sid not in [x.id for x in services.sessions.list_sessions()], 30.0)
    assert client.get(f"/sessions/{sid}/state").status_code == 404
    assert wait_for(lambda: not s.alive, 30.0)  # its thread (or worker) has ended
