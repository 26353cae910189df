"""A small closed-loop sweep through both backends (Ray local with 2 CPUs): the rates are the runs' own reports';
and a Ray worker killed mid-sweep: every case still accounted for."""

from __future__ import annotations

import os
import signal
import threading
import time
from collections.abc import Iterator

import pytest
import ray  # a dependency of the project: a missing Ray is a broken install, which this test must report

from planning.sweep import LocalBackend, RayBackend, ResultStore, expand, parse_spec, run_sweep


@pytest.fixture(scope="module")
def ray_backend() -> Iterator[RayBackend]:
    backend = RayBackend(num_cpus=2)
    backend.init()
    yield backend
    ray.shutdown()


# stand, 1.2 s, pushed at 0.3 s: not at all, or by 60 N·s (it falls) — two clear outcomes, not a threshold
PUSHES = {"format": "footfall/sweep@1", "name": "pushes", "run": {"maneuver": "stand"},
          "defaults": {"duration_s": 1.2, "push": {"t_s": 0.3, "direction_deg": 90}},
          "axes": {"push_impulse_ns": [0, 60]}}  # fmt: skip


@pytest.mark.sim
def test_stand_pushes_through_both_backends_rates_match_the_reports(tmp_path, ray_backend) -> None:
    spec = parse_spec(PUSHES)
    cases = expand(spec)
    for name, backend in (("local", LocalBackend(workers=2)), ("ray", ray_backend)):
        s = run_sweep(spec, backend, tmp_path / name, progress=False)
        store = ResultStore(tmp_path / name)
        reports = {c["axes"]["push_impulse_ns"]: store.get(c["key"])["report"] for c in cases}
        assert s["backend"] == name and s["overall"]["done"] == 2 and s["overall"]["crashed"] == 0
        assert s["overall"]["successes"] == sum(r["success"] for r in reports.values())
        for cell in s["cells"]:
            r = reports[float(cell["axes"]["push_impulse_ns"])]
            assert cell["successes"] == int(r["success"])
        assert reports[0]["success"] and reports[0]["pushes"] == []
        assert not reports[60]["success"] and reports[60]["fell"]
        assert reports[60]["pushes"][0]["impulse_ns"] == pytest.approx(60.0)
        assert s["overall"]["failure_reasons"]  # the fall, grouped


def test_a_killed_ray_worker_case_is_retried_and_every_case_accounted_for(tmp_path, ray_backend) -> None:
    marks = tmp_path / "marks"
    marks.mkdir()
    spec = parse_spec({"format": "footfall/sweep@1", "name": "probe",
                       "run": {"probe": {"sleep_s": 1.5, "mark_dir": str(marks)}},
                       "axes": {"seed": [0, 1, 2, 3]}})  # fmt: skip
    killed: list[int] = []

    def killer() -> None:
        for _ in range(600):
            pids = [int(p.name) for p in marks.iterdir()]
            if pids:
                os.kill(pids[0], signal.SIGKILL)
                killed.append(pids[0])
                return
            time.sleep(0.05)

    t = threading.Thread(target=killer)
    t.start()
    s = run_sweep(spec, ray_backend, tmp_path / "out", progress=False)
    t.join()
    assert killed
    assert s["overall"]["done"] == 4 and s["overall"]["pending"] == 0 and s["overall"]["crashed"] == 0
    store = ResultStore(tmp_path / "out")
    records = [store.get(c["key"]) for c in expand(spec)]
    assert all(r is not None and r["status"] == "done" for r in records)
    assert sorted(r["attempts"] for r in records) == [1, 1, 1, 2]


def test_the_server_on_ray_runs_simulations_and_sweeps(tmp_path, ray_backend) -> None:
    from fastapi.testclient import TestClient

    from server.app import create_app
    from server.settings import Settings

    app = create_app(Settings(data_dir=tmp_path / "data", backend="ray", studio=False))
    with TestClient(app) as c:
        r = c.post("/simulations", json={"maneuver": "stand", "duration": 0.3})
        assert r.status_code == 202, r.text
        sim = r.json()["id"]
        s = c.post("/sweeps", json={"format": "footfall/sweep@1", "name": "p", "run": {"probe": {}},
                                    "axes": {"seed": [0, 1, 2]}})  # fmt: skip
        assert s.status_code == 202, s.text
        deadline = time.time() + 120
        while time.time() < deadline:
            job = c.get(f"/simulations/{sim}").json()
            sweep = c.get(f"/sweeps/{s.json()['id']}").json()
            if job["status"] in ("done", "failed") and sweep["status"] in ("done", "failed"):
                break
            time.sleep(0.2)
        assert job["status"] == "done", job["error"]
        assert job["report"]["duration_s"] == pytest.approx(0.3, abs=0.01)
        assert sweep["status"] == "done" and sweep["progress"]["done"] == 3
        cases = c.get(f"/sweeps/{s.json()['id']}/cases").json()
        rec = c.get(f"/sweeps/{s.json()['id']}/cases/{cases[0]['key']}").json()
        assert rec["backend"] == "ray" and rec["worker"] != os.getpid()
