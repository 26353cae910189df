"""Where a sweep's cases run: `local` (worker processes on this machine) or `ray` (tasks on a Ray cluster).

Both run the same function (cases.run_case) on the same case dicts and give the same records, one per case, as soon
as each finishes: {"key", "status": "done" | "crashed", "attempts", "report", "error", "wall_s", "worker"}. A case
whose worker dies, that raises, or that runs past the timeout is tried once more; if that fails too it is
recorded as crashed, with the reason. Never lost: every case given to `run` gets exactly one record (unless the
sweep is cancelled, when the cases not yet finished get none).
"""

from __future__ import annotations

import multiprocessing as mp
import os
import time
import traceback
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass
from multiprocessing.connection import Connection, wait
from typing import Any

from planning.sweep.cases import run_case

MAX_ATTEMPTS = 2  # a case is tried at most this many times (once, then retried once)
OnResult = Callable[[dict[str, Any]], None]
Cancelled = Callable[[], bool]


def _record(case: dict[str, Any], status: str, attempts: int, **kw: Any) -> dict[str, Any]:
    return {
        "key": case["key"],
        "status": status,
        "attempts": attempts,
        "report": kw.get("report"),
        "error": kw.get("error"),
        "wall_s": kw.get("wall_s"),
        "worker": kw.get("worker"),
    }


# ---- local ----------------------------------------------------------------------------------------------------
def _worker_main(conn: Connection) -> None:
    """A worker process: runs the cases it is sent, one at a time, and sends back each report or error."""
    while True:
        try:
            params = conn.recv()
        except (EOFError, OSError):
            return
        if params is None:
            return
        t0 = time.perf_counter()
        try:
            report = run_case(params)
            conn.send(("ok", report, time.perf_counter() - t0))
        except Exception as e:  # noqa: BLE001 - any error of a run is this case's outcome
            tb = traceback.format_exc(limit=6)
            conn.send(("error", f"{type(e).__name__}: {e}\n{tb}", time.perf_counter() - t0))


@dataclass
class _Slot:
    proc: Any
    conn: Connection
    case: dict[str, Any] | None = None
    attempt: int = 0
    t_start: float = 0.0


class LocalBackend:
    """A pool of worker processes (spawned, one per core by default), each running one case at a time."""

    name = "local"

    def __init__(self, workers: int | None = None, timeout_s: float | None = None) -> None:
        self.workers = max(1, workers or os.cpu_count() or 1)
        self.timeout_s = timeout_s
        self._ctx = mp.get_context("spawn")

    def _start(self) -> _Slot:
        parent, child = self._ctx.Pipe()
        proc = self._ctx.Process(
            target=_worker_main, args=(child,), daemon=True, name="footfall-sweep-worker"
        )
        proc.start()
        child.close()
        return _Slot(proc, parent)

    def run(
        self,
        cases: list[dict[str, Any]],
        on_result: OnResult,
        cancelled: Cancelled = lambda: False,
        on_start: Callable[[dict[str, Any], int], None] | None = None,
    ) -> None:
        todo: deque[tuple[dict[str, Any], int]] = deque((c, 1) for c in cases)
        slots = [self._start() for _ in range(min(self.workers, len(cases)))]

        def failed(slot: _Slot, reason: str) -> None:
            case, attempt = slot.case, slot.attempt
            assert case is not None
            slot.case = None
            if attempt < MAX_ATTEMPTS:
                todo.appendleft((case, attempt + 1))
            else:
                on_result(
                    _record(case, "crashed", attempt, error=reason, wall_s=time.perf_counter() - slot.t_start)
                )

        try:
            while True:
                if cancelled():
                    return
                for slot in slots:
                    if slot.case is None and todo:
                        slot.case, slot.attempt = todo.popleft()
                        slot.t_start = time.perf_counter()
                        slot.conn.send(slot.case["params"])
                        if on_start is not None:
                            on_start(slot.case, slot.proc.pid)
                busy = [s for s in slots if s.case is not None]
                if not busy:
                    return
                wait([s.conn for s in busy] + [s.proc.sentinel for s in busy], timeout=0.5)
                for i, slot in enumerate(slots):
                    if slot.case is None:
                        continue
                    msg = None
                    try:
                        if slot.conn.poll():
                            msg = slot.conn.recv()
                    except (EOFError, OSError):
                        msg = None
                    if msg is not None:
                        kind, payload, wall = msg
                        if kind == "ok":
                            case, slot.case = slot.case, None
                            on_result(
                                _record(
                                    case,
                                    "done",
                                    slot.attempt,
                                    report=payload,
                                    wall_s=wall,
                                    worker=slot.proc.pid,
                                )
                            )
                        else:
                            failed(slot, payload)
                        continue
                    dead = not slot.proc.is_alive()
                    late = self.timeout_s is not None and time.perf_counter() - slot.t_start > self.timeout_s
                    if dead or late:
                        reason = (
                            f"worker {slot.proc.pid} died (exit code {slot.proc.exitcode})"
                            if dead
                            else f"ran past the sweep's timeout_s ({self.timeout_s} s) and was stopped"
                        )
                        if not dead:
                            slot.proc.kill()
                        slot.proc.join(5)
                        slot.conn.close()
                        fresh = self._start()
                        fresh.case, fresh.attempt, fresh.t_start = slot.case, slot.attempt, slot.t_start
                        slots[i] = fresh
                        failed(fresh, reason)
        finally:
            for slot in slots:
                try:
                    if slot.case is None:
                        slot.conn.send(None)
                except (OSError, ValueError):
                    pass
            for slot in slots:
                if slot.case is not None:
                    slot.proc.kill()
                slot.proc.join(2)
                if slot.proc.is_alive():
                    slot.proc.kill()
                slot.conn.close()


# ---- ray ------------------------------------------------------------------------------------------------------
def _ray_case(params: dict[str, Any]) -> tuple[dict[str, Any], float, int]:
    t0 = time.perf_counter()
    report = run_case(params)
    return report, time.perf_counter() - t0, os.getpid()


class RayBackend:
    """Cases as Ray tasks (one CPU each) on the cluster at `address`, or on a local Ray started on the spot.
    Results are taken as they finish; at most `window` tasks are submitted ahead of the results."""

    name = "ray"

    def __init__(
        self,
        address: str | None = None,
        num_cpus: int | None = None,
        timeout_s: float | None = None,
        window: int = 512,
    ) -> None:
        self.address = address
        self.num_cpus = num_cpus
        self.timeout_s = timeout_s
        self.window = window

    def init(self) -> Any:
        try:
            import ray
        except ImportError as e:  # pragma: no cover - ray is a dependency
            raise RuntimeError(f"the ray backend needs the ray package: {e}") from None
        if not ray.is_initialized():
            kw: dict[str, Any] = {
                "include_dashboard": False,
                "log_to_driver": False,
                "configure_logging": False,
            }
            if self.address:
                ray.init(address=self.address, **kw)
            else:
                ray.init(num_cpus=self.num_cpus or os.cpu_count(), **kw)
        return ray

    def run(
        self,
        cases: list[dict[str, Any]],
        on_result: OnResult,
        cancelled: Cancelled = lambda: False,
        on_start: Callable[[dict[str, Any], int], None] | None = None,
    ) -> None:
        ray = self.init()
        from ray.exceptions import GetTimeoutError, RayError, RayTaskError

        task = ray.remote(num_cpus=1, max_retries=0)(_ray_case)
        window = self.window
        if self.timeout_s is not None:  # a task's clock starts at submission: submit no more than can run
            window = max(1, int(ray.cluster_resources().get("CPU", 1)))
        todo: deque[tuple[dict[str, Any], int]] = deque((c, 1) for c in cases)
        flying: dict[Any, tuple[dict[str, Any], int, float]] = {}
        try:
            while todo or flying:
                if cancelled():
                    for ref in flying:
                        ray.cancel(ref, force=True)
                    return
                while todo and len(flying) < window:
                    case, attempt = todo.popleft()
                    flying[task.remote(case["params"])] = (case, attempt, time.perf_counter())
                done, _ = ray.wait(list(flying), num_returns=min(len(flying), 256), timeout=0.2)
                for ref in done:
                    case, attempt, t0 = flying.pop(ref)
                    error = None
                    try:
                        report, wall, pid = ray.get(ref)
                    except RayTaskError as e:
                        error = f"{type(e.cause).__name__ if e.cause else 'error'}: {e.cause or e}"
                    except (
                        RayError,
                        GetTimeoutError,
                    ) as e:  # the worker died (killed, out of memory, node lost)
                        error = f"{type(e).__name__}: {str(e).splitlines()[0] if str(e) else ''}"
                    if error is None:
                        on_result(_record(case, "done", attempt, report=report, wall_s=wall, worker=pid))
                    elif attempt < MAX_ATTEMPTS:
                        todo.appendleft((case, attempt + 1))
                    else:
                        on_result(
                            _record(case, "crashed", attempt, error=error, wall_s=time.perf_counter() - t0)
                        )
                if self.timeout_s is not None:
                    now = time.perf_counter()
                    for ref, (case, attempt, t0) in list(flying.items()):
                        if now - t0 > self.timeout_s:
                            ray.cancel(ref, force=True)
                            del flying[ref]
                            reason = f"ran past the sweep's timeout_s ({self.timeout_s} s) and was stopped"
                            if attempt < MAX_ATTEMPTS:
                                todo.appendleft((case, attempt + 1))
                            else:
                                on_result(_record(case, "crashed", attempt, error=reason, wall_s=now - t0))
        finally:
            for ref in flying:
                ray.cancel(ref, force=True)


def make_backend(
    name: str, address: str | None = None, workers: int | None = None, timeout_s: float | None = None
) -> LocalBackend | RayBackend:
    """The backend named `local` or `ray` (ValueError otherwise)."""
    if name == "local":
        if address:
            raise ValueError("--address is for the ray backend")
        return LocalBackend(workers, timeout_s)
    if name == "ray":
        return RayBackend(address, workers, timeout_s)
    raise ValueError(f"unknown backend {name!r} (local or ray)")
