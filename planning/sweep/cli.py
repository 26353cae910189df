"""`footfall sweep SPEC [--backend local|ray] [--address ADDR] [--out DIR] [--json FILE] [--workers N]`,
`footfall sweep --compare A B [--json FILE]` (two results directories, paired case by case), and
`footfall sweep --rerun CASE [--trace FILE] [--trace-every S] [--report FILE]` (one case of a results directory run
again here, its outcome set beside the stored one)."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

EXIT_OK, EXIT_CRASHED, EXIT_INVALID = 0, 1, 2


def add_parser(sub: argparse._SubParsersAction) -> argparse.ArgumentParser:  # type: ignore[type-arg]
    s = sub.add_parser(
        "sweep",
        help="run a robustness sweep (a footfall/sweep@1 spec): success rates over a family of variants",
    )
    s.add_argument(
        "spec",
        nargs="?",
        metavar="SPEC",
        help="a sweep spec .yaml, or a shipped sweep's name (sweeps/NAME.yaml)",
    )
    s.add_argument("--backend", choices=("local", "ray"), default="local", help="local worker processes "
                   "(default, one per core) or Ray tasks")  # fmt: skip
    s.add_argument("--address", metavar="ADDR", help="ray: a running cluster's address (default: start a "
                   "local Ray for this sweep)")  # fmt: skip
    s.add_argument("--out", metavar="DIR", help="where results go (default sweep-results/NAME); a sweep "
                   "run again into the same directory goes on where it stopped")  # fmt: skip
    s.add_argument("--json", metavar="FILE", help="also write the summary as JSON here")
    s.add_argument("--workers", type=int, metavar="N", help="local: worker processes (default: one per core); "
                   "ray: CPUs of the local Ray it starts")  # fmt: skip
    s.add_argument("--schema", action="store_true", help="print the spec format's JSON Schema and exit")
    s.add_argument("--compare", nargs=2, metavar=("A", "B"), help="compare two results directories of the same "
                   "spec (before and after a change) case by case: both rates, the cases B gains and loses, and "
                   "the exact sign test's p on them (no SPEC; --json writes the comparison)")  # fmt: skip
    s.add_argument("--rerun", metavar="CASE", help="run one case of a results directory again in this process "
                   "(DIR/cases/KEY.json, or a unique prefix of it: DIR/cases/d3a95a45) and set its outcome beside the "
                   "stored one (no SPEC)")  # fmt: skip
    s.add_argument("--trace", metavar="FILE", help="--rerun of a walk case: write its per-leg trace here (CSV; "
                   "README, Tracing a walk)")  # fmt: skip
    s.add_argument("--trace-every", type=float, metavar="S", help="the trace's sampling period, "
                   "simulated seconds (default 0.01, at least 0.002)")  # fmt: skip
    s.add_argument("--report", metavar="FILE", help="--rerun: write the new run report here (JSON)")
    return s


def _case_file(arg: str) -> Path:
    """The case file --rerun names: the path itself, or the one file of its directory whose name starts with it."""
    p = Path(arg)
    if p.is_file():
        return p
    if p.is_dir():  # (the cases directory itself: every case in it matches)
        matches = sorted(p.glob("*.json"))
    else:
        matches = sorted(p.parent.glob(p.name + "*.json")) if p.parent.is_dir() else []
    if len(matches) == 1:
        return matches[0]
    if not matches:
        raise ValueError(f"--rerun {arg}: no such case file (DIR/cases/KEY.json)")
    raise ValueError(f"--rerun {arg}: {len(matches)} case files start so; give more of the key")


def _outcome(report: dict[str, Any] | None) -> str:
    if not report:
        return "no report"
    return "success" if report.get("success") else str(report.get("failure_reason") or "failed")


def _rerun(a: argparse.Namespace, err: Any) -> int:
    from planning.sim.trace import DEFAULT_TRACE_EVERY_S
    from planning.sweep.cases import rerun_walk_case, run_case

    if a.spec:
        return err("--rerun takes a case file and no SPEC")
    if a.report is not None and not (parent := Path(a.report).expanduser().resolve().parent).is_dir():
        return err(f"--report {a.report}: no such directory {parent}")
    try:
        path = _case_file(a.rerun)
        stored = json.loads(path.read_text())
        params = stored["case"]["params"]
        kind = params["kind"]
    except ValueError as e:  # (json.JSONDecodeError is one)
        return err(str(e) if str(e).startswith("--rerun") else f"--rerun {a.rerun}: not a case file: {e}")
    except (KeyError, TypeError):
        return err(f"--rerun {a.rerun}: not a case file (no case.params.kind)")
    if a.trace is not None and kind != "walk":
        return err(f"--trace: only for a walk case (this one is a {kind} case)")
    trace = None
    if kind == "walk":
        every = DEFAULT_TRACE_EVERY_S if a.trace_every is None else a.trace_every
        report, trace = rerun_walk_case(params, None if a.trace is None else every)
    else:
        report = run_case(params)
    print(f"case {stored.get('key', path.stem)} ({path})")
    print(f"  stored: {_outcome(stored.get('report'))}")
    print(f"  now:    {_outcome(report)}")
    if a.report is not None:
        Path(a.report).write_text(json.dumps(report, indent=2) + "\n")
    if trace is not None:
        out = trace.write_csv(a.trace)
        print(f"trace: {len(trace.rows)} rows to {out}", file=sys.stderr)
    return EXIT_OK


def _compare(a: argparse.Namespace, err: Any) -> int:
    from planning.sweep.compare import CompareError, compare, format_compare

    if a.spec:
        return err("--compare takes two results directories and no SPEC")
    try:
        c = compare(a.compare[0], a.compare[1])
    except CompareError as e:
        return err(f"--compare: {e}")
    print(format_compare(c))
    if a.json:
        try:
            Path(a.json).write_text(json.dumps(c, indent=2) + "\n")
        except OSError as e:
            return err(f"--json {a.json}: cannot write: {e.strerror}")
    return EXIT_OK


def main(a: argparse.Namespace) -> int:
    from planning.sweep.backends import make_backend
    from planning.sweep.runner import run_sweep
    from planning.sweep.spec import SweepSpecError, load_spec, sweep_json_schema
    from planning.sweep.summary import format_table

    def err(msg: str) -> int:
        print(f"footfall: error: {msg}", file=sys.stderr)
        return EXIT_INVALID

    if a.schema:
        print(json.dumps(sweep_json_schema(), indent=2))
        return EXIT_OK
    from planning.sim.trace import trace_args_error

    why = trace_args_error(a.trace, a.trace_every)
    if why is not None:
        return err(why)
    if a.compare:
        return _compare(a, err)
    if a.rerun:
        return _rerun(a, err)
    if a.trace is not None or a.report is not None:
        return err("--trace, --report: only with --rerun CASE")
    if not a.spec:
        return err("SPEC: give a sweep spec file or a shipped sweep's name (footfall sweep push-stand)")
    if a.workers is not None and not (1 <= a.workers <= 1024):
        return err(f"--workers {a.workers}: must be in 1..1024")
    try:
        spec = load_spec(a.spec)
        backend = make_backend(a.backend, a.address, a.workers, spec.timeout_s)
        out = Path(a.out) if a.out else Path("sweep-results") / spec.name
        summary = run_sweep(spec, backend, out)
    except SweepSpecError as e:
        return err(str(e))
    except ValueError as e:
        return err(str(e))
    except ConnectionError as e:
        return err(f"--address {a.address}: {e}")
    print(format_table(summary))
    print(
        f"results in {out}/ (summary.json, cells.csv, cases.csv{', heatmap.png' if summary['heatmap'] else ''})"
    )
    if a.json:
        try:
            Path(a.json).write_text(json.dumps(summary, indent=2) + "\n")
        except OSError as e:
            return err(f"--json {a.json}: cannot write: {e.strerror}")
    return EXIT_CRASHED if summary["overall"]["crashed"] else EXIT_OK
