"""The maneuver library over REST: read, create, replace (ETags), delete, validate; bad input never writes."""

from __future__ import annotations

import copy
import json
import os
from pathlib import Path
from typing import Any

import pytest
import yaml
from fastapi.testclient import TestClient
from server_fakes import files_in


def _mine(bow: dict[str, Any], name: str = "my-bow") -> dict[str, Any]:
    doc = copy.deepcopy(bow)
    doc["name"] = name
    return doc


def _errors_name(r: Any, field: str) -> bool:
    return any(e["field"] == field or e["field"].startswith(field) for e in r.json()["errors"])


# ---- reading ------------------------------------------------------------------------------------------------------
def test_health(client: TestClient) -> None:
    r = client.get("/health")
    assert r.status_code == 200 and r.json()["status"] == "ok"


def test_list_shows_shipped_maneuvers_read_only(client: TestClient) -> None:
    r = client.get("/maneuvers")
    assert r.status_code == 200
    by_name = {m["name"]: m for m in r.json()}
    assert {"bow", "stand"} <= set(by_name)
    assert by_name["bow"]["source"] == "shipped" and by_name["bow"]["editable"] is False
    assert by_name["bow"]["duration"] == pytest.approx(6.0)


def test_get_json_yaml_download_and_etag(client: TestClient) -> None:
    r = client.get("/maneuvers/bow")
    assert r.status_code == 200 and r.json()["name"] == "bow"
    etag = r.headers["etag"]
    assert etag.startswith('"') and r.headers["x-footfall-source"] == "shipped"
    y = client.get("/maneuvers/bow", params={"format": "yaml", "download": True})
    assert y.headers["content-type"].startswith("application/yaml")
    assert "attachment" in y.headers["content-disposition"]
    assert yaml.safe_load(y.text)["name"] == "bow" and "# rpy in degrees" in y.text  # the file as written
    assert client.get("/maneuvers/bow", headers={"If-None-Match": etag}).status_code == 304


@pytest.mark.parametrize(
    "name,status",
    [
        ("nope", 404),
        ("Bow", 422),
        ("...", 422),
        ("bow.yaml", 422),
        ("a--b", 422),
        ("x" * 65, 422),
        ("%2e%2e", 422),
    ],
)
def test_get_bad_or_unknown_names(client: TestClient, name: str, status: int) -> None:
    r = client.get(f"/maneuvers/{name}")
    assert r.status_code == status
    assert r.json()["detail"]


def test_path_tricks_do_not_reach_outside(client: TestClient, user_dir: Path, bow: dict[str, Any]) -> None:
    for path in ("/maneuvers/../x", "/maneuvers/..%2Fx", "/maneuvers/%2e%2e%2fsecret", "/maneuvers/a%00b"):
        r = client.put(path, json=_mine(bow, "x"))
        assert 400 <= r.status_code < 500, path
    assert files_in(user_dir) in ([], [".lock"])
    assert not (user_dir.parent / "x.yaml").exists()


# ---- writing ------------------------------------------------------------------------------------------------------
def test_create_replace_with_etag_and_conflict(
    client: TestClient, user_dir: Path, bow: dict[str, Any]
) -> None:
    doc = _mine(bow)
    r = client.put("/maneuvers/my-bow", json=doc)
    assert r.status_code == 201, r.text
    etag1 = r.json()["etag"]
    assert r.headers["etag"] == etag1 and (user_dir / "my-bow.yaml").is_file()
    listed = {m["name"]: m for m in client.get("/maneuvers").json()}
    assert listed["my-bow"]["source"] == "user" and listed["my-bow"]["editable"]

    # replacing needs If-Match
    doc["duration"] = 6.5
    assert client.put("/maneuvers/my-bow", json=doc).status_code == 428
    # Alice and Bob both read etag1; Alice saves first, Bob's save is refused
    r = client.put("/maneuvers/my-bow", json=doc, headers={"If-Match": etag1})
    assert r.status_code == 200 and r.json()["created"] is False
    etag2 = r.json()["etag"]
    assert etag2 != etag1
    bob = _mine(bow)
    bob["title"] = "Bob's"
    r = client.put("/maneuvers/my-bow", json=bob, headers={"If-Match": etag1})
    assert r.status_code == 409 and _errors_name(r, "If-Match")
    assert client.get("/maneuvers/my-bow").json()["duration"] == 6.5  # Alice's edit survives
    # create-only refuses an existing name
    assert client.put("/maneuvers/my-bow", json=doc, headers={"If-None-Match": "*"}).status_code == 409
    # delete with a stale ETag is refused, with the current one works
    assert client.delete("/maneuvers/my-bow", headers={"If-Match": etag1}).status_code == 409
    assert client.delete("/maneuvers/my-bow", headers={"If-Match": etag2}).status_code == 204
    assert client.get("/maneuvers/my-bow").status_code == 404
    assert files_in(user_dir) == [".lock"]


def test_yaml_body_is_stored_as_sent(client: TestClient, user_dir: Path) -> None:
    text = (
        (Path(__file__).resolve().parents[2] / "maneuvers" / "bow.yaml")
        .read_text()
        .replace("name: bow", "name: y")
    )
    text = "# my notes survive\n" + text
    r = client.put("/maneuvers/y", content=text, headers={"Content-Type": "application/yaml"})
    assert r.status_code == 201, r.text
    assert (user_dir / "y.yaml").read_text() == text
    assert client.get("/maneuvers/y", params={"format": "yaml"}).text == text


def test_missing_name_is_taken_from_the_url(client: TestClient, bow: dict[str, Any]) -> None:
    doc = _mine(bow)
    del doc["name"]
    r = client.put("/maneuvers/from-url", json=doc)
    assert r.status_code == 201 and client.get("/maneuvers/from-url").json()["name"] == "from-url"


def test_shipped_maneuvers_are_read_only(client: TestClient, bow: dict[str, Any]) -> None:
    r = client.put("/maneuvers/bow", json=bow, headers={"If-Match": "*"})
    assert r.status_code == 403 and _errors_name(r, "name")
    assert client.delete("/maneuvers/bow").status_code == 403
    assert client.get("/maneuvers/bow").status_code == 200


# ---- bad input: 4xx with the field, nothing written -----------------------------------------------------------------
def _bad_bodies(bow: dict[str, Any]) -> list[tuple[str, Any, str]]:
    wrong_type = _mine(bow)
    wrong_type["duration"] = "six"
    negative = _mine(bow)
    negative["body"][0]["t"] = -1.0
    unknown_field = _mine(bow)
    unknown_field["durration"] = 3.0
    bad_leg = _mine(bow)
    bad_leg["events"] = [{"t": 0.5, "leg": "XX", "type": "liftoff"}]
    out_of_order = _mine(bow)  # a touchdown before its liftoff: a validation failure, not a shape error
    out_of_order["events"] = [  # (events may be listed in any order: this touchdown is earlier in time)
        {"t": 1.4, "leg": "RL", "type": "liftoff"},
        {"t": 1.0, "leg": "RL", "type": "touchdown", "at": [-0.4, 0.17, 0.0]},
    ]
    other_name = _mine(bow, "someone-else")
    too_long = _mine(bow)
    too_long["duration"] = 61.0
    many_events = _mine(bow)
    many_events["gaits"] = [{"gait": "trot", "from": 0.0, "to": 59.0, "cycle": 0.1, "duty": 0.5}]
    many_events["duration"] = 60.0
    return [
        ("wrong type", wrong_type, "duration"),
        ("negative time", negative, "body[0].t"),
        ("unknown field", unknown_field, "durration"),
        ("bad leg", bad_leg, "events[0].leg"),
        ("touchdown before liftoff", out_of_order, "events"),
        ("name mismatch", other_name, "name"),
        ("too long", too_long, "duration"),
        ("too many events", many_events, "events"),
        ("not a mapping", [1, 2, 3], ""),
        ("null", None, ""),
    ]


def test_invalid_maneuvers_are_refused_with_the_field(
    client: TestClient, user_dir: Path, bow: dict[str, Any]
) -> None:
    for label, body, field in _bad_bodies(bow):
        r = client.put("/maneuvers/my-bow", json=body)
        assert r.status_code == 422, (label, r.status_code, r.text)
        errs = r.json()["errors"]
        assert errs and all("reason" in e and "field" in e for e in errs), label
        assert any(e["field"].startswith(field) for e in errs), (label, errs)
    assert files_in(user_dir) in ([], [".lock"])


def test_malformed_bodies(client: TestClient, user_dir: Path, settings: Any) -> None:
    cases = [
        (b"{not json", "application/json", 422),
        (b"format: [unclosed", "application/yaml", 422),
        (b"\xff\xfe\x00", "application/json", 400),
        (b"", "application/json", 422),
        (b"<maneuver/>", "application/xml", 415),
        (b'{"duration": NaN}', "application/json", 422),
        (b"[" * 5000 + b"]" * 5000, "application/json", 422),
        (b"x" * (settings.max_body_bytes + 1), "application/json", 413),
    ]
    for body, ctype, status in cases:
        r = client.put("/maneuvers/my-bow", content=body, headers={"Content-Type": ctype})
        assert r.status_code == status, (body[:20], r.status_code, r.text[:200])
        assert r.json()["detail"]
    assert files_in(user_dir) in ([], [".lock"])


def test_oversize_body_without_content_length_is_refused(
    client: TestClient, user_dir: Path, settings: Any
) -> None:
    def chunks() -> Any:
        for _ in range(settings.max_body_bytes // 1000 + 2):
            yield b" " * 1000

    r = client.put("/maneuvers/my-bow", content=chunks(), headers={"Content-Type": "application/json"})
    assert r.status_code == 413
    assert files_in(user_dir) in ([], [".lock"])


# ---- validation -----------------------------------------------------------------------------------------------------
def test_validate_answers_warnings_and_failures(client: TestClient, bow: dict[str, Any]) -> None:
    r = client.post("/maneuvers/validate", json=bow)
    assert r.status_code == 200 and r.json()["ok"] is True and r.json()["failures"] == []
    bad = copy.deepcopy(bow)
    bad["events"] = [{"t": 1.0, "leg": "FL", "type": "touchdown"}]
    r = client.post("/maneuvers/validate", json=bad)
    assert r.status_code == 200
    body = r.json()
    assert body["ok"] is False and body["failures"][0]["path"].startswith("events[0]")
    assert body["failures"][0]["reason"]
    shape = client.post("/maneuvers/validate", json={"format": "footfall/maneuver@1"})
    assert shape.status_code == 200 and {f["field"] for f in shape.json()["failures"]} >= {"name", "duration"}
    assert (
        client.post(
            "/maneuvers/validate", content=b"{", headers={"Content-Type": "application/json"}
        ).status_code
        == 422
    )


def test_validate_accepts_yaml_and_reports_lines(client: TestClient) -> None:
    text = "format: footfall/maneuver@1\nname: y\nduration: 2.0\nevents:\n  - {t: 1.0, leg: FL, type: touchdown}\n"
    r = client.post("/maneuvers/validate", content=text, headers={"Content-Type": "application/yaml"})
    assert r.status_code == 200
    fails = r.json()["failures"]
    assert fails and fails[0]["line"] == 5


# ---- atomic writes ----------------------------------------------------------------------------------------------------
def test_a_crash_during_save_leaves_the_old_file(
    client: TestClient, user_dir: Path, bow: dict[str, Any], monkeypatch: pytest.MonkeyPatch
) -> None:
    doc = _mine(bow)
    r = client.put("/maneuvers/my-bow", json=doc)
    assert r.status_code == 201
    before = (user_dir / "my-bow.yaml").read_bytes()

    def crash(src: Any, dst: Any) -> None:
        raise OSError(28, "No space left on device (simulated crash before the rename)")

    monkeypatch.setattr(os, "replace", crash)
    doc["title"] = "changed"
    r = client.put("/maneuvers/my-bow", json=doc, headers={"If-Match": r.json()["etag"]})
    assert r.status_code >= 500  # a server-side failure, reported, not swallowed
    assert "traceback" not in r.text.lower()
    monkeypatch.undo()
    assert (user_dir / "my-bow.yaml").read_bytes() == before
    assert files_in(user_dir) == [".lock", "my-bow.yaml"]  # no temporary left behind
    assert json.loads(json.dumps(client.get("/maneuvers/my-bow").json()))["title"] == bow["title"]


def test_landing_page_links_studio_docs_and_library(client: TestClient) -> None:
    r = client.get("/")
    assert r.status_code == 200 and r.headers["content-type"].startswith("text/html")
    assert 'href="/docs"' in r.text and 'viewerPort: "8080"' in r.text and "{{" not in r.text
    js = client.get("/static/app.js")
    assert js.status_code == 200 and "/studio/preview" in js.text and "/maneuvers" in js.text
    assert [t["name"] for t in client.get("/terrains").json()][:2] == ["flat", "stairs"]
