"""Load: 20 clients poll a live session's state for 30 s on loopback; no errors, the session keeps real time.

Slow (~35 s): runs only when selected, `pytest -m load tests/server` (the same as `python -m benchmarks.load_api`).
"""

from __future__ import annotations

import pytest

from benchmarks.load_api import run_load


@pytest.mark.load
def test_twenty_clients_polling_while_a_session_runs() -> None:
    r = run_load(clients=20, duration_s=30.0, hz=10.0, maneuver="bow")
    assert r["errors"] == 0, r["error_samples"]
    assert r["requests"] >= 20 * 10 * 30 * 0.8  # the clients really did poll at ~10 Hz each
    s = r["session"]
    assert s["status"] == "running" and not s["fell"]
    assert s["realtime_ratio"] >= 0.97, r
    assert s["dropped_s"] <= 0.3, r
    assert r["latency_ms"]["p99"] < 250.0, r
