"""The robot picker over REST: GET /robots lists the shipped robots and the robot files in <data dir>/robots; a
session is created on, and reset to, a named robot; a name not listed or a file that does not load is a 422 naming
the field `robot` (never a 500), and no server path is named in the list."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
import yaml
from fastapi.testclient import TestClient
from server_fakes import FakeSim, fake_runner, make_client

from planning.robot.model import ASSETS
from server.robots import robot_dir
from server.settings import Settings

BUILT = []  # the robot argument of every simulation the sessions built, in order


class RobotFake(FakeSim):
    def __init__(self, maneuver: Any, terrain: str, robot: str = "spot") -> None:
        super().__init__(maneuver, terrain, robot)
        BUILT.append(robot)


@pytest.fixture
def rclient(settings: Settings) -> Iterator[TestClient]:
    """A client whose data directory holds a robot folder (the shipped go1 as a user's file, with its description
    beside it) and a broken robot file."""
    folder = robot_dir(settings) / "mybot"
    folder.mkdir(parents=True)
    (folder / "mybot.xml").write_text((ASSETS / "go1.xml").read_text())
    desc = yaml.safe_load((ASSETS / "go1.yaml").read_text())
    for key in ("name", "title", "mjcf"):
        desc.pop(key)
    (folder / "mybot.footfall.yaml").write_text(yaml.safe_dump(desc))
    (robot_dir(settings) / "broken.xml").write_text("<mujoco><worldbody/></mujoco>")
    BUILT.clear()
    yield from make_client(settings, sim_factory=RobotFake, sim_runner=fake_runner)


def test_the_list_names_shipped_and_file_robots_without_paths(
    rclient: TestClient, settings: Settings
) -> None:
    r = rclient.get("/robots")
    assert r.status_code == 200
    by_name = {e["name"]: e for e in r.json()}
    assert {"spot", "go1", "mybot", "broken"} <= set(by_name)
    assert by_name["spot"]["default"] and not by_name["go1"]["default"]
    assert by_name["go1"]["source"] == "shipped" and by_name["mybot"]["source"] == "file"
    assert str(settings.data_dir) not in r.text


def test_sessions_run_and_reset_on_a_named_robot(rclient: TestClient, settings: Settings) -> None:
    r = rclient.post("/sessions", json={"robot": "go1"})
    assert r.status_code == 201, r.text
    sid = r.json()["id"]
    assert r.json()["robot"] == "go1" and BUILT[-1] == "go1"
    assert rclient.get(f"/sessions/{sid}/state").json()["robot"] == "go1"
    r = rclient.post(f"/sessions/{sid}/reset", json={"robot": "mybot"})
    assert r.status_code == 200, r.text
    assert Path(BUILT[-1]) == (robot_dir(settings) / "mybot" / "mybot.xml").resolve()
    r = rclient.post(f"/sessions/{sid}/reset", json={"terrain": "flat"})  # keeps its robot
    assert r.status_code == 200 and "mybot" in BUILT[-1]
    r = rclient.post("/sessions", json={})
    assert r.status_code == 201 and r.json()["robot"] == "spot" and BUILT[-1] == "spot"


@pytest.mark.parametrize(
    ("robot", "reason"),
    [
        ("nope", "the robots: go1, spot, broken, mybot"),
        ("../go1", "no robot"),
        ("/etc/passwd.xml", "no robot"),
        ("broken", "cannot be loaded"),
        (7, "string"),
    ],
)
def test_bad_robots_are_422_naming_the_field(rclient: TestClient, robot: Any, reason: str) -> None:
    n = len(BUILT)
    r = rclient.post("/sessions", json={"robot": robot})
    assert r.status_code == 422, r.text
    assert any(e["field"].endswith("robot") for e in r.json()["errors"]), r.text
    assert reason in r.text
    sid = rclient.post("/sessions", json={}).json()["id"]
    r = rclient.post(f"/sessions/{sid}/reset", json={"robot": robot})
    assert r.status_code == 422 and "robot" in r.text
    assert len(BUILT) == n + 1  # nothing was built for the refused robot


def test_simulations_run_on_a_named_robot(rclient: TestClient) -> None:
    r = rclient.post("/simulations", json={"maneuver": "stand", "robot": "go1"})
    assert r.status_code == 202, r.text
    assert rclient.get(r.headers["Location"]).json()["request"]["robot"] == "go1"
    r = rclient.post("/simulations", json={"maneuver": "stand", "robot": "nope"})
    assert r.status_code == 422 and r.json()["errors"][0]["field"] == "robot", r.text


def test_the_servers_own_robot_file_is_listed_and_is_the_default(tmp_path: Path) -> None:
    from server.robots import default_name, list_robots, resolve_robot

    xml = tmp_path / "models" / "go1.xml"  # a file named like a shipped robot
    xml.parent.mkdir()
    xml.write_text((ASSETS / "go1.xml").read_text())
    desc = yaml.safe_load((ASSETS / "go1.yaml").read_text())
    (tmp_path / "models" / "go1.footfall.yaml").write_text(
        yaml.safe_dump({k: v for k, v in desc.items() if k not in ("name", "title", "mjcf")})
    )
    s = Settings(data_dir=tmp_path / "data", robot=str(xml))
    listed = {e["name"]: e for e in list_robots(s)}
    assert listed["server-go1"] == {"name": "server-go1", "source": "server", "default": True}
    assert listed["go1"]["source"] == "shipped" and default_name(s) == "server-go1"
    assert resolve_robot("server-go1", s) == str(xml.resolve())
