"""Running a sweep: its cases on a backend, each result stored as it comes (so an interrupted sweep goes on where
it stopped), a progress line, and the summary written as JSON, CSV and a heat map PNG.

The output directory holds cases/<key>.json (one record per case: the case, its status, attempts and full run
report), summary.json, cells.csv, cases.csv and heatmap.png.
"""

from __future__ import annotations

import json
import os
import sys
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from planning.sweep.backends import LocalBackend, RayBackend
from planning.sweep.cases import code_version, expand
from planning.sweep.heatmap import write_png
from planning.sweep.spec import SweepSpec
from planning.sweep.summary import cases_csv, cells_csv, summarize


class ResultStore:
    """One JSON file per case under DIR/cases, named by the case's key, written atomically."""

    def __init__(self, out_dir: str | Path) -> None:
        self.dir = Path(out_dir)
        self.cases_dir = self.dir / "cases"
        self.cases_dir.mkdir(parents=True, exist_ok=True)

    def path(self, key: str) -> Path:
        return self.cases_dir / f"{key}.json"

    def get(self, key: str) -> dict[str, Any] | None:
        try:
            return json.loads(self.path(key).read_text())  # type: ignore[no-any-return]
        except (OSError, ValueError):
            return None  # absent, or cut short by an interruption: runs again

    def put(self, record: dict[str, Any]) -> None:
        p = self.path(record["key"])
        tmp = p.with_suffix(f".tmp{os.getpid()}.{threading.get_ident()}")
        tmp.write_text(json.dumps(record, separators=(",", ":")))
        tmp.replace(p)

    def write(self, name: str, text: str) -> Path:
        p = self.dir / name
        tmp = p.with_suffix(p.suffix + ".tmp")
        tmp.write_text(text)
        tmp.replace(p)
        return p


class Progress:
    """Cases done, rate, ETA and the running success rate: one updating line on a terminal, else a line at most
    every `every_s` seconds (and at the end)."""

    def __init__(
        self, name: str, total: int, already: int, stream: Any = None, every_s: float = 10.0
    ) -> None:
        self.name = name
        self.total = total
        self.already = already
        self.done = already
        self.ok = 0
        self.finished = 0  # finished with a report in this process (ok counts these and the resumed ones)
        self.crashed = 0
        self.t0 = time.perf_counter()
        self.stream = stream if stream is not None else sys.stderr
        self.tty = bool(getattr(self.stream, "isatty", lambda: False)())
        self.every_s = every_s
        self._last = 0.0

    def count(self, record: dict[str, Any], fresh: bool = True) -> None:
        if fresh:
            self.done += 1
        if record["status"] == "crashed":
            self.crashed += 1
        else:
            self.finished += 1
            self.ok += bool((record.get("report") or {}).get("success"))

    def line(self) -> str:
        el = time.perf_counter() - self.t0
        ran = self.done - self.already
        rate = ran / el if el > 0 else 0.0
        left = self.total - self.done
        eta = left / rate if rate > 0 else float("inf")
        eta_s = "—" if eta == float("inf") else _duration(eta)
        runs = self.finished
        succ = f"{self.ok}/{runs} = {100 * self.ok / runs:.0f} %" if runs else "—"
        crashed = f", {self.crashed} crashed" if self.crashed else ""
        filled = int(20 * self.done / self.total) if self.total else 20
        bar = "[" + "#" * filled + "." * (20 - filled) + "]"
        return (
            f"sweep {self.name} {bar} {self.done}/{self.total} cases{crashed} · {rate * 60:.1f} cases/min · "
            f"ETA {eta_s} · success {succ}"
        )

    def show(self, final: bool = False) -> None:
        now = time.perf_counter()
        if self.tty:
            self.stream.write("\r" + self.line() + "   " + ("\n" if final else ""))
            self.stream.flush()
        elif final or now - self._last >= self.every_s:
            self._last = now
            self.stream.write(self.line() + "\n")
            self.stream.flush()


def _duration(s: float) -> str:
    if s < 90:
        return f"{s:.0f} s"
    if s < 5400:
        return f"{s / 60:.0f} min"
    return f"{s / 3600:.1f} h"


def run_sweep(
    spec: SweepSpec,
    backend: LocalBackend | RayBackend,
    out_dir: str | Path,
    *,
    progress: Progress | bool = True,
    cancelled: Callable[[], bool] = lambda: False,
    on_record: Callable[[dict[str, Any], dict[str, Any]], None] | None = None,
    write_outputs: bool = True,
    on_start: Callable[[dict[str, Any], int], None] | None = None,
    cases: list[dict[str, Any]] | None = None,
) -> dict[str, Any]:
    """Runs the cases of `spec` not yet stored in out_dir and returns the summary (see summary.summarize), with
    "code_version", "backend", "wall_s", "resumed" (cases found stored) and "ran" (cases run now).

    on_record(case, record) is called after each case's record is stored; cases: expand(spec), when the caller
    has them already."""
    if cases is None:
        cases = expand(spec)
    store = ResultStore(out_dir)
    records: dict[str, dict[str, Any]] = {}
    for c in cases:
        r = store.get(c["key"])
        if r is not None:
            records[c["key"]] = r
    by_key: dict[str, dict[str, Any]] = {}
    for c in cases:
        by_key.setdefault(c["key"], c)
    todo = [c for k, c in by_key.items() if k not in records]
    prog: Progress | None
    if progress is True:
        prog = Progress(spec.name, len(by_key), len(by_key) - len(todo))
    else:
        prog = progress or None
    if prog is not None:
        for r in records.values():
            prog.count(r, fresh=False)
    lock = threading.Lock()

    def on_result(record: dict[str, Any]) -> None:
        case = by_key[record["key"]]
        full = {**record, "case": case, "code_version": code_version(), "backend": backend.name}
        store.put(full)
        with lock:
            records[record["key"]] = full
        if prog is not None:
            prog.count(full)
            prog.show()
        if on_record is not None:
            on_record(case, full)

    t0 = time.perf_counter()
    if todo:
        if prog is not None:
            prog.show()
        backend.run(todo, on_result, cancelled, on_start)
    wall = time.perf_counter() - t0
    if prog is not None:
        prog.show(final=True)
    summary = summarize(spec, cases, records)
    summary.update(
        {
            "code_version": code_version(),
            "backend": backend.name,
            "wall_s": round(wall, 3),
            "runs": len(by_key),
            "resumed": len(by_key) - len(todo),
            "ran": sum(1 for c in todo if c["key"] in records),
        }
    )
    if write_outputs:
        write_outputs_to(store, spec, cases, records, summary)
    return summary


def write_outputs_to(
    store: ResultStore,
    spec: SweepSpec,
    cases: list[dict[str, Any]],
    records: dict[str, dict[str, Any]],
    summary: dict[str, Any],
) -> None:
    store.write("summary.json", json.dumps(summary, indent=2) + "\n")
    store.write("cells.csv", cells_csv(summary))
    store.write("cases.csv", cases_csv(cases, records))
    if summary.get("heatmap"):
        write_png(store.dir / "heatmap.png", summary["heatmap"], title=f"sweep {spec.name}: success")
