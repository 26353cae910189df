"""Fuzz every operation from the OpenAPI description (schemathesis): every default check, every phase (examples,
coverage, fuzzing, stateful), 50 examples per operation, and no failure of any kind: no 5xx, every status and
body as declared, schema-valid requests accepted, schema-invalid ones refused. The one configured exception (422
for a well-formed maneuver that breaks a rule) is in schemathesis.toml beside this file, with its reason."""

from __future__ import annotations

import shutil
import tempfile
from collections.abc import Iterator
from pathlib import Path

import pytest
import schemathesis
from hypothesis import HealthCheck, settings
from server_fakes import FakeSim, fake_runner

from server.app import create_app
from server.settings import Settings

_PARENT = Path(tempfile.mkdtemp(prefix="footfall-fuzz-"))  # private: the suite reads only what it made
_DATA = _PARENT / "data"
app = create_app(
    # validation's physics check off by default (each would queue a run); `?physics=true` is still fuzzed
    Settings(
        data_dir=_DATA,
        max_sessions=2,
        max_queued_simulations=2,
        max_body_bytes=64 * 1024,
        validate_physics=False,
    ),  # fmt: skip
    sim_factory=FakeSim,
    sim_runner=fake_runner,
)
config = schemathesis.Config.from_path(Path(__file__).with_name("schemathesis.toml"))
schema = schemathesis.openapi.from_asgi("/openapi.json", app, config=config)
schema.config.generation.update(deterministic=True)


@pytest.fixture(scope="module", autouse=True)
def _close_services() -> Iterator[None]:
    yield
    app.state.services.close()
    shutil.rmtree(_PARENT, ignore_errors=True)


@schema.parametrize()
@settings(deadline=None, suppress_health_check=list(HealthCheck), derandomize=True)
def test_every_operation(case: schemathesis.Case) -> None:
    case.call_and_validate()  # every default check


Stateful = schema.as_state_machine()
TestStateful = Stateful.TestCase
TestStateful.settings = settings(
    max_examples=50,
    deadline=None,
    suppress_health_check=list(HealthCheck),
    derandomize=True,
    stateful_step_count=6,
)


def test_nothing_escaped_the_data_dir() -> None:
    root = _DATA.resolve()
    assert all(p.resolve().is_relative_to(root) for p in _DATA.rglob("*"))
    assert [p.name for p in _PARENT.iterdir()] in ([], ["data"])  # nothing written beside the data directory
