"""Issue 24 in the studio: tabs take a session slot only when they may drive (never the API's last one), and
the studio validates with the same function as the CLI and REST."""

from __future__ import annotations

from pathlib import Path

from fastapi.testclient import TestClient
from server_fakes import FakeSim, fake_runner
from test_server_studio import wait_for

from benchmarks.studio_stream import FakeBrowser
from server.app import create_app
from server.settings import Settings

TOKEN = "studio-slots-token"


def _studio_sessions(client: TestClient) -> list[dict]:
    return [s for s in client.get("/sessions").json() if s["origin"] == "studio"]


def test_anonymous_tabs_take_no_session_and_the_token_opens_one(tmp_path: Path) -> None:
    s = Settings(data_dir=tmp_path, viewer_port=0, max_sessions=4, api_token=TOKEN)
    app = create_app(s, sim_factory=FakeSim, sim_runner=fake_runner, with_studio=True)
    with TestClient(app, raise_server_exceptions=False) as client:
        studio = app.state.services.studio
        tabs = [FakeBrowser(studio.port) for _ in range(4)]
        try:
            assert wait_for(lambda: client.get("/studio").json()["clients"] == 4, 30.0)
            assert wait_for(
                lambda: all(getattr(c, "ready", False) for c in list(studio.clients.values())), 30.0
            )
            assert _studio_sessions(client) == []
            r = client.post("/sessions", json={}, headers={"X-Footfall-Token": TOKEN})
            assert r.status_code == 201, r.text
            tab = next(iter(studio.clients.values()))
            tab.token = TOKEN  # what the Access field's handler sets
            assert tab.may_drive()
            tab._open_session()
            assert tab.session is not None and len(_studio_sessions(client)) == 1
        finally:
            for t in tabs:
                t.close()


def test_studio_tabs_leave_a_slot_for_the_api(tmp_path: Path) -> None:
    s = Settings(data_dir=tmp_path, viewer_port=0, max_sessions=2)
    app = create_app(s, sim_factory=FakeSim, sim_runner=fake_runner, with_studio=True)
    with TestClient(app, raise_server_exceptions=False) as client:
        studio = app.state.services.studio
        tabs = [FakeBrowser(studio.port) for _ in range(2)]
        try:
            assert wait_for(lambda: client.get("/studio").json()["clients"] == 2, 30.0)
            assert wait_for(
                lambda: all(getattr(c, "ready", False) for c in list(studio.clients.values())), 30.0
            )
            assert len(_studio_sessions(client)) == 1  # the second tab authors without a live robot
            r = client.post("/sessions", json={})
            assert r.status_code == 201, r.text
        finally:
            for t in tabs:
                t.close()


def test_the_studio_validates_as_the_cli_and_rest_do(tmp_path: Path) -> None:
    """Item 3: the studio's check is the same function: a 2 s flight fails its dry solve there too."""
    import yaml
    from test_server_reliability import FLIGHT

    s = Settings(data_dir=tmp_path, viewer_port=0, max_sessions=2)
    app = create_app(s, sim_factory=FakeSim, sim_runner=fake_runner, with_studio=True)
    with TestClient(app, raise_server_exceptions=False) as client:
        studio = app.state.services.studio
        tab = FakeBrowser(studio.port)
        try:
            assert wait_for(lambda: client.get("/studio").json()["clients"] == 1, 30.0)
            sc = next(iter(studio.clients.values()))
            assert wait_for(lambda: getattr(sc, "ready", False), 30.0)
            ed = sc.editor
            ed.document = lambda: (yaml.safe_load(FLIGHT), [], [])
            result = ed.validate_now()
            assert result is not None and not result.ok
            assert result.failures and all("no feasible plan" in p.message for p in result.failures)
            rest = client.post(
                "/maneuvers/validate", content=FLIGHT, headers={"Content-Type": "application/yaml"}
            )
            assert {f["message"] for f in rest.json()["failures"]} == {p.message for p in result.failures}
        finally:
            tab.close()
