"""Issue 24: no 500 from any input; a bad library file never takes the list down; deep nesting is cheap to refuse."""

from __future__ import annotations

from pathlib import Path

import pytest
from fastapi.testclient import TestClient

YAML = {"Content-Type": "application/yaml"}
GOOD = "format: footfall/maneuver@1\nname: {name}\nduration: 2.0\n"
BAD_VALUES = {
    "date": ("duration: 2001-13-45\n", 3),
    "int-tag": ("duration: !!int abc\n", 3),
    "float-tag": ("duration: !!float abc\n", 3),
    "huge-int": ("duration: " + "9" * 5000 + "\n", 3),
}


@pytest.mark.parametrize("kind", sorted(BAD_VALUES))
def test_unreadable_yaml_values_are_a_4xx_naming_the_line(client: TestClient, kind: str) -> None:
    tail, line = BAD_VALUES[kind]
    text = "format: footfall/maneuver@1\nname: bad\n" + tail
    r = client.post("/maneuvers/validate", content=text, headers=YAML)
    assert 400 <= r.status_code < 500, r.text
    body = r.json()
    failures = body.get("failures") or body.get("errors")
    assert failures and failures[0]["line"] == line, body
    assert f"line {line}" in failures[0]["reason"]
    r = client.put("/maneuvers/bad", content=text, headers=YAML)
    assert r.status_code == 422 and r.json()["errors"][0]["line"] == line, r.text


def test_a_bad_file_in_the_library_is_listed_with_its_error(client: TestClient, user_dir: Path) -> None:
    user_dir.mkdir(parents=True, exist_ok=True)
    (user_dir / "good-one.yaml").write_text(GOOD.format(name="good-one"))
    for kind, (tail, _) in BAD_VALUES.items():
        (user_dir / f"bad-{kind}.yaml").write_text("format: footfall/maneuver@1\nname: x\n" + tail)
    r = client.get("/maneuvers")
    assert r.status_code == 200, r.text
    entries = {e["name"]: e for e in r.json()}
    assert entries["good-one"].get("problems") is None and entries["good-one"]["duration"] == 2.0
    for kind in BAD_VALUES:
        (problem,) = entries[f"bad-{kind}"]["problems"]
        assert problem["line"] == 3 and "line 3" in problem["message"]
        r = client.get(f"/maneuvers/bad-{kind}")
        assert r.status_code == 422 and "line 3" in r.json()["detail"], r.text
        assert client.get(f"/maneuvers/bad-{kind}?format=yaml").status_code == 200  # the text, to fix it
        r = client.post("/simulations", json={"maneuver": f"bad-{kind}"})
        assert r.status_code == 422 and "line 3" in r.json()["detail"], r.text


@pytest.mark.parametrize("opener", ["[", "{", "- "])
def test_deep_nesting_is_refused_before_it_is_read(
    client: TestClient, opener: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Refused before the work that makes deep nesting expensive, counted (not timed: CPU time here includes
    other tests' server threads): brackets never reach the YAML parser, and block nesting stops composing at
    MAX_NESTING nodes instead of reading all 100 000 levels."""
    from planning.maneuver import load

    composed: list[int] = []

    class Counting(load._Loader):
        def compose_node(self, parent, index):  # type: ignore[no-untyped-def]
            composed.append(1)
            return super().compose_node(parent, index)

    monkeypatch.setattr(load, "_Loader", Counting)
    head = "format: footfall/maneuver@1\nname: deep\nduration:" + ("\n" if opener == "- " else " ")
    text = head + opener * (200_000 // len(opener))
    r = client.post("/maneuvers/validate", content=text, headers=YAML)
    assert r.status_code == 422, r.text
    assert "nest" in r.json()["errors"][0]["reason"]
    if opener == "- ":
        # the root and three keys, then the levels up to the limit
        assert 0 < len(composed) <= load.MAX_NESTING + 10, len(composed)
    else:
        assert composed == [], "bracket nesting reached the YAML parser"


# ---- item 10: the smaller defects ------------------------------------------------------------------------------
def test_non_utf8_json_body_names_the_body(client: TestClient) -> None:
    for path in ("/sessions", "/simulations"):
        r = client.post(
            path, content=b'{"terrain": "\xff\xfe"}', headers={"Content-Type": "application/json"}
        )
        assert 400 <= r.status_code < 500, r.text
        errors = r.json()["errors"]
        assert errors and errors[0]["field"] == "body", r.text


@pytest.mark.parametrize("value", ["nan", "inf", "-inf"])
def test_idle_timeout_must_be_finite(value: str) -> None:
    from server.settings import Settings, SettingsError

    with pytest.raises(SettingsError, match="FOOTFALL_SESSION_IDLE_S|session_idle_s"):
        Settings.from_env({"FOOTFALL_SESSION_IDLE_S": value})


@pytest.mark.parametrize(
    ("host", "shown"), [("127.0.0.2", "127.0.0.2"), ("::1", "[::1]"), ("0.0.0.0", "127.0.0.1")]
)
def test_banner_shows_the_bound_address(tmp_path: Path, monkeypatch, capsys, host: str, shown: str) -> None:
    import uvicorn

    from server.app import serve

    monkeypatch.setattr(uvicorn, "run", lambda *a, **k: None)
    monkeypatch.setenv("FOOTFALL_ALLOW_OPEN", "1")
    serve(host=host, port=18000, viewer_port=18080, data_dir=tmp_path)
    err = capsys.readouterr().err
    assert f"REST API on http://{shown}:18000" in err and f"studio on http://{shown}:18080" in err, err


def test_empty_token_header_does_not_hide_a_bearer(tmp_path: Path) -> None:
    from server_fakes import FakeSim, fake_runner, make_client

    from server.settings import Settings

    s = Settings(data_dir=tmp_path, api_token="secret-token-1", max_sessions=1)
    for c in make_client(s, sim_factory=FakeSim, sim_runner=fake_runner):
        r = c.post(
            "/sessions", json={}, headers={"X-Footfall-Token": "", "Authorization": "Bearer secret-token-1"}
        )
        assert r.status_code == 201, r.text
        r = c.delete(f"/sessions/{r.json()['id']}", headers={"X-Footfall-Token": "secret-token-1"})
        assert r.status_code in (200, 204)


def test_host_header_is_checked_on_loopback(tmp_path: Path) -> None:
    from server_fakes import FakeSim, fake_runner

    from server.app import create_app
    from server.settings import Settings

    app = create_app(
        Settings(data_dir=tmp_path), sim_factory=FakeSim, sim_runner=fake_runner, check_host=True
    )
    with TestClient(app, base_url="http://127.0.0.1:8000") as c:
        assert c.get("/health").status_code == 200
        assert c.get("/health", headers={"Host": "localhost:8000"}).status_code == 200
        assert c.get("/health", headers={"Host": "[::1]:8000"}).status_code == 200
        r = c.get("/health", headers={"Host": "evil.example:8000"})
        assert r.status_code == 421 and r.json()["errors"][0]["field"] == "Host"
        r = c.put("/maneuvers/x", content=GOOD.format(name="x"), headers={**YAML, "Host": "rebound.example"})
        assert r.status_code == 421
    assert not (tmp_path / "maneuvers" / "x.yaml").exists()


def test_temp_files_of_killed_writes_are_cleaned_at_start(tmp_path: Path) -> None:
    from server_fakes import FakeSim, fake_runner, make_client

    from server.settings import Settings

    s = Settings(data_dir=tmp_path)
    s.user_dir.mkdir(parents=True)
    left = s.user_dir / ".bow-copy.yaml.k2j3h4.tmp"
    left.write_text("format: footfall/maneuver@1\nname: bow-co")  # half a file
    keep = s.user_dir / "mine.yaml"
    keep.write_text(GOOD.format(name="mine"))
    for c in make_client(s, sim_factory=FakeSim, sim_runner=fake_runner):
        assert not left.exists() and keep.exists()
        assert c.get("/maneuvers/mine").status_code == 200


def test_a_queued_simulation_can_be_cancelled(tmp_path: Path) -> None:
    from server_fakes import FakeSim, make_client, slow_runner

    from server.settings import Settings

    s = Settings(data_dir=tmp_path, sim_workers=1, max_queued_simulations=4)
    for c in make_client(s, sim_factory=FakeSim, sim_runner=slow_runner):
        first = c.post("/simulations", json={"maneuver": "stand", "duration": 0.5}).json()["id"]
        second = c.post("/simulations", json={"maneuver": "stand", "duration": 0.5}).json()["id"]
        r = c.delete(f"/simulations/{second}")
        assert r.status_code == 200 and r.json()["status"] == "cancelled", r.text
        assert c.get(f"/simulations/{second}").json()["status"] == "cancelled"
        r = c.delete(f"/simulations/{first}")  # running (or done): too late
        assert r.status_code == 409, r.text
        assert c.delete("/simulations/0123456789abcdef").status_code == 404


# ---- item 3: one validation everywhere -------------------------------------------------------------------------
FLIGHT = "format: footfall/maneuver@1\nname: flight\nduration: 4.0\nevents:\n" + "".join(
    f"  - {{t: {t}, leg: {leg}, type: {kind}}}\n"
    for t, kind in ((1.0, "liftoff"), (3.0, "touchdown"))
    for leg in ("FL", "FR", "RL", "RR")
)  # two seconds with every foot in the air: the rules only warn, the dry solve finds no feasible plan


def test_rest_validate_put_and_cli_agree(client: TestClient, tmp_path: Path, capsys) -> None:
    from server.cli import main

    r = client.post("/maneuvers/validate", content=FLIGHT, headers=YAML)
    assert r.status_code == 200 and not r.json()["ok"], r.text
    rest = {(f["path"], f["line"], f["message"]) for f in r.json()["failures"]}
    assert rest and all("no feasible plan" in m for _, _, m in rest), rest
    r = client.put("/maneuvers/flight", content=FLIGHT, headers=YAML)
    assert r.status_code == 422 and "no feasible plan" in r.json()["detail"], r.text
    assert client.get("/maneuvers/flight").status_code == 404  # not stored
    f = tmp_path / "flight.yaml"
    f.write_text(FLIGHT)
    assert main(["validate", str(f)]) == 2
    cli = {
        line.removeprefix("failure: ")
        for line in capsys.readouterr().out.splitlines()
        if line.startswith("failure")
    }
    assert cli == {f"line {line}: {path}: {message}" for path, line, message in rest}


FOUR_PROBLEMS = """\
format: footfall/maneuver@1
name: four-problems
duration: 3.0
events:
  - {t: 0.5, leg: FX, type: liftoff}
  - {t: .nan, leg: FL, type: liftoff}
  - {t: 1.0, leg: FL, type: touchdown}
  - {t: 2.0, leg: RR, type: liftoff}
  - {t: 1.5, leg: RR, type: touchdown}
  - {t: 3.5, leg: RL, type: liftoff}
  - {t: 3.8, leg: RL, type: touchdown}
"""  # an unknown leg, a NaN, a touchdown before its liftoff, events past the end


def test_rest_reports_every_problem_in_one_pass(client: TestClient) -> None:
    r = client.post("/maneuvers/validate", content=FOUR_PROBLEMS, headers=YAML)
    assert r.status_code == 200 and not r.json()["ok"], r.text
    got = {f["path"] for f in r.json()["failures"]}
    assert got == {"events[0].leg", "events[1].t", "events[4].t", "events[5].t", "events[6].t"}, got
    r = client.put("/maneuvers/four-problems", content=FOUR_PROBLEMS, headers=YAML)
    assert r.status_code == 422 and {e["field"] for e in r.json()["errors"]} == got, r.text


def test_a_405_names_every_method_of_the_path(client: TestClient) -> None:
    r = client.options("/sessions/0123456789abcdef")
    assert r.status_code == 405
    assert set(r.headers["allow"].replace(" ", "").split(",")) == {"GET", "DELETE"}, r.headers
