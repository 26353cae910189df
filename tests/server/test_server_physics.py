"""Validation's physics check through the REST API: on by default (off in the other service tests' settings),
`?physics=` per request, a fall is a failure on the event responsible, never a 500. The runs are fakes here: the
real physics is tested in tests/maneuver/test_maneuver_physics.py and, through the studio, in test_server_studio.py."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import pytest
from fastapi.testclient import TestClient
from server_fakes import failing_runner, falling_runner, make_client

from server.settings import Settings

STEP = {"format": "footfall/maneuver@1", "name": "one-step", "duration": 3.0,
        "events": [{"t": 1.0, "leg": "FL", "type": "liftoff"},
                   {"t": 1.4, "leg": "FL", "type": "touchdown", "adjust": {"time": 0.05}}]}  # fmt: skip


@pytest.fixture
def falling(settings: Settings) -> Iterator[TestClient]:
    yield from make_client(settings, sim_runner=falling_runner)


def test_physics_is_on_by_default_and_read_from_the_environment() -> None:
    assert Settings().validate_physics is True
    assert Settings.from_env({"FOOTFALL_VALIDATE_PHYSICS": "0"}).validate_physics is False
    assert Settings.from_env({"FOOTFALL_PHYSICS_TIMEOUT_S": "30"}).physics_timeout_s == 30.0


def test_a_fall_fails_validation_on_the_event_responsible(falling: TestClient) -> None:
    r = falling.post("/maneuvers/validate?physics=true", json=STEP)
    assert r.status_code == 200, r.text
    body = r.json()
    assert body["ok"] is False
    assert [f["path"] for f in body["failures"]] == ["events[1]"]
    assert (
        "touchdown of FL at 1.4 s" in body["failures"][0]["reason"]
        and "fell" in body["failures"][0]["reason"]
    )
    ph = body["physics"]
    assert ph["ran"] and ph["fell"] and ph["responsible"]["path"] == "events[1]"
    assert [e["status"] for e in ph["events"]] == [
        "warning",
        "failure",
    ]  # 99% torque at the liftoff: a warning
    # the run is a simulation: it is listed with them
    assert any(s["request"].get("physics_check") for s in falling.get("/simulations").json())
    # without the check, the same maneuver is valid
    r = falling.post("/maneuvers/validate?physics=false", json=STEP)
    assert r.json()["ok"] is True and r.json()["physics"] is None
    # saving runs it too (when asked): refused with the failure; ?physics=false saves
    r = falling.put("/maneuvers/one-step?physics=true", json=STEP, headers={"If-None-Match": "*"})
    assert r.status_code == 422 and "events[1]" in r.text
    r = falling.put("/maneuvers/one-step?physics=false", json=STEP, headers={"If-None-Match": "*"})
    assert r.status_code == 201 and r.json()["physics"] is None


def test_physics_that_cannot_run_is_said_not_a_500(settings: Settings, client: TestClient) -> None:
    r = client.post("/maneuvers/validate", json=STEP)
    assert r.status_code == 200 and r.json()["physics"] is None  # the tests' settings turn it off by default
    r = client.post("/maneuvers/validate?physics=true", json=STEP)
    assert r.status_code == 200, r.text
    assert r.json()["ok"] is True and r.json()["physics"]["ran"] is True and r.json()["physics"]["success"]
    r = client.post("/maneuvers/validate?physics=maybe", json=STEP)
    assert r.status_code == 422 and "physics" in r.text
    bad = {**STEP, "events": [{"t": 1.0, "leg": "FL", "type": "liftoff"}]}  # never lands: no simulation
    r = client.post("/maneuvers/validate?physics=true", json=bad)
    assert r.status_code == 200 and r.json()["ok"] is False and r.json()["physics"]["ran"] is False
    for c in make_client(settings, sim_runner=failing_runner):
        r = c.post("/maneuvers/validate?physics=true", json=STEP)
        assert r.status_code == 200, r.text
        ph: dict[str, Any] = r.json()["physics"]
        assert r.json()["ok"] is True and ph["ran"] is False and "planner gave up" in ph["reason"]
