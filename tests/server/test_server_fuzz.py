"""Fuzz every operation from the OpenAPI schema (schemathesis, valid and invalid inputs): never a 5xx."""

from __future__ import annotations

import tempfile
from collections.abc import Iterator
from pathlib import Path

import pytest
import schemathesis
from hypothesis import HealthCheck, settings
from schemathesis.checks import not_a_server_error
from server_fakes import FakeSim, fake_runner

from server.app import create_app
from server.settings import Settings

_PARENT = Path(tempfile.mkdtemp(prefix="footfall-fuzz-"))  # private: the suite reads only what it made
_DATA = _PARENT / "data"
app = create_app(
    Settings(data_dir=_DATA, max_sessions=2, max_queued_simulations=2, max_body_bytes=64 * 1024),
    sim_factory=FakeSim,
    sim_runner=fake_runner,
)
schema = schemathesis.openapi.from_asgi("/openapi.json", app)
schema.config.generation.update(max_examples=25, deterministic=True)


@pytest.fixture(scope="module", autouse=True)
def _close_services() -> Iterator[None]:
    yield
    app.state.services.close()


@schema.parametrize()
@settings(max_examples=25, deadline=None, suppress_health_check=list(HealthCheck), derandomize=True)
def test_no_server_errors(case: schemathesis.Case) -> None:
    response = case.call()
    case.validate_response(response, checks=[not_a_server_error])
    if 400 <= response.status_code < 500 and response.status_code != 404:
        body = response.json()
        assert body.get("detail"), f"a {response.status_code} without a detail: {body}"


def test_nothing_escaped_the_data_dir() -> None:
    root = _DATA.resolve()
    assert all(p.resolve().is_relative_to(root) for p in _DATA.rglob("*"))
    assert [p.name for p in _PARENT.iterdir()] in ([], ["data"])  # nothing written beside the data directory
