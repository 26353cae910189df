"""Queued headless simulations: a bounded queue in front of a small pool of worker processes, with progress.

Simulations are CPU-bound Python: they run in worker processes (spawned, not forked: the server has threads) so
they neither hold the server's GIL nor take it down if MuJoCo crashes. The pool keeps at most `sim_workers` jobs in
flight and the rest in its own queue, so a crashed worker fails only the job it was running; the pool is then
rebuilt. Workers report progress through a queue that a thread of the server drains into the job table.
"""

from __future__ import annotations

import contextlib
import functools
import logging
import multiprocessing as mp
import queue
import secrets
import threading
import time
from collections import OrderedDict, deque
from collections.abc import Callable
from concurrent.futures import Future, ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass, field
from typing import Any, Literal

from server.settings import Settings

log = logging.getLogger("footfall.simulations")

JobStatus = Literal["queued", "running", "done", "failed", "cancelled"]
Runner = Callable[[dict[str, Any]], dict[str, Any]]

_progress_queue: Any = None  # set in each worker process by _init_worker


def _init_worker(q: Any) -> None:
    global _progress_queue
    _progress_queue = q


def worker_progress(job_id: str) -> Callable[[float, float, float], None] | None:
    """Returns a progress callback (t s, duration s, rtf) for a job running in this worker, or None outside one."""
    q = _progress_queue
    if q is None:
        return None

    def report(t: float, duration: float, rtf: float) -> None:
        try:
            q.put_nowait((job_id, float(t), float(duration), float(rtf)))
        except Exception:  # noqa: BLE001 - progress is best effort; a full or closed queue must not fail the run
            pass

    report(0.0, 0.0, 0.0)  # marks the job as started in this worker
    return report


class QueueFull(Exception):
    """More simulations are waiting than the queue holds."""


@dataclass
class Job:
    """One simulation request and what became of it."""

    id: str
    request: dict[str, Any]  # what was asked (maneuver name, terrain, pushes, ...), for the answer
    payload: dict[str, Any]  # what the worker gets
    status: JobStatus = "queued"
    created: float = field(default_factory=time.time)
    started: float | None = None
    finished: float | None = None
    progress: dict[str, float] = field(default_factory=dict)
    report: dict[str, Any] | None = None
    error: str | None = None

    def public(self, position: int | None = None) -> dict[str, Any]:
        out: dict[str, Any] = {
            "id": self.id,
            "status": self.status,
            "request": self.request,
            "created": self.created,
            "started": self.started,
            "finished": self.finished,
            "progress": self.progress or None,
            "report": self.report,
            "error": self.error,
        }
        if position is not None:
            out["queue_position"] = position
        return out


class SimulationPool:
    """Runs submitted jobs on worker processes, at most `settings.sim_workers` at a time."""

    def __init__(self, settings: Settings, runner: Runner | None = None) -> None:
        from server.engine import run_headless

        self.settings = settings
        self.runner: Runner = runner or run_headless
        self._jobs: OrderedDict[str, Job] = OrderedDict()
        self._pending: deque[str] = deque()
        self._in_flight: set[str] = set()
        self._lock = threading.RLock()  # re-entrant: a done callback may run inside _dispatch
        self._ctx = mp.get_context("spawn")
        self._executor: ProcessPoolExecutor | None = None
        self._progress: Any = None
        self._drain: threading.Thread | None = None
        self._closed = False
        self._ray_task: Any = None

    # ---- public ---------------------------------------------------------------------------------------------------
    def submit(self, request: dict[str, Any], payload: dict[str, Any]) -> Job:
        """Queues a job; raises QueueFull when `max_queued_simulations` are already waiting."""
        with self._lock:
            if len(self._pending) >= self.settings.max_queued_simulations:
                raise QueueFull(
                    f"{len(self._pending)} simulations are already waiting (the queue holds "
                    f"{self.settings.max_queued_simulations}); try again when some have finished"
                )
            job = Job(secrets.token_hex(8), request, {**payload})
            job.payload["id"] = job.id
            self._jobs[job.id] = job
            self._pending.append(job.id)
            self._forget_old()
        self._dispatch()
        return job

    def get(self, job_id: str) -> tuple[Job, int | None] | None:
        """Returns (job, its place in the queue or None) or None when unknown."""
        with self._lock:
            job = self._jobs.get(job_id)
            if job is None:
                return None
            pos = self._pending.index(job_id) if job.status == "queued" and job_id in self._pending else None
            return job, pos

    def cancel(self, job_id: str) -> Job | None:
        """Cancels a queued job (it never runs); returns it, or None when unknown. A job already running or
        finished is returned unchanged: the caller tells the user it is too late."""
        with self._lock:
            job = self._jobs.get(job_id)
            if job is not None and job.status == "queued" and job_id in self._pending:
                self._pending.remove(job_id)
                job.status, job.finished = "cancelled", time.time()
            return job

    @property
    def closed(self) -> bool:
        """True once shut down: nothing queued runs any more."""
        return self._closed

    def list(self) -> list[Job]:
        with self._lock:
            return list(self._jobs.values())

    def shutdown(self, grace_s: float = 2.0) -> None:
        """Ends every worker process this pool started: queued jobs are dropped, a running one is terminated
        (SIGTERM, then SIGKILL after `grace_s`), so no worker outlives the server (nor the resource tracker that
        multiprocessing keeps for them, which exits when they are gone)."""
        self._closed = True
        ex, self._executor = self._executor, None
        if ex is not None:
            workers = list((getattr(ex, "_processes", None) or {}).values())
            ex.shutdown(wait=False, cancel_futures=True)
            for w in workers:
                with contextlib.suppress(Exception):
                    w.terminate()
            deadline = time.monotonic() + grace_s
            for w in workers:
                with contextlib.suppress(Exception):
                    w.join(max(0.0, deadline - time.monotonic()))
                    if w.is_alive():
                        w.kill()
                        w.join(1.0)
        if self._progress is not None:
            try:
                self._progress.put_nowait(None)
            except Exception:  # noqa: BLE001
                pass

    # ---- internals ------------------------------------------------------------------------------------------------
    def _forget_old(self) -> None:
        finished = [j for j in self._jobs.values() if j.status in ("done", "failed", "cancelled")]
        for j in finished[: max(0, len(finished) - self.settings.max_kept_simulations)]:
            del self._jobs[j.id]

    def _ensure_executor(self) -> ProcessPoolExecutor:
        if self._executor is None:
            if self._progress is None:
                self._progress = self._ctx.Queue(maxsize=1000)
                self._drain = threading.Thread(
                    target=self._drain_progress, name="footfall-sim-progress", daemon=True
                )
                self._drain.start()
            self._executor = ProcessPoolExecutor(
                max_workers=self.settings.sim_workers,
                mp_context=self._ctx,
                initializer=_init_worker,
                initargs=(self._progress,),
            )
        return self._executor

    def _submit(self, payload: dict[str, Any]) -> Future[dict[str, Any]]:
        """Starts one job: on a worker process of the pool, or (backend ray) as a Ray task, retried once if its
        worker dies."""
        if self.settings.backend == "ray":
            if self._ray_task is None:
                from planning.sweep.backends import RayBackend

                ray = RayBackend(self.settings.ray_address).init()
                self._ray_task = ray.remote(num_cpus=1, max_retries=1)(self.runner)
            return self._ray_task.remote(payload).future()  # type: ignore[no-any-return]
        return self._ensure_executor().submit(self.runner, payload)

    def _dispatch(self) -> None:
        with self._lock:
            if self._closed:
                return
            while self._pending and len(self._in_flight) < self.settings.sim_workers:
                job = self._jobs.get(self._pending.popleft())
                if job is None:
                    continue
                try:
                    fut = self._submit(job.payload)
                except (BrokenProcessPool, RuntimeError) as e:
                    self._executor = None
                    job.status, job.error, job.finished = (
                        "failed",
                        f"could not start a worker: {e}",
                        time.time(),
                    )
                    continue
                self._in_flight.add(job.id)
                job.status, job.started = "running", time.time()
                fut.add_done_callback(functools.partial(self._done, job.id))

    def _done(self, job_id: str, fut: Future[dict[str, Any]]) -> None:
        with self._lock:
            self._in_flight.discard(job_id)
            job = self._jobs.get(job_id)
            try:
                report = fut.result()
            except BrokenProcessPool:
                self._executor = None  # rebuilt on the next dispatch
                err: str | None = "the simulation worker crashed (the process died); the run was not finished"
                report = None
            except Exception as e:  # noqa: BLE001 - a failed run is the job's result, not the server's
                err, report = f"{type(e).__name__}: {e}"[:1000], None
            else:
                err = None
            if job is not None:
                job.finished = time.time()
                job.started = job.started or job.finished
                if err is None and isinstance(report, dict):
                    job.status, job.report = "done", report
                    if "duration_s" in report:
                        job.progress = {**job.progress, "t": float(report["duration_s"]), "fraction": 1.0}
                else:
                    job.status, job.error = "failed", err or "the run returned no report"
        if err is not None:
            log.warning("simulation %s failed: %s", job_id, err)
        self._dispatch()

    def _drain_progress(self) -> None:
        q = self._progress
        while True:
            try:
                item = q.get(timeout=1.0)
            except queue.Empty:
                if self._closed:
                    return
                continue
            except (EOFError, OSError):
                return
            if item is None:
                return
            job_id, t, duration, rtf = item
            with self._lock:
                job = self._jobs.get(job_id)
                if job is None or job.status in ("done", "failed", "cancelled"):
                    continue
                if duration > 0:
                    job.progress = {
                        "t": round(t, 3),
                        "duration": round(duration, 3),
                        "fraction": round(min(1.0, t / duration), 4),
                        "rtf": round(rtf, 3),
                    }
