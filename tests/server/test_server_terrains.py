"""The REST terrain field (string and structured forms, uploaded files) and /terrain-files: bad input is a 4xx
naming the field, and no request reaches a file outside the terrain directory."""

from __future__ import annotations

import io
import struct
import time
from pathlib import Path

import numpy as np
import pytest
from fastapi.testclient import TestClient

from server.settings import Settings
from server.terrains import terrain_dir


def _npy(a: np.ndarray) -> bytes:
    buf = io.BytesIO()
    np.save(buf, a)
    return buf.getvalue()


def _session_terrain(client: TestClient, terrain) -> tuple[int, dict]:
    r = client.post("/sessions", json={"terrain": terrain})
    body = r.json()
    if r.status_code == 201:
        client.delete(f"/sessions/{body['id']}")
    return r.status_code, body


@pytest.mark.parametrize(
    ("terrain", "expected"),
    [
        ("stairs:riser_m=0.18,tread_m=0.28", "stairs:riser_m=0.18,tread_m=0.28"),
        (
            {"name": "stairs", "params": {"riser_m": 0.18, "railings": False}},
            "stairs:riser_m=0.18,railings=false",
        ),
        ({"name": "stones", "params": {"gap_m": [0.15, 0.2]}}, "stones:gap_m=0.15..0.2"),
        ({"name": "mixed"}, "mixed"),
    ],
)
def test_sessions_take_both_forms(client: TestClient, terrain, expected: str) -> None:
    status, body = _session_terrain(client, terrain)
    assert status == 201, body
    assert body["terrain"] == expected


@pytest.mark.parametrize(
    ("terrain", "reason"),
    [
        ("stairs:riser=0.18", "unknown parameter 'riser'; valid: x_start_m"),
        (
            {"name": "stairs", "params": {"riser_m": 0.5}},
            "stairs.riser_m=0.5: outside the allowed range 0.02–0.3 m",
        ),
        ({"name": "stairs", "params": {"riser_m": "0.18"}}, "expected a number, not text"),
        ({"name": "stairs", "file": "a.xml"}, "exactly one of name"),
        ({"name": "lava"}, "lava"),
        ({"file": "hills.npy", "params": {"cell_m": 0.05}, "extra": 1}, "extra"),
        ("moon", "unknown terrain 'moon'"),
        ("/etc/passwd.xml", "over the network a file is one uploaded with PUT /terrain-files/NAME"),
        ("../secrets/x.npy:cell_m=0.05", "over the network a file is one uploaded"),
        ({"file": "../../x.xml"}, "over the network a file is one uploaded"),
        ("..x.npy:cell_m=0.05", "over the network a file is one uploaded"),
        ("nothere.npy:cell_m=0.05", "no uploaded terrain file 'nothere.npy'"),
        (5, "terrain"),
        ([], "terrain"),
        ({"name": 3}, "terrain"),
        ("x" * 3000, "terrain"),
    ],
)
def test_bad_terrains_are_422_naming_the_field(client: TestClient, terrain, reason: str) -> None:
    for path, body in (("/sessions", {"terrain": terrain}),
                       ("/simulations", {"walk": {"vx": 0.2}, "terrain": terrain})):  # fmt: skip
        r = client.post(path, json=body)
        assert r.status_code == 422, (path, r.text)
        err = r.json()
        assert any("terrain" in e["field"] for e in err["errors"]), err
        assert reason in r.text, r.text


def test_upload_use_list_and_delete_a_heightmap(client: TestClient, settings: Settings) -> None:
    hills = 0.05 + 0.03 * np.sin(np.arange(40)[None, :] * 0.3) * np.ones((20, 1))
    r = client.put("/terrain-files/hills.npy", content=_npy(hills))
    assert r.status_code == 201 and r.json() == {
        "name": "hills.npy",
        "bytes": r.json()["bytes"],
        "kind": "heightmap",
    }
    assert client.put("/terrain-files/hills.npy", content=_npy(hills)).status_code == 200  # replaced
    assert [f["name"] for f in client.get("/terrain-files").json()] == ["hills.npy"]
    # without a cell size it cannot be built: named, without the server's directory in the message
    r = client.post("/sessions", json={"terrain": "hills.npy"})
    assert r.status_code == 422 and "needs cell_m" in r.text and str(settings.data_dir) not in r.text
    r = client.post("/sessions", json={"terrain": {"file": "hills.npy", "params": {"cell_m": 0.05}}})
    assert r.status_code == 201, r.text
    sid = r.json()["id"]
    # the simulation runs the file inside the terrain directory
    assert r.json()["terrain"] == f"{terrain_dir(settings) / 'hills.npy'}:cell_m=0.05"
    client.delete(f"/sessions/{sid}")
    # a YAML beside it gives the cell size
    assert client.put("/terrain-files/hills.yaml", content=b"cell_m: 0.04\n").status_code == 201
    assert _session_terrain(client, "hills.npy")[0] == 201
    r = client.post("/simulations", json={"walk": {"vx": 0.3}, "terrain": "hills.npy", "duration": 1.0})
    assert r.status_code == 202, r.text
    job = r.json()["id"]
    end = time.monotonic() + 60.0  # a worker process starts first; on a loaded machine that takes seconds
    while (st := client.get(f"/simulations/{job}").json())["status"] not in ("done", "failed"):
        assert time.monotonic() < end, st
        time.sleep(0.05)
    assert st["status"] == "done" and st["request"]["terrain"] == "hills.npy"
    assert client.delete("/terrain-files/hills.npy").status_code == 204
    assert client.delete("/terrain-files/hills.npy").status_code == 404
    assert _session_terrain(client, "hills.npy")[0] == 422


def test_an_uploaded_scene_may_not_reach_outside_the_terrain_directory(
    client: TestClient, tmp_path: Path
) -> None:
    secret = tmp_path / "secret.xml"
    secret.write_text('<mujoco><worldbody><geom type="plane" size="1 1 1"/></worldbody></mujoco>')
    scene = f'<mujoco><include file="{secret}"/></mujoco>'.encode()
    assert client.put("/terrain-files/room.xml", content=scene).status_code == 201
    r = client.post("/sessions", json={"terrain": "room.xml"})
    assert r.status_code == 422 and "names a file outside the scene's directory" in r.text
    scene = (
        b'<mujoco><asset><hfield name="h" file="../../../etc/hostname.png" size="1 1 1 1"/></asset></mujoco>'
    )
    client.put("/terrain-files/room.xml", content=scene)
    assert client.post("/sessions", json={"terrain": "room.xml"}).status_code == 422
    good = b'<mujoco><worldbody><geom name="floor" type="plane" size="5 5 0.1"/></worldbody></mujoco>'
    client.put("/terrain-files/room.xml", content=good)
    assert _session_terrain(client, "room.xml")[0] == 201


@pytest.mark.parametrize("name", ["a b.npy", "x.exe", ".hidden.npy", "x" * 90 + ".npy"])
def test_bad_upload_names_are_refused(client: TestClient, name: str) -> None:
    r = client.put(f"/terrain-files/{name}", content=b"123")
    assert r.status_code == 422 and r.json()["errors"][0]["field"] == "name", r.text


def test_uploads_need_a_body_and_stay_under_the_body_limit(client: TestClient) -> None:
    assert client.put("/terrain-files/a.npy", content=b"").status_code == 422
    assert client.put("/terrain-files/a.npy", content=b"x" * (300 * 1024)).status_code == 413
    assert client.get("/terrain-files").json() == []


def test_terrains_list_their_parameters(client: TestClient) -> None:
    terrains = {t["name"]: t for t in client.get("/terrains").json()}
    assert "mixed" in terrains
    riser = next(p for p in terrains["stairs"]["params"] if p["name"] == "riser_m")
    assert riser == {"name": "riser_m", "kind": "float", "default": 0.15, "range": [0.02, 0.3], "unit": "m"}


def test_an_uploaded_scene_uses_an_uploaded_mesh(client: TestClient) -> None:
    tris = [((0, 0, 0), (1, 0, 0), (0, 1, 0)), ((0, 0, 0), (0, 1, 0), (0, 0, 0.2)),
            ((0, 0, 0), (0, 0, 0.2), (1, 0, 0)), ((1, 0, 0), (0, 0, 0.2), (0, 1, 0))]  # fmt: skip
    stl = b"\0" * 80 + struct.pack("<I", len(tris))  # binary STL: header, count, (normal, 3 vertices, attr)
    for tri in tris:
        stl += struct.pack("<12fH", 0, 0, 0, *(c for v in tri for c in v), 0)
    assert client.put("/terrain-files/wedge.stl", content=stl).json()["kind"] == "mesh"
    scene = (
        '<mujoco><asset><mesh name="w" file="wedge.stl"/></asset><worldbody>'
        '<geom name="floor" type="plane" size="5 5 0.1"/><geom name="wedge" type="mesh" mesh="w" pos="2 0 0"/>'
        "</worldbody></mujoco>"
    )
    assert client.put("/terrain-files/wedged.xml", content=scene.encode()).status_code == 201
    status, body = _session_terrain(client, "wedged.xml")
    assert status == 201, body
    # a mesh is not a terrain by itself
    r = client.post("/sessions", json={"terrain": "wedge.stl"})
    assert r.status_code == 422 and "unknown kind '.stl'" in r.text
