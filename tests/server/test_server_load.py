"""Load: 20 clients poll a live session's state on loopback; no errors, and the session keeps real time as well as
it does with no client polling on the same machine in the same run.

Slow (~40 s): runs only when selected, `pytest -m load tests/server` (the same as `python -m benchmarks.load_api`).
"""

from __future__ import annotations

import pytest

from benchmarks.load_api import local_server, run_load

POLL_S = 15.0  # s of polling by 20 clients
ALONE_S = POLL_S  # s of the same session with no client, side by side, first


@pytest.mark.load
def test_twenty_clients_polling_while_a_session_runs() -> None:
    """On an idle 2-core machine the session keeps real time under the polling (measured: ratio 0.99-1.00, 0 s
    dropped). A machine busy with other work slows the session with or without clients, so its real-time keeping is
    judged against the same session measured alone just before: within 3 % of real time or of that run's ratio,
    and at most 0.3 s dropped beyond what it dropped alone. The pollers run at a lower priority (they stand in for
    clients on other machines; `benchmarks.load_api.POLLER_NICE`). Measured beside 2 busy processes: 3 of 3 pass
    (1 of 3 before, with 0.9 s dropped, the pollers at the session's priority); beside 4 the server's own handling
    of the 200 requests a second takes the cores the session needs (0.56-0.77 of real time against 0.84-0.86
    alone), and the test fails: this is a test of a machine with the cores to spare."""
    with local_server() as url:
        alone = run_load(url, clients=0, duration_s=ALONE_S, maneuver="bow")["session"]
        r = run_load(url, clients=20, duration_s=POLL_S, hz=10.0, maneuver="bow")
    assert r["errors"] == 0, r["error_samples"]
    assert r["requests"] >= 20 * 10 * POLL_S * 0.8  # the clients really did poll at ~10 Hz each
    s = r["session"]
    assert s["status"] == "running" and not s["fell"]
    assert s["realtime_ratio"] >= min(0.97, alone["realtime_ratio"] - 0.03), (r, alone)
    assert s["dropped_s"] <= max(0.3, alone["dropped_s"] + 0.3), (r, alone)
    assert r["latency_ms"]["p99"] < 250.0, r
