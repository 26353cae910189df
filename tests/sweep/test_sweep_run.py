"""Running sweeps on local worker processes: records for every case, resuming, crashes retried once, a killed
worker's case accounted for; the summary's intervals, table, CSV and heat map PNG."""

from __future__ import annotations

import csv
import io
import json
import os
import signal
import struct
import threading
import time
import zlib

import pytest

from planning.sweep import LocalBackend, ResultStore, expand, format_table, parse_spec, run_sweep, wilson
from planning.sweep.heatmap import png_bytes, render


def _probe_spec(n: int, **probe):
    return parse_spec({"format": "footfall/sweep@1", "name": "probe", "run": {"probe": probe},
                       "axes": {"seed": {"min": 0, "max": n - 1, "integer": True}}})  # fmt: skip


def test_wilson_interval_known_values() -> None:
    lo, hi = wilson(0, 10)
    assert lo == 0.0 and hi == pytest.approx(0.2775, abs=1e-4)
    lo, hi = wilson(8, 10)
    assert (lo, hi) == (pytest.approx(0.4902, abs=1e-4), pytest.approx(0.9433, abs=1e-4))
    assert wilson(0, 0) == (0.0, 1.0)


def test_probe_sweep_counts_resumes_and_writes_outputs(tmp_path) -> None:
    spec = _probe_spec(9, fail_every=3)
    s = run_sweep(spec, LocalBackend(workers=2), tmp_path, progress=False)
    assert s["overall"]["done"] == 9 and s["overall"]["successes"] == 6 and s["ran"] == 9
    lo, hi = s["overall"]["ci95"]
    assert lo < 6 / 9 < hi
    assert list(s["overall"]["failure_reasons"].values()) == [3]
    records = [json.loads(p.read_text()) for p in (tmp_path / "cases").glob("*.json")]
    assert len(records) == 9 and {r["status"] for r in records} == {"done"}
    assert sum(r["report"]["success"] for r in records) == 6
    rows = list(csv.DictReader(io.StringIO((tmp_path / "cases.csv").read_text())))
    assert len(rows) == 9 and sum(r["success"] == "True" for r in rows) == 6
    # run again: every case is found stored, none runs
    again = run_sweep(spec, LocalBackend(workers=2), tmp_path, progress=False)
    assert again["resumed"] == 9 and again["ran"] == 0 and again["overall"]["successes"] == 6


def test_interrupted_sweep_goes_on_where_it_stopped(tmp_path) -> None:
    spec = _probe_spec(6)
    seen: list[str] = []
    s = run_sweep(spec, LocalBackend(workers=1), tmp_path, progress=False,
                  on_record=lambda c, r: seen.append(c["key"]), cancelled=lambda: len(seen) >= 2)  # fmt: skip
    assert 2 <= s["overall"]["done"] < 6 and s["overall"]["pending"] == 6 - s["overall"]["done"]
    assert "have not run yet" in format_table(s)
    rest = run_sweep(spec, LocalBackend(workers=2), tmp_path, progress=False)
    assert rest["resumed"] == s["overall"]["done"] and rest["ran"] == 6 - rest["resumed"]
    assert rest["overall"]["done"] == 6 and rest["overall"]["pending"] == 0


def test_a_killed_worker_case_is_retried_and_every_case_accounted_for(tmp_path) -> None:
    marks = tmp_path / "marks"
    marks.mkdir()
    spec = _probe_spec(4, sleep_s=1.0, mark_dir=str(marks))
    killed: list[int] = []

    def killer() -> None:
        for _ in range(300):
            pids = [int(p.name) for p in marks.iterdir()]
            if pids:
                os.kill(pids[0], signal.SIGKILL)
                killed.append(pids[0])
                return
            time.sleep(0.05)

    t = threading.Thread(target=killer)
    t.start()
    s = run_sweep(spec, LocalBackend(workers=2), tmp_path / "out", progress=False)
    t.join()
    assert killed
    assert s["overall"]["done"] == 4 and s["overall"]["crashed"] == 0 and s["overall"]["pending"] == 0
    store = ResultStore(tmp_path / "out")
    records = [store.get(c["key"]) for c in expand(spec)]
    assert all(r is not None and r["status"] == "done" for r in records)
    assert sorted(r["attempts"] for r in records) == [1, 1, 1, 2]  # the killed one ran again
    assert killed[0] not in {r["worker"] for r in records}


def test_a_case_that_crashes_twice_is_reported_as_crashed(tmp_path) -> None:
    spec = parse_spec(
        {"format": "footfall/sweep@1", "name": "c", "run": {"probe": {"mark_dir": "/nonexistent/x"}}}
    )
    s = run_sweep(spec, LocalBackend(workers=1), tmp_path, progress=False)
    assert s["overall"]["crashed"] == 1 and s["overall"]["done"] == 0
    rec = next(json.loads(p.read_text()) for p in (tmp_path / "cases").glob("*.json"))
    assert rec["status"] == "crashed" and rec["attempts"] == 2 and "FileNotFoundError" in rec["error"]


def test_heatmap_png_is_a_valid_image_with_the_rates_colors(tmp_path) -> None:
    hm = {"x": "push_impulse_ns", "y": "push_direction_deg", "x_labels": ["0", "10"], "y_labels": ["0", "90"],
          "successes": [[4, 0], [4, 2]], "done": [[4, 4], [4, 4]]}  # fmt: skip
    img = render(hm, "t")
    data = png_bytes(img)
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    w, h = struct.unpack(">II", data[16:24])
    assert (h, w) == img.shape[:2]
    n = struct.unpack(">I", data[33:37])[0]
    raw = zlib.decompress(data[41 : 41 + n])
    assert len(raw) == h * (1 + 3 * w)
    colors = {tuple(int(v) for v in px) for px in img.reshape(-1, 3)}
    assert (220, 60, 60) in colors  # 0 %: red
    assert (50, 180, 60) in colors  # 100 %: green


def test_progress_line_has_done_rate_eta_and_success() -> None:
    from planning.sweep import Progress

    out = io.StringIO()
    p = Progress("x", total=4, already=0, stream=out, every_s=0.0)
    p.count({"status": "done", "report": {"success": True}})
    p.count({"status": "done", "report": {"success": False}})
    p.count({"status": "crashed", "report": None})
    p.show(final=True)
    line = out.getvalue()
    assert "[###############.....] 3/4 cases, 1 crashed" in line
    assert "cases/min" in line and "ETA" in line and "success 1/2 = 50 %" in line


def test_bench_variant_stage_runs_through_the_sweep(tmp_path) -> None:
    from benchmarks.run import sweep_variants

    spec = tmp_path / "v.yaml"
    spec.write_text("format: footfall/sweep@1\nname: v\nrun:\n  - {label: sensor, probe: {}}\n"
                    "  - {label: truth, probe: {fail_every: 2}}\naxes: {seed: [0, 1]}\n")  # fmt: skip
    out = sweep_variants(str(spec), str(tmp_path / "out"))
    assert list(out["by_variant"]) == ["sensor seed=0", "sensor seed=1", "truth seed=0", "truth seed=1"]
    assert out["runs"] == 4 and out["success_rate"] == 0.75
    assert out["by_variant"]["truth seed=1"]["failure_reason"].startswith("probe case 3 fails")
