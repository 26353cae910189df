"""Fixtures for the service tests: settings in a temporary data directory, a TestClient on a fake simulation."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from fastapi.testclient import TestClient
from server_fakes import FakeSim, fake_runner, make_client

from server.settings import Settings


@pytest.fixture
def settings(tmp_path: Path) -> Settings:
    # validation's physics check is asked for by the tests about it (?physics=true): the others stay quick
    return Settings(data_dir=tmp_path / "data", max_sessions=3, sim_workers=1, max_queued_simulations=4,
                    reaper_period_s=0.2, validate_physics=False)  # fmt: skip


@pytest.fixture
def client(settings: Settings) -> Iterator[TestClient]:
    """A client of an app whose sessions run FakeSim and whose simulations run fake_runner."""
    yield from make_client(settings, sim_factory=FakeSim, sim_runner=fake_runner)


@pytest.fixture
def user_dir(settings: Settings) -> Path:
    return settings.user_dir


@pytest.fixture
def bow(client: TestClient) -> dict[str, Any]:
    """The shipped `bow` as a JSON document."""
    r = client.get("/maneuvers/bow")
    assert r.status_code == 200
    return r.json()
