"""Queued headless runs: 202 + id, progress, report; failures and dead workers are the job's result; bounded queue."""

from __future__ import annotations

import copy
import time
from collections.abc import Iterator
from typing import Any

import pytest
from fastapi.testclient import TestClient
from server_fakes import dying_runner, failing_runner, make_client, slow_runner

from server.settings import Settings


def wait_done(client: TestClient, job_id: str, timeout_s: float = 60.0) -> dict[str, Any]:
    end = time.monotonic() + timeout_s
    while time.monotonic() < end:
        j = client.get(f"/simulations/{job_id}").json()
        if j["status"] in ("done", "failed"):
            return j
        time.sleep(0.05)
    raise AssertionError(f"simulation {job_id} did not finish")


def test_simulation_runs_and_reports(client: TestClient) -> None:
    r = client.post("/simulations", json={"maneuver": "bow", "terrain": "stairs",
                                          "pushes": [{"t": 1.0, "force": [0, 150, 0]}, "2.0:0,-100,0:0.2"]})  # fmt: skip
    assert r.status_code == 202 and r.headers["location"] == f"/simulations/{r.json()['id']}"
    j = wait_done(client, r.json()["id"])
    assert j["status"] == "done", j
    assert j["report"]["maneuver"] == "bow" and j["report"]["terrain"] == "stairs"
    assert j["report"]["pushes"] == [[1.0, [0.0, 150.0, 0.0], 0.1], [2.0, [0.0, -100.0, 0.0], 0.2]]
    assert j["progress"]["fraction"] == 1.0
    assert any(s["id"] == j["id"] for s in client.get("/simulations").json())


def test_walk_simulation(client: TestClient) -> None:
    r = client.post("/simulations", json={"walk": {"vx": 0.3, "gait": "trot"}, "duration": 2.0})
    assert r.status_code == 202, r.text
    j = wait_done(client, r.json()["id"])
    assert j["status"] == "done" and j["request"]["walk"]["vx"] == 0.3 and j["report"]["maneuver"] == "walk"


def test_walk_maps_field(client: TestClient) -> None:
    """A walk's "maps" (sensor, truth, off) is accepted and kept in the request; an unknown source is a 422 naming
    the field."""
    body = {"walk": {"vx": 0.3, "maps": "truth"}, "terrain": "slope", "duration": 1.0}
    r = client.post("/simulations", json=body)
    assert r.status_code == 202, r.text
    assert wait_done(client, r.json()["id"])["request"]["walk"]["maps"] == "truth"
    bad = client.post("/simulations", json={"walk": {"vx": 0.3, "maps": "lidar"}, "terrain": "slope"})
    assert bad.status_code == 422 and "maps" in bad.text


def test_headless_walk_maps_reach_the_terrain_pipeline() -> None:
    """The worker turns "maps" into the walk's map source: "truth" runs the terrain pipeline on the scene's maps (its
    counters in the report), "off" walks blind (no `navigator` section: the report's name for the pipeline's counters)."""
    from server.engine import run_headless

    job = {"id": "t", "terrain": "slope", "pushes": [], "duration": 1.0, "robot": "spot", "maneuver": None}
    truth = run_headless({**job, "walk": {"vx": 0.3, "maps": "truth", "terrain_speed": 1.0}})
    assert truth["navigator"]["scans"] >= 5
    assert truth["command"]["terrain_speed_mps"] == 1.0
    blind = run_headless({**job, "walk": {"vx": 0.3, "maps": "off"}})
    assert "navigator" not in blind
    assert truth["command"]["descend_backward"] is True  # the default
    fwd = run_headless({**job, "walk": {"goal": [3.0, 0.0], "maps": "truth", "descend_backward": False}})
    assert fwd["command"]["descend_backward"] is False


def test_inline_maneuver(client: TestClient, bow: dict[str, Any]) -> None:
    doc = copy.deepcopy(bow)
    doc["name"] = "inline-bow"
    r = client.post("/simulations", json={"maneuver": doc})
    assert r.status_code == 202
    assert wait_done(client, r.json()["id"])["report"]["maneuver"] == "inline-bow"


@pytest.mark.parametrize(
    "body,status,field",
    [
        ({"maneuver": "no-such"}, 422, "maneuver"),  # the body is wrong, not the URL
        ({"maneuver": "../../x"}, 422, "maneuver"),
        ({"maneuver": {"format": "footfall/maneuver@1"}}, 422, "name"),
        ({"maneuver": "bow", "terrain": "lava"}, 422, "body.terrain"),
        ({"maneuver": "bow", "pushes": ["1.0:0,150"]}, 422, "pushes[0]"),
        ({"maneuver": "bow", "pushes": [{"t": -1, "force": [0, 0, 0]}]}, 422, "body.pushes[0].t"),
        ({"maneuver": "bow", "duration": 0}, 422, "body.duration"),
        ({"maneuver": "bow", "duration": "long"}, 422, "body.duration"),
        ({}, 422, ""),
        ({"maneuver": "bow", "walk": {"vx": 0.3}}, 422, ""),
        ({"walk": {"vx": 0.3, "gait": "moonwalk"}}, 422, "body.walk.gait"),
        ({"walk": {"vx": 9.0}}, 422, "body.walk.vx"),
        (
            {"walk": {"goal": [6, 0], "descend_backward": "sideways"}, "terrain": "stairs"},
            422,
            "body.walk.descend_backward",
        ),
        ({"walk": {"vx": 1.0, "terrain_speed": 1.0}, "terrain": "stairs"}, 422, "body.walk.terrain_speed"),
        ({"walk": {"vx": 1.0, "terrain_speed": 3.0}, "terrain": "slope"}, 422, "body.walk.terrain_speed"),
        (
            {"walk": {"goal": [6, 0], "terrain_pipeline": "modes"}, "terrain": "stairs"},
            422,
            "body.walk.terrain_pipeline",
        ),
    ],
)
def test_bad_simulation_requests(client: TestClient, body: dict[str, Any], status: int, field: str) -> None:
    n_before = len(client.get("/simulations").json())
    r = client.post("/simulations", json=body)
    assert r.status_code == status, r.text
    assert any(e["field"].startswith(field) for e in r.json()["errors"]), r.json()
    assert len(client.get("/simulations").json()) == n_before  # nothing queued


def test_unknown_simulation_is_404(client: TestClient) -> None:
    assert client.get("/simulations/0123456789abcdef").status_code == 404


@pytest.fixture
def failing_client(settings: Settings) -> Iterator[TestClient]:
    yield from make_client(settings, sim_runner=failing_runner)


def test_a_failing_run_is_a_failed_job(failing_client: TestClient) -> None:
    r = failing_client.post("/simulations", json={"maneuver": "stand"})
    j = wait_done(failing_client, r.json()["id"])
    assert j["status"] == "failed" and "planner gave up" in j["error"]


@pytest.fixture
def dying_client(settings: Settings) -> Iterator[TestClient]:
    yield from make_client(settings, sim_runner=dying_runner)


def test_a_dead_worker_fails_its_job_only(dying_client: TestClient) -> None:
    r1 = dying_client.post("/simulations", json={"maneuver": "bow"})
    r2 = dying_client.post("/simulations", json={"maneuver": "stand"})
    j1, j2 = wait_done(dying_client, r1.json()["id"]), wait_done(dying_client, r2.json()["id"])
    assert j1["status"] == "failed" and "crashed" in j1["error"]
    assert j2["status"] == "done", j2  # the pool was rebuilt
    assert dying_client.get("/health").status_code == 200


@pytest.fixture
def slow_client(settings: Settings) -> Iterator[TestClient]:
    yield from make_client(settings, sim_runner=slow_runner)


def test_the_queue_is_bounded(slow_client: TestClient, settings: Settings) -> None:
    answers = [
        slow_client.post("/simulations", json={"maneuver": "stand"})
        for _ in range(settings.max_queued_simulations + 3)
    ]
    codes = [a.status_code for a in answers]
    assert 429 in codes and codes[0] == 202
    refused = next(a for a in answers if a.status_code == 429)
    assert refused.headers["retry-after"] and "queue" in refused.json()["detail"]
    first = answers[0].json()["id"]
    assert slow_client.get(f"/simulations/{first}").json()["status"] in ("running", "done")


def test_live_walk_on_a_terrain_walks_on_the_scenes_maps() -> None:
    """A live (studio) walking session on a terrain runs the terrain pipeline on the scene's own maps, so it keeps real
    time: steered onto the slope it keeps its feet, with maps and no sensor."""
    from server.engine import LiveSim, walk_command

    sim = LiveSim(walk_command(vx=0.4), "slope")
    for _ in range(int(1.0 / sim.dt)):
        sim.step()
    nav = sim.session.pipeline
    assert nav is not None and nav.perception is None and nav.maps is not None
    assert not sim.fell
