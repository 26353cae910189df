"""Validation on a picked robot over REST: POST /maneuvers/validate?robot=NAME checks the maneuver for that robot
(scaled to it, its reach and torque, the physics check run on it) and says which robot it checked; a name that is
not listed is a 422 naming the field `robot`, never a 500."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import pytest
from fastapi.testclient import TestClient
from server_fakes import fake_runner, make_client

from server.settings import Settings

# A body keyframe 0.70 m up (written for the reference robot): out of the shipped spot's reach (its legs give
# 0.665 m below the hips), within the go1's once scaled to its standing height (0.70 × 0.30 / 0.52 = 0.40 m).
HIGH = {
    "format": "footfall/maneuver@1",
    "name": "reach-up",
    "duration": 3.0,
    "start": "stand",
    "tracks": ["body"],
    "body": [
        {"t": 1.0, "position": [0.0, 0.0, 0.70], "rpy": [0, 0, 0], "weight": 1.0},
        {"t": 2.5, "position": [0.0, 0.0, 0.52], "rpy": [0, 0, 0], "weight": 1.0},
    ],
}


def robot_telling_runner(job: dict[str, Any]) -> dict[str, Any]:
    """A physics check that fails naming the robot it was run on (other jobs as fake_runner)."""
    if not job.get("physics_check"):
        return fake_runner(job)
    return {"maneuver": job["maneuver"]["name"], "success": False, "fell": False, "duration_s": 0.1,
            "failure_reason": f"ran on {job['robot']}", "timing": {"wall_s": 0.1, "rtf": 1.0}, "events": []}  # fmt: skip


@pytest.fixture
def telling(settings: Settings) -> Iterator[TestClient]:
    yield from make_client(settings, sim_runner=robot_telling_runner)


def test_validate_checks_the_picked_robot(client: TestClient) -> None:
    spot = client.post("/maneuvers/validate", json=HIGH)
    assert spot.status_code == 200, spot.text
    assert spot.json()["robot"] == "spot" and not spot.json()["ok"]
    assert any("out of reach" in f["reason"] for f in spot.json()["failures"]), spot.json()
    go1 = client.post("/maneuvers/validate?robot=go1", json=HIGH)
    assert go1.status_code == 200, go1.text
    assert go1.json()["robot"] == "go1" and go1.json()["ok"], go1.json()
    named = client.post("/maneuvers/validate?robot=spot", json=HIGH)
    assert named.json()["robot"] == "spot" and not named.json()["ok"]


def test_validate_refuses_a_robot_not_listed(client: TestClient) -> None:
    for bad in ("nosuch", "../etc/passwd", "x" * 150):
        r = client.post(f"/maneuvers/validate?robot={bad}", json=HIGH)
        assert r.status_code == 422, r.text
        assert [e["field"] for e in r.json()["errors"]] == ["robot"], r.json()
        assert "go1" in r.json()["errors"][0]["reason"]  # the list of robots a client may name


def test_the_physics_check_runs_on_the_picked_robot(telling: TestClient) -> None:
    doc = dict(HIGH, body=[{"t": 1.0, "position": [0.0, 0.0, 0.48], "weight": 1.0}])
    r = telling.post("/maneuvers/validate?robot=go1&physics=true", json=doc)
    assert r.status_code == 200, r.text
    assert r.json()["robot"] == "go1"
    assert r.json()["physics"]["failure_reason"] == "ran on go1", r.json()["physics"]
