"""The REST API on the real planning stack: a live MuJoCo session and a headless run in a worker process."""

from __future__ import annotations

import time
from collections.abc import Iterator
from pathlib import Path

import pytest
from fastapi.testclient import TestClient
from server_fakes import make_client

from server.settings import Settings


@pytest.fixture(scope="module")
def live(tmp_path_factory: pytest.TempPathFactory) -> Iterator[TestClient]:
    s = Settings(data_dir=Path(tmp_path_factory.mktemp("live")), max_sessions=2, sim_workers=1)
    yield from make_client(s)


def test_live_session_state_and_plan(live: TestClient) -> None:
    started = time.monotonic()
    r = live.post("/sessions", json={"terrain": "flat", "mode": "maneuver"})
    assert r.status_code == 201
    sid = r.json()["id"]
    st = live.get(f"/sessions/{sid}/state").json()
    assert st["body"]["position"][2] == pytest.approx(0.52, abs=0.03)
    assert set(st["joints"]) == {"FL", "FR", "RL", "RR"} and all(st["contacts"].values())
    live.post(f"/sessions/{sid}/maneuver", json={"maneuver": "crouch", "speed": 1.0})
    # it advances (how fast depends on the machine's load: the load test measures real time on a quiet machine)
    end = time.monotonic() + 60.0
    while (st := live.get(f"/sessions/{sid}/state").json())["t"] <= 1.0 and time.monotonic() < end:
        time.sleep(0.1)
    assert st["status"] == "running" and not st["fell"] and st["t"] > 1.0
    # paced to the wall clock: never ahead of real time in total (the windowed rate may exceed 1 for a moment while
    # a session that fell behind on a loaded machine catches up on its owed time, at most MAX_LAG_S)
    assert st["realtime_factor"] > 0.0
    assert st["t"] <= time.monotonic() - started + 0.05
    plan = live.get(f"/sessions/{sid}/plan").json()["overlays"]
    assert {"contact_forces", "body_path", "capture_point"} <= set(plan)
    forces = plan["contact_forces"]["forces_n"]
    total_fz = sum(f[2] for f in forces.values())
    assert 150.0 < total_fz < 500.0  # the feet carry the robot's weight (~32 kg)
    assert len(plan["contact_forces"]["points"]) == 8  # one arrow per stance foot
    report = live.get(f"/sessions/{sid}/report").json()
    assert report["maneuver"] == "crouch" and "solver" in report
    assert live.delete(f"/sessions/{sid}").status_code == 204


def test_headless_simulation_in_a_worker(live: TestClient) -> None:
    r = live.post("/simulations", json={"maneuver": "stand", "duration": 0.6, "pushes": ["0.2:0,40,0:0.1"]})
    assert r.status_code == 202
    jid = r.json()["id"]
    end = time.monotonic() + 90
    while time.monotonic() < end:
        j = live.get(f"/simulations/{jid}").json()
        if j["status"] in ("done", "failed"):
            break
        time.sleep(0.2)
    assert j["status"] == "done", j
    rep = j["report"]
    assert rep["maneuver"] == "stand" and rep["duration_s"] == pytest.approx(0.6, abs=0.01)
    assert rep["pushes"][0]["force_n"] == [0.0, 40.0, 0.0] and isinstance(rep["success"], bool)


def test_steering_walks_the_robot(live: TestClient) -> None:
    r = live.post("/sessions", json={"terrain": "flat", "mode": "maneuver"})
    sid = r.json()["id"]
    try:
        # a session running a maneuver switches to walking on the first command
        r = live.post(f"/sessions/{sid}/steer", json={"vx": 0.4, "vy": 0.0, "yaw_rate": 0.0, "gait": "trot"})
        assert r.status_code == 200, r.text
        assert r.json()["mode"] == "steer" and r.json()["maneuver"] == "walk"
        assert r.json()["command"] == {"vx": 0.4, "vy": 0.0, "yaw_rate": 0.0, "gait": "trot"}
        x0 = live.get(f"/sessions/{sid}/state").json()["body"]["position"][0]
        end = time.monotonic() + 8.0
        while time.monotonic() < end:
            st = live.get(f"/sessions/{sid}/state").json()
            if st["fell"] or st["body"]["position"][0] - x0 > 0.3:
                break
            time.sleep(0.25)
        assert not st["fell"] and st["body"]["position"][0] - x0 > 0.3, st["body"]
        plan = live.get(f"/sessions/{sid}/plan").json()["overlays"]
        steps = plan.get("steps_selected") or plan.get("step_plan")
        assert steps is not None and len(steps["points"]) >= 2, sorted(plan)
        bad = live.post(f"/sessions/{sid}/steer", json={"vx": 0.1, "gait": "moonwalk"})
        assert bad.status_code == 422
        # weight presets change while walking
        r = live.post(f"/sessions/{sid}/steer", json={"vx": 0.4, "gait": "trot", "weights": "stable_body"})
        assert r.status_code == 200 and r.json()["command"]["weights"] == "stable_body"
        bad = live.post(f"/sessions/{sid}/steer", json={"vx": 0.4, "weights": "heavy"})
        assert bad.status_code == 422 and "weights" in bad.text
        # reset keeps steer mode: walking again from the origin with a zero command
        st = live.post(f"/sessions/{sid}/reset").json()
        assert st["mode"] == "steer" and abs(st["body"]["position"][0]) < 0.05
    finally:
        live.delete(f"/sessions/{sid}")


def _overlays_once_drawn(live: TestClient, sid: str, name: str, timeout_s: float = 15.0) -> dict:
    """The session's plan overlays once the overlay `name` has points (or the last ones seen at the timeout)."""
    end = time.monotonic() + timeout_s
    while True:
        plan: dict = live.get(f"/sessions/{sid}/plan").json()["overlays"]
        if plan.get(name, {}).get("points") or time.monotonic() > end:
            return plan
        time.sleep(0.25)


def test_a_steered_session_on_a_terrain_shows_the_terrain_stacks_overlays(live: TestClient) -> None:
    """On the stones, the plan carries what the terrain stack sees and plans: the no-step outline (the pit's
    edges ahead), and once walking toward the stones, where it is headed."""
    r = live.post("/sessions", json={"terrain": "stones", "mode": "steer"})
    assert r.status_code == 201, r.text
    sid = r.json()["id"]
    try:
        live.post(f"/sessions/{sid}/steer", json={"vx": 0.3, "gait": "trot"})
        plan = _overlays_once_drawn(live, sid, "terrain_no_step")
        no_step = plan["terrain_no_step"]
        assert no_step["kind"] == "points" and len(no_step["points"]) > 20, sorted(plan)
        xs = [p[0] for p in no_step["points"]]
        assert min(xs) > 0.5  # the platform the robot stands on is steppable; the outline is the pit's edges
        assert "terrain_body_obstacles" in plan
        assert "depth_cloud" not in plan  # live sessions walk on the scene's maps unless asked otherwise
        st = live.get(f"/sessions/{sid}/state").json()
        assert not st["fell"]
    finally:
        live.delete(f"/sessions/{sid}")


def test_a_session_on_the_depth_sensor_shows_its_scans(live: TestClient) -> None:
    r = live.post("/sessions", json={"terrain": "stones", "mode": "steer", "maps": "sensor"})
    assert r.status_code == 201, r.text
    sid = r.json()["id"]
    try:
        plan = _overlays_once_drawn(live, sid, "depth_cloud")
        cloud = plan["depth_cloud"]["points"]
        assert len(cloud) > 500, sorted(plan)
        assert min(p[0] for p in cloud) < 0.5 < max(p[0] for p in cloud)  # the scan sees around the body
        assert plan["terrain_no_step"]["points"]  # the sensor's own maps, outlined
        assert live.get(f"/sessions/{sid}/state").json()["maps"] == "sensor"
    finally:
        live.delete(f"/sessions/{sid}")
