"""The studio's Robustness tab in a browser (issue 25): click a failed cell of the heat map, choose one of its failed
cases, and the live robot starts that case (the sweep's outcomes are made up: this is about the panel, not the runs)."""

from __future__ import annotations

import time
from pathlib import Path

import pytest
from fastapi.testclient import TestClient
from test_server_browser import _browser_page

from planning.maneuver import find_maneuver, load_maneuver
from planning.sweep import expand, parse_spec
from server.app import create_app
from server.settings import Settings
from server.sweeps import SweepJob


@pytest.mark.browser
def test_click_a_failed_cell_and_replay_its_case(tmp_path: Path) -> None:
    s = Settings(data_dir=tmp_path / "data", viewer_port=0, max_sessions=2, studio_shadows=False)
    app = create_app(s, with_studio=True)
    with (
        TestClient(app, raise_server_exceptions=False) as client,
        _browser_page(tmp_path) as (page, problems),
    ):
        services = app.state.services
        page.set_default_timeout(90_000)  # software WebGL on a loaded 2-core machine renders slowly
        page.goto(f"http://127.0.0.1:{services.studio.port}/", wait_until="domcontentloaded")
        page.get_by_role("button", name="Preview", exact=True).wait_for(timeout=60_000)
        end = (
            time.monotonic() + 90
        )  # the live robot is a worker process: seconds to start on a loaded machine
        ready = lambda c: c.session is not None and getattr(c, "ready", False)  # noqa: E731 - every panel built
        while not (tabs := [c for c in services.studio.clients.values() if ready(c)]):
            assert time.monotonic() < end, "the studio tab got no live robot"
            time.sleep(0.2)
        tab = tabs[0]
        panel = tab.robustness
        # a finished sweep of `stand` over terrain × seed in which only the slope's seed-0 layout failed
        stand = load_maneuver(find_maneuver("stand"))
        spec = parse_spec(panel.spec_for(stand, "terrain family × seed"))
        cases = expand(spec)
        job = SweepJob("j1", spec, cases, len({c["key"] for c in cases}), status="done", started=time.time())
        for c in cases:
            ok = not (c["axes"]["terrain"] == "slope" and c["axes"]["seed"] == 0)
            job.records[c["key"]] = {"status": "done", "attempts": 1, "wall_s": 1.0, "error": None,
                                     "report": {"success": ok, "failure_reason": None if ok else "fell: trunk"}}  # fmt: skip
        panel.job = job
        panel.refresh()
        generation = tab.session.generation

        page.get_by_role("tab", name="Robustness").click()
        page.get_by_role("button", name="terrain=slope: 0/1 ✗").click()
        chooser = page.get_by_label("failed case", exact=True)
        end = time.monotonic() + 30
        while "choose one of 1 failed" not in chooser.input_value():
            assert time.monotonic() < end, (
                f"the cell's failed cases were not listed: {chooser.input_value()!r}"
            )
            time.sleep(0.2)
        chooser.click()
        page.get_by_role("option", name="terrain=slope, seed=0: fell: trunk").click()

        sid = tab.session.id
        end = time.monotonic() + 60
        while True:  # the case starts on the live robot: the slope, the maneuver from its beginning, stepping
            st = client.get(f"/sessions/{sid}/state").json()
            if st["generation"] > generation and str(st["terrain"]).startswith("slope") and st["t"] > 0.2:
                break
            assert time.monotonic() < end, f"the case did not start: {st}"
            time.sleep(0.2)
        assert st["maneuver"] == "stand" and st["status"] == "running"
        assert not problems, problems
