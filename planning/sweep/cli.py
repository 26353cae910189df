"""`footfall sweep SPEC [--backend local|ray] [--address ADDR] [--out DIR] [--json FILE] [--workers N]`, and
`footfall sweep --compare A B [--json FILE]` (two results directories, paired case by case)."""

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
    return s


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
    if a.compare:
        return _compare(a, err)
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
