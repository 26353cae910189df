"""The token rule: open on loopback, a token for writes and driving when bound beyond it; reads stay free."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from fastapi.testclient import TestClient
from server_fakes import FakeSim, fake_runner, files_in, make_client

from server.settings import Settings

TOKEN = "s3cret-token-for-tests"


@pytest.fixture
def locked(tmp_path: Path) -> Iterator[TestClient]:
    s = Settings(host="0.0.0.0", data_dir=tmp_path / "data", api_token=TOKEN, max_sessions=2)
    yield from make_client(s, sim_factory=FakeSim, sim_runner=fake_runner)


WRITES: list[tuple[str, str, Any]] = [
    ("put", "/maneuvers/mine", {"format": "footfall/maneuver@1", "name": "mine", "duration": 2.0}),
    ("delete", "/maneuvers/mine", None),
    ("post", "/simulations", {"maneuver": "stand"}),
    ("post", "/sessions", {"terrain": "flat"}),
    ("post", "/studio/preview", {"maneuver": "bow"}),
]


@pytest.mark.parametrize("method,path,body", WRITES)
def test_writes_need_the_token(locked: TestClient, method: str, path: str, body: Any) -> None:
    kw = {"json": body} if body is not None else {}
    r = getattr(locked, method)(path, **kw)
    assert r.status_code == 401 and r.json()["errors"][0]["field"] == "X-Footfall-Token"
    assert "www-authenticate" in r.headers
    r = getattr(locked, method)(path, headers={"X-Footfall-Token": "wrong-token"}, **kw)
    assert r.status_code == 403


def test_right_token_writes_and_drives(locked: TestClient, tmp_path: Path) -> None:
    h = {"X-Footfall-Token": TOKEN}
    doc = {"format": "footfall/maneuver@1", "name": "mine", "duration": 2.0}
    assert locked.put("/maneuvers/mine", json=doc, headers=h).status_code == 201
    bearer = {"Authorization": f"Bearer {TOKEN}"}
    r = locked.post("/sessions", json={"terrain": "flat"}, headers=bearer)
    assert r.status_code == 201
    sid = r.json()["id"]
    assert locked.post(f"/sessions/{sid}/push", json={"force": [0, 10, 0]}).status_code == 401
    assert locked.post(f"/sessions/{sid}/push", json={"force": [0, 10, 0]}, headers=h).status_code == 200
    assert locked.delete(f"/sessions/{sid}", headers=h).status_code == 204
    assert files_in(tmp_path / "data" / "maneuvers") == [".lock", "mine.yaml"]


def test_reads_are_free(locked: TestClient) -> None:
    for path in ("/health", "/maneuvers", "/maneuvers/bow", "/terrains", "/openapi.json", "/studio", "/"):
        assert locked.get(path).status_code == 200, path
    assert locked.post("/maneuvers/validate", json={"format": "footfall/maneuver@1"}).status_code == 200


def test_bound_beyond_loopback_without_token_refuses_writes(tmp_path: Path) -> None:
    s = Settings(host="0.0.0.0", data_dir=tmp_path / "d")
    assert s.token_required
    for c in make_client(s, sim_factory=FakeSim):
        r = c.post("/sessions", json={"terrain": "flat"})
        assert r.status_code == 403 and "FOOTFALL_API_TOKEN" in r.json()["detail"]


def test_open_when_explicitly_allowed_or_on_loopback(tmp_path: Path) -> None:
    assert not Settings(host="0.0.0.0", allow_open=True).token_required
    assert not Settings(host="127.0.0.1").token_required
    assert not Settings(host="::1").token_required
    assert Settings(host="127.0.0.1", api_token=TOKEN).token_required  # a configured token always applies
