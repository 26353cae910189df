"""`footfall sweep --rerun CASE`: one case of a results directory run again, its outcome beside the stored one, with
the per-leg trace of a walk case; clear errors for what it cannot rerun."""

from __future__ import annotations

import csv
import json

import pytest

from planning.sweep import LocalBackend, parse_spec, run_sweep
from server.cli import main


@pytest.fixture(scope="module")
def results(tmp_path_factory):
    """A two-case walk sweep (0.6 s on flat and on the slope with the scene's maps) and a two-case probe sweep."""
    out = tmp_path_factory.mktemp("walks")
    spec = parse_spec({"format": "footfall/sweep@1", "name": "w",
                       "run": {"walk": {"vx": 0.3, "maps": "truth"}},
                       "defaults": {"duration_s": 0.6}, "axes": {"terrain": ["flat", "slope"]}})  # fmt: skip
    run_sweep(spec, LocalBackend(workers=1), out, progress=False)
    probes = tmp_path_factory.mktemp("probes")
    pspec = parse_spec({"format": "footfall/sweep@1", "name": "p", "run": {"probe": {"fail_every": 2}},
                        "axes": {"seed": {"min": 0, "max": 1, "integer": True}}})  # fmt: skip
    run_sweep(pspec, LocalBackend(workers=1), probes, progress=False)
    return out, probes


def test_rerun_of_a_walk_case_matches_its_record_and_writes_the_trace(results, tmp_path, capsys) -> None:
    out, _ = results
    files = sorted((out / "cases").glob("*.json"))
    rec = next(
        json.loads(f.read_text())
        for f in files
        if json.loads(f.read_text())["case"]["params"]["terrain"] == "slope"
    )
    key = rec["key"]
    trace, report = tmp_path / "t.csv", tmp_path / "r.json"
    argv = ["sweep", "--rerun", str(out / "cases" / key[:10]), "--trace", str(trace), "--report", str(report)]
    assert main(argv) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].startswith(f"case {key}")
    stored = lines[1].split(":", 1)[1].strip()
    now = lines[2].split(":", 1)[1].strip()
    assert stored == now == ("success" if rec["report"]["success"] else rec["report"]["failure_reason"])
    new = json.loads(report.read_text())
    assert new["mode"] == "walk" and new["terrain"] == rec["report"]["terrain"]
    with trace.open() as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == 4 * len({r["t_s"] for r in rows}) >= 4 * 55  # every 10 ms over 0.6 s
    assert any(r["chosen_x"] for r in rows)  # a terrain walk: the pipeline's footholds


@pytest.mark.parametrize(
    ("argv", "needle"),
    [
        (["--rerun", "{walks}/cases/zzzz"], "no such case file"),
        (["--rerun", "{walks}/cases/"], "case files start so; give more of the key"),
        (["push-stand", "--rerun", "{walks}/cases/zzzz"], "--rerun takes a case file and no SPEC"),
        (["--rerun", "{probes}/cases/", "--trace", "t.csv"], "case files start so"),
        (["--trace", "t.csv"], "--trace, --report: only with --rerun CASE"),
        (
            ["--rerun", "{walks}/cases/x", "--trace", "no/such/dir/t.csv"],
            "--trace no/such/dir/t.csv: no such",
        ),
        (
            ["--rerun", "{walks}/cases/x", "--trace", "t.csv", "--trace-every", "0"],
            "--trace-every 0 s: must be",
        ),
        (["--rerun", "{bad}"], "not a case file"),
        (["--rerun", "{walks}/cases/x", "--trace-every", "0.02"], "--trace-every: only with --trace FILE"),
    ],
)
def test_rerun_errors_are_one_line(results, tmp_path, argv, needle, capsys) -> None:
    walks, probes = results
    bad = tmp_path / "bad.json"
    bad.write_text('{"case": {}}')
    argv = [a.format(walks=walks, probes=probes, bad=bad) for a in argv]
    assert main(["sweep", *argv]) == 2
    err = capsys.readouterr().err.strip()
    assert needle in err and len(err.splitlines()) == 1


def test_a_probe_case_reruns_without_a_trace(results, capsys) -> None:
    _, probes = results
    f = sorted((probes / "cases").glob("*.json"))[0]
    assert main(["sweep", "--rerun", str(f)]) == 0
    out = capsys.readouterr().out
    assert "stored:" in out and "now:" in out
    assert main(["sweep", "--rerun", str(f), "--trace", "t.csv"]) == 2
    assert "--trace: only for a walk case (this one is a probe case)" in capsys.readouterr().err
