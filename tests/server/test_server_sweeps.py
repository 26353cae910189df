"""POST /sweeps: 202 + id, progress, the summary and heat map, cases and their records, cancel; the token rule,
the queue limit, and clear 422s for specs the server will not run."""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

import pytest
from fastapi.testclient import TestClient
from server_fakes import make_client

from planning.robot.model import ASSETS
from server.settings import Settings


def _probe(n: int, **probe: Any) -> dict[str, Any]:
    return {"format": "footfall/sweep@1", "name": "probe", "run": {"probe": {"fail_every": 2, **probe}},
            "axes": {"seed": {"min": 0, "max": n - 1, "integer": True}, "friction": [0.5, 0.8]}}  # fmt: skip


def _wait(
    client: TestClient, sweep_id: str, status: tuple[str, ...] = ("done",), timeout: float = 60
) -> dict:
    t0 = time.time()
    while time.time() - t0 < timeout:
        body = client.get(f"/sweeps/{sweep_id}").json()
        if body["status"] in status:
            return body
        time.sleep(0.1)
    raise AssertionError(f"sweep still {body['status']} after {timeout} s")


def test_a_sweep_runs_and_reports(client: TestClient) -> None:
    r = client.post("/sweeps", json=_probe(3))
    assert r.status_code == 202, r.text
    sid = r.json()["id"]
    assert r.headers["Location"] == f"/sweeps/{sid}" and r.json()["runs"] == 6
    body = _wait(client, sid)
    p = body["progress"]
    assert (p["done"], p["total"], p["crashed"]) == (6, 6, 0)
    s = body["summary"]
    assert s["overall"]["successes"] == 3 and s["overall"]["done"] == 6
    assert s["by"] == ["seed", "friction"] or s["by"] == ["friction"]
    cases = client.get(f"/sweeps/{sid}/cases").json()
    assert len(cases) == 6 and sum(bool(c["success"]) for c in cases) == 3
    rec = client.get(f"/sweeps/{sid}/cases/{cases[0]['key']}").json()
    assert rec["status"] == "done" and rec["report"]["mode"] == "probe"
    png = client.get(f"/sweeps/{sid}/heatmap.png")
    assert png.status_code == 200 and png.content[:8] == b"\x89PNG\r\n\x1a\n"
    assert any(j["id"] == sid for j in client.get("/sweeps").json())
    # the same cases again: found stored, none runs
    again = _wait(client, client.post("/sweeps", json=_probe(3)).json()["id"])
    assert again["progress"]["done"] == 6 and again["summary"]["overall"]["successes"] == 3


def test_cancel_stops_a_sweep(client: TestClient) -> None:
    sid = client.post("/sweeps", json=_probe(20, sleep_s=0.5)).json()["id"]
    time.sleep(1.0)
    r = client.post(f"/sweeps/{sid}/cancel")
    assert r.status_code == 200
    body = _wait(client, sid, ("cancelled",))
    assert body["progress"]["done"] < 40


@pytest.mark.parametrize(
    ("doc", "field"),
    [
        ({"format": "footfall/sweep@1", "name": "x"}, "run"),
        ({**_probe(1), "axes": {"wind": [1]}}, "axes"),
        ({**_probe(1), "run": {"maneuver": "../../etc/passwd"}}, "run.maneuver"),
        ({**_probe(1), "run": {"maneuver": "no-such-maneuver"}}, "run.maneuver"),
        ({**_probe(1), "run": {"probe": {"mark_dir": "/tmp"}}}, "run.probe.mark_dir"),
        ({**_probe(1), "defaults": {"robot": "/etc/robot.yaml"}}, "robot"),
        # a repeat axis is checked like the others (a path that exists, which expansion alone would load)
        (
            {
                **_probe(1),
                "sampling": {"random": 2, "repeat": {"robot": ["spot", str(ASSETS / "spot.yaml")]}},
            },
            "robot",
        ),
        (
            {**_probe(1), "sampling": {"random": 2, "repeat": {"maneuver": ["../x"]}}},
            "sampling.repeat.maneuver",
        ),
        ({**_probe(1), "defaults": {"duration_s": 500}}, "defaults.duration_s"),
        ({**_probe(1), "axes": {"seed": {"min": 0, "max": 5000, "integer": True}}}, "axes"),
        ({**_probe(1), "summary": {"by": ["wind"]}}, "summary.by"),
        ([1, 2], ""),
    ],
)
def test_bad_specs_are_422_naming_the_field(client: TestClient, doc: Any, field: str) -> None:
    r = client.post("/sweeps", json=doc)
    assert r.status_code == 422, r.text
    body = r.json()
    assert body["detail"]
    assert any(e["field"].startswith(field) for e in body["errors"]), body


def test_unknown_sweep_is_404(client: TestClient) -> None:
    assert client.get("/sweeps/nope").status_code == 404
    assert client.post("/sweeps/nope/cancel").status_code == 404


def test_writes_need_the_token_and_the_queue_is_bounded(tmp_path: Path) -> None:
    s = Settings(host="0.0.0.0", data_dir=tmp_path / "data", api_token="tok", max_queued_simulations=1)
    for c in make_client(s):
        assert c.post("/sweeps", json=_probe(1)).status_code == 401
        h = {"X-Footfall-Token": "tok"}
        first = c.post("/sweeps", json=_probe(8, sleep_s=1.0), headers=h)
        assert first.status_code == 202
        codes = [
            c.post("/sweeps", json=_probe(2, sleep_s=0.1 * k), headers=h).status_code for k in range(1, 4)
        ]
        assert 429 in codes
        assert c.post(f"/sweeps/{first.json()['id']}/cancel").status_code == 401
        assert c.post(f"/sweeps/{first.json()['id']}/cancel", headers=h).status_code == 200
