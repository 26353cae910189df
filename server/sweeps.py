"""Sweeps submitted over REST: a queue of footfall/sweep@1 specs run one at a time by a thread of the server, each
case in a worker process (planning.sweep's local backend with `sim_workers` workers, or Ray).

Case results go to one store under DATA_DIR/sweeps/cases, keyed by case and code version like the CLI's, so a case
that any earlier sweep ran is not run again. What a request may name is narrower than on the command line:
maneuvers by library name only (the shipped library and the user's), robots by built-in name, no probe marks on
disk, and at most MAX_API_SWEEP_RUNS runs of at most the server's max_sim_duration_s each.
"""

from __future__ import annotations

import logging
import re
import secrets
import threading
import time
from collections import OrderedDict, deque
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Literal

from planning.sweep.spec import SweepSpec, SweepSpecError, parse_spec
from server.settings import Settings

log = logging.getLogger("footfall.sweeps")

MAX_API_SWEEP_RUNS = 2000  # distinct runs in one sweep submitted over REST
MAX_PROBE_SLEEP_S = 5.0  # a probe case's sleep over REST
SweepStatus = Literal["queued", "running", "done", "cancelled", "failed"]
BackendFactory = Callable[[Settings], Any]
_SAFE_NAME = re.compile(r"^[a-z0-9][a-z0-9-]{0,63}$")
_LIGHT_FIELDS = ("success", "failure_reason", "fell", "duration_s", "final_pose_error", "foot_placement_error_m",
                 "time_to_goal_s", "time_to_cross_s", "crossed")  # fmt: skip


class SweepQueueFull(Exception):
    """More sweeps are waiting than the queue holds."""


class SweepRejected(Exception):
    """A spec the server will not run; problems as (field, reason)."""

    def __init__(self, problems: list[tuple[str, str]]) -> None:
        self.problems = problems
        super().__init__("; ".join(f"{f}: {r}" if f else r for f, r in problems))


@dataclass
class SweepJob:
    """One submitted sweep and what became of it."""

    id: str
    spec: SweepSpec
    cases: list[dict[str, Any]]
    runs: int
    status: SweepStatus = "queued"
    created: float = field(default_factory=time.time)
    started: float | None = None
    finished: float | None = None
    records: dict[str, dict[str, Any]] = field(default_factory=dict)  # key → light record (no full report)
    error: str | None = None
    cancel: bool = False

    def progress(self) -> dict[str, Any]:
        done = len(self.records)
        crashed = sum(1 for r in self.records.values() if r["status"] == "crashed")
        ok = sum(1 for r in self.records.values() if r["status"] == "done" and r["report"].get("success"))
        finished = done - crashed
        out: dict[str, Any] = {
            "done": done,
            "total": self.runs,
            "crashed": crashed,
            "successes": ok,
            "success_rate": round(ok / finished, 4) if finished else None,
            "rate_per_min": None,
            "eta_s": None,
        }
        if self.started is not None and done:
            el = (self.finished or time.time()) - self.started
            if el > 0:
                rate = done / el
                out["rate_per_min"] = round(rate * 60, 2)
                out["eta_s"] = round((self.runs - done) / rate, 1) if self.status == "running" else 0.0
        return out

    def public(self, position: int | None = None, with_summary: bool = False) -> dict[str, Any]:
        out: dict[str, Any] = {
            "id": self.id,
            "name": self.spec.name,
            "status": self.status,
            "created": self.created,
            "started": self.started,
            "finished": self.finished,
            "cases": len(self.cases),
            "progress": self.progress(),
            "error": self.error,
        }
        if position is not None:
            out["queue_position"] = position
        if with_summary:
            from planning.sweep.summary import summarize

            out["summary"] = summarize(self.spec, self.cases, dict(self.records))
        return out


def _light(record: dict[str, Any]) -> dict[str, Any]:
    rep = record.get("report") or {}
    return {
        "status": record["status"],
        "attempts": record.get("attempts"),
        "wall_s": record.get("wall_s"),
        "error": (record.get("error") or "")[:500] or None,
        "report": {k: rep.get(k) for k in _LIGHT_FIELDS if k in rep},
    }


def check_request(spec: SweepSpec, settings: Settings) -> None:
    """Raises SweepRejected for what a request may not name (see the module docstring)."""
    problems: list[tuple[str, str]] = []
    for r in spec.runs():
        where = f"run.{r.name()}" if isinstance(spec.run, list) else "run"
        if r.maneuver is not None and not _SAFE_NAME.match(r.maneuver):
            problems.append(
                (f"{where}.maneuver", "a library name (lowercase letters, digits, dashes), not a path")
            )
        if r.probe is not None:
            if r.probe.mark_dir is not None:
                problems.append((f"{where}.probe.mark_dir", "not accepted over REST"))
            if r.probe.sleep_s > MAX_PROBE_SLEEP_S:
                problems.append((f"{where}.probe.sleep_s", f"at most {MAX_PROBE_SLEEP_S} s over REST"))
    robots = [spec.defaults.robot]
    named: list[tuple[str, dict[str, Any]]] = [
        ("axes", spec.axes),
        *(("axes", r.axes) for r in spec.runs()),
        ("sampling.repeat", spec.repeat()),
    ]
    for where, axes in named:
        for name in ("robot", "maneuver"):
            ax = axes.get(name)
            if isinstance(ax, list):
                for v in ax:
                    if name == "robot":
                        robots.append(str(v))
                    elif not _SAFE_NAME.match(str(v)):
                        problems.append((f"{where}.{name}", f"{v!r}: a library name, not a path"))
    for rb in robots:
        if not _SAFE_NAME.match(rb):
            problems.append(("robot", f"{rb!r}: a built-in robot name (spot, go1), not a path"))
    d = spec.defaults.duration_s
    if d is not None and d > settings.max_sim_duration_s:
        problems.append(("defaults.duration_s", f"at most {settings.max_sim_duration_s} s on this server"))
    if problems:
        raise SweepRejected(problems)


class SweepManager:
    """Queued sweeps, run one at a time on a thread; each case on the backend's worker processes."""

    def __init__(self, settings: Settings, backend_factory: BackendFactory | None = None) -> None:
        self.settings = settings
        self.backend_factory = backend_factory or _local_backend
        self.store_dir = settings.data_dir / "sweeps" / "cases"
        self._jobs: OrderedDict[str, SweepJob] = OrderedDict()
        self._pending: deque[str] = deque()
        self._lock = threading.Lock()
        self._wake = threading.Event()
        self._thread: threading.Thread | None = None
        self._closed = False

    # ---- public ---------------------------------------------------------------------------------------------------
    def prepare(
        self, doc: Any, inline: dict[str, dict[str, Any]] | None = None
    ) -> tuple[SweepSpec, list[dict[str, Any]]]:
        """Parses, checks and expands a spec document (slow-ish: loads maneuvers); raises SweepRejected.
        inline: maneuver documents by name that win over the library (the studio's open, maybe unsaved, one)."""
        from planning.sweep.cases import expand, maneuver_doc

        try:
            spec = parse_spec(doc)
        except SweepSpecError as e:
            raise SweepRejected([_split(p) for p in e.problems]) from None
        check_request(spec, self.settings)
        from planning.maneuver.load import SHIPPED_LIBRARY

        dirs = (self.settings.library_dir or SHIPPED_LIBRARY, self.settings.user_dir)
        known = dict(inline or {})
        try:
            cases = expand(
                spec, maneuvers=lambda name: known.get(name) or maneuver_doc(name, dirs, allow_paths=False)
            )
        except SweepSpecError as e:
            raise SweepRejected([_split(p) for p in e.problems]) from None
        runs = len({c["key"] for c in cases})
        if runs > MAX_API_SWEEP_RUNS:
            raise SweepRejected(
                [("axes", f"{runs} runs; a sweep over REST may have at most {MAX_API_SWEEP_RUNS}")]
            )
        try:
            from planning.sweep.summary import summarize

            summarize(spec, cases, {})  # summary.by and summary.heatmap name axes of this sweep
        except ValueError as e:
            raise SweepRejected([_split(str(e))]) from None
        return spec, cases

    def submit(self, spec: SweepSpec, cases: list[dict[str, Any]]) -> SweepJob:
        """Queues a prepared sweep; raises SweepQueueFull when `max_queued_simulations` sweeps already wait."""
        with self._lock:
            if len(self._pending) >= self.settings.max_queued_simulations:
                raise SweepQueueFull(
                    f"{len(self._pending)} sweeps are already waiting (the queue holds "
                    f"{self.settings.max_queued_simulations}); try again when some have finished"
                )
            job = SweepJob(secrets.token_hex(8), spec, cases, len({c["key"] for c in cases}))
            self._jobs[job.id] = job
            self._pending.append(job.id)
            self._forget_old()
            if self._thread is None:
                self._thread = threading.Thread(target=self._loop, name="footfall-sweeps", daemon=True)
                self._thread.start()
        self._wake.set()
        return job

    def get(self, sweep_id: str) -> tuple[SweepJob, int | None] | None:
        with self._lock:
            job = self._jobs.get(sweep_id)
            if job is None:
                return None
            pos = self._pending.index(sweep_id) if sweep_id in self._pending else None
            return job, pos

    def list(self) -> list[SweepJob]:
        with self._lock:
            return list(self._jobs.values())

    def cancel(self, sweep_id: str) -> SweepJob | None:
        """Stops a sweep (its running cases are stopped; finished cases stay stored)."""
        with self._lock:
            job = self._jobs.get(sweep_id)
            if job is None:
                return None
            job.cancel = True
            if sweep_id in self._pending:
                self._pending.remove(sweep_id)
                job.status, job.finished = "cancelled", time.time()
            return job

    def record(self, job: SweepJob, key: str) -> dict[str, Any] | None:
        """The full stored record (with the run report) of one of the sweep's cases."""
        from planning.sweep.runner import ResultStore

        if key not in {c["key"] for c in job.cases}:
            return None
        return ResultStore(self.store_dir).get(key)

    def shutdown(self) -> None:
        self._closed = True
        with self._lock:
            for job in self._jobs.values():
                job.cancel = True
        self._wake.set()
        t = self._thread
        if t is not None:
            t.join(10)

    # ---- internals ------------------------------------------------------------------------------------------------
    def _forget_old(self) -> None:
        finished = [j for j in self._jobs.values() if j.status in ("done", "cancelled", "failed")]
        for j in finished[: max(0, len(finished) - self.settings.max_kept_simulations)]:
            del self._jobs[j.id]

    def _loop(self) -> None:
        while not self._closed:
            with self._lock:
                job = self._jobs.get(self._pending.popleft()) if self._pending else None
                if job is not None:
                    job.status, job.started = "running", time.time()
            if job is None:
                self._wake.wait(1.0)
                self._wake.clear()
                continue
            self._run(job)

    def _run(self, job: SweepJob) -> None:
        from planning.sweep.runner import ResultStore, run_sweep

        def on_record(case: dict[str, Any], record: dict[str, Any]) -> None:
            job.records[record["key"]] = _light(record)

        try:
            store = ResultStore(self.store_dir)
            for c in job.cases:  # cases stored by an earlier sweep count at once
                r = store.get(c["key"])
                if r is not None:
                    job.records[c["key"]] = _light(r)
            backend = self.backend_factory(self.settings)
            run_sweep(job.spec, backend, self.store_dir, progress=False, on_record=on_record,
                      cancelled=lambda: job.cancel or self._closed, write_outputs=False, cases=job.cases)  # fmt: skip
        except Exception as e:  # noqa: BLE001 - a failed sweep is the job's result, not the server's
            log.warning("sweep %s failed: %s", job.id, e)
            job.status, job.error = "failed", f"{type(e).__name__}: {e}"[:1000]
        else:
            job.status = "cancelled" if job.cancel else "done"
        job.finished = time.time()


def manager_of(services: Any) -> SweepManager:
    """The service's sweep manager (one per app, for the REST routes and the studio alike), made on first use."""
    manager = getattr(services, "sweeps", None)
    if manager is None:
        manager = SweepManager(services.settings)
        services.sweeps = manager
    return manager


def _split(problem: str) -> tuple[str, str]:
    head, sep, rest = problem.partition(": ")
    if sep and " " not in head.strip():
        return head, rest
    return "", problem


def _local_backend(settings: Settings) -> Any:
    """Local worker processes (sim_workers of them), or Ray tasks with backend ray."""
    from planning.sweep.backends import LocalBackend, RayBackend

    if settings.backend == "ray":
        return RayBackend(settings.ray_address)
    return LocalBackend(workers=max(1, settings.sim_workers))
