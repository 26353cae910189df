"""Live sessions in worker processes: each session's simulation loop runs in a child process of its own.

The child (`worker_main`) runs an ordinary thread-stepped `LiveSession` on its own interpreter, so sessions no longer
share one GIL: four sessions on two cores each get their share of a core instead of a quarter of one interpreter.
The server keeps a `ProcessSession` with `LiveSession`'s public API (the REST routes and the studio call it
unchanged); it forwards commands over a pipe and mirrors what the child publishes.

- Commands (push, steer, pause, resume, speed, reset, start a maneuver, plan, report, visuals, stop) are requests
  with an id; the caller waits for the child's answer (bounded by a timeout, never forever).
- The child publishes at most one message per snapshot (≤ 60 Hz): the newest state and body poses, plus the plot
  samples and recorded frames made since its last message. It sends from its own I/O thread while the stepping
  thread keeps going, so a slow reader delays only that message, which then carries the newest pose: the backlog is
  never more than one message.
- An exception in the child's simulation marks the session crashed (the child stays, a reset revives it), exactly
  as a thread session. A child that dies (kill -9, a segfault in MuJoCo) closes its end of the pipe: the server's
  reader sees the end of file at once, marks the session crashed with the exit code, fails the requests in flight
  and reaps the process; a reset starts a new child.
- Children are started by a fork server preloaded with numpy, MuJoCo and the planning stack (never a fork of the
  threaded server), so a new session costs a fork and a scene build, not an interpreter start. A child ends when
  its pipe closes: when the session stops, and when the server exits or dies (nothing keeps the pipe open).
"""

from __future__ import annotations

import contextlib
import itertools
import logging
import multiprocessing as mp
import os
import signal
import sys
import threading
import time
from dataclasses import dataclass
from typing import Any

# The children each use one core; BLAS thread pools would oversubscribe it. Only effective where numpy is not loaded
# yet (the fork server imports this module first).
if "numpy" not in sys.modules:
    for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ.setdefault(_var, "1")

import numpy as np

from server.sessions import (
    MAX_FRAMES,
    PUBLISH_PERIOD_S,
    LiveSession,
    Mode,
    PlotSample,
    Recording,
    SessionBadInput,
    SessionCrashed,
    SessionError,
    SessionLimit,
    SessionNotFound,
    SimFactory,
    Snapshot,
)

log = logging.getLogger("footfall.sessions")

# Python 3.11's fork server ignores the parent's sys.path: the parent passes it in this variable (set before the fork
# server starts), so what it preloads (e.g. a test's fake simulation module) is found there and not imported anew by
# every child.
_PATH_VAR = "FOOTFALL_FORKSERVER_SYS_PATH"
for _p in os.environ.get(_PATH_VAR, "").split(os.pathsep):
    if _p and _p not in sys.path:
        sys.path.append(_p)

START_TIMEOUT_S = 120.0  # a new worker: fork, scene build, controller setup (seconds on a loaded machine)
REPLACE_TIMEOUT_S = 60.0  # starting a maneuver or a reset builds a new simulation in the worker
REQUEST_TIMEOUT_S = 10.0  # any other command (push, steer, pause, plan, ...)
STOP_GRACE_S = 2.0  # a stopping worker may take this long to end by itself before it is terminated
_PRELOAD = ["server.session_worker", "server.engine", "planning.sim.run"]
_ERRORS: dict[str, type[SessionError]] = {
    c.__name__: c for c in (SessionError, SessionNotFound, SessionLimit, SessionCrashed, SessionBadInput)
}
_ctx_lock = threading.Lock()
_ctx: Any = None


def worker_context(factory: Any = None) -> Any:
    """Returns the multiprocessing context the session workers start from: a fork server preloaded with the
    simulation's imports (and those of the first factory's module), on Linux and macOS; else spawn."""
    global _ctx
    with _ctx_lock:
        if _ctx is None:
            if "forkserver" in mp.get_all_start_methods():
                _ctx = mp.get_context("forkserver")
                os.environ[_PATH_VAR] = os.pathsep.join(p for p in sys.path if p)
                extra = getattr(factory, "__module__", None)
                _ctx.set_forkserver_preload(_PRELOAD + ([extra] if extra and extra not in _PRELOAD else []))
            else:  # pragma: no cover - Windows
                _ctx = mp.get_context("spawn")
        return _ctx


# ---- the child --------------------------------------------------------------------------------------------------
class _Publisher:
    """The child's view of what it has sent: it turns the session's state into messages of what is new."""

    def __init__(self, s: LiveSession) -> None:
        self.s = s
        self.seq = -1
        self.generation = -1
        self.plot_n = 0
        self.frames_n = 0
        self.maneuver_id = 0  # id() of the maneuver object sent last: it is sent again only when it changes

    def message(self, force: bool = False) -> dict[str, Any] | None:
        s = self.s
        if s.snapshot.seq == self.seq and not force:
            return None  # nothing new (checked without waiting for a batch in flight)
        with s.lock:
            snap = s.snapshot
            if snap.seq == self.seq and not force:
                return None
            self.seq = snap.seq
            rec = s.recording
            new_rec = None
            if s.generation != self.generation:
                self.generation = s.generation
                self.frames_n = 0
                self.plot_n = 0
                new_rec = (rec.maneuver, rec.terrain)
            k = min(rec.n - self.frames_n, len(rec.t))
            frames = (list(rec.t)[-k:], list(rec.xpos)[-k:], list(rec.xquat)[-k:]) if k > 0 else None
            self.frames_n = rec.n
            kp = min(s.plot_n - self.plot_n, len(s.plot))
            plot = list(s.plot)[-kp:] if kp > 0 else []
            self.plot_n = s.plot_n
            meta = s._meta()
            maneuver = getattr(s.sim, "maneuver", None)
            if id(maneuver) == self.maneuver_id and new_rec is None and not force:
                maneuver = None  # unchanged (a maneuver document can be tens of kB: not 60 times a second)
            else:
                self.maneuver_id = id(maneuver)
        return {
            "snap": snap,
            "meta": meta,
            "steps": s.steps,
            "new_rec": new_rec,
            "frames": frames,
            "plot": plot,
            "maneuver": maneuver,
        }


def _do(s: LiveSession, op: str, args: tuple[Any, ...]) -> Any:
    if op == "start":
        s.start()
    elif op == "start_maneuver":
        s.start_maneuver(args[0])
    elif op == "restart":
        s.restart()
    elif op == "reset":
        s.reset(*args)
    elif op == "pause":
        s.pause()
    elif op == "resume":
        s.resume()
    elif op == "set_speed":
        s.set_speed(*args)
    elif op == "push":
        s.push(*args)
    elif op == "steer":
        s.steer(*args)
    elif op == "plan":
        return s.plan()
    elif op == "report":
        return s.report()
    elif op == "visuals":
        with s.lock:
            fn = getattr(s.sim, "visuals", None)
            return fn() if callable(fn) else None
    elif op == "setattr":  # tests: set an attribute of the simulation (e.g. make a fake one crash)
        with s.lock:
            setattr(s.sim, args[0], args[1])
    else:
        raise SessionError(f"unknown session command {op!r}")
    return None


def worker_main(conn: Any, session_id: str, terrain: str, mode: Mode, robot: str, factory: SimFactory,
                origin: str, maps: str) -> None:  # fmt: skip
    """The child: builds the session, answers commands, publishes what is new until its pipe closes."""
    with contextlib.suppress(ValueError, OSError):
        signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C goes to the server, which stops its workers
    try:
        s = LiveSession(session_id, terrain, mode, robot, factory, origin, maps=maps)
    except BaseException as e:  # noqa: BLE001 - reported to the server, which raises it to the caller
        with contextlib.suppress(OSError):
            conn.send(("fatal", f"{type(e).__name__}: {e}"[:500]))
        return
    pub = _Publisher(s)
    send_lock = threading.Lock()

    def send(msg: Any) -> bool:
        try:
            with send_lock:
                conn.send(msg)
            return True
        except (OSError, ValueError):
            return False

    stop = threading.Event()

    def publisher() -> None:
        # its own thread: a blocked send (a slow reader) holds neither the commands nor the stepping
        while not stop.wait(PUBLISH_PERIOD_S / 2):
            with send_lock:  # never in between a command's snapshot and its answer
                msg = pub.message()
                if msg is None:
                    continue
                try:
                    conn.send(("snap", msg))
                except (OSError, ValueError):
                    return

    send(("ready", float(s.sim.dt), pub.message(force=True)))
    pub_thread = threading.Thread(target=publisher, name="footfall-publisher", daemon=True)
    pub_thread.start()
    try:
        while True:
            try:
                op, rid, args = conn.recv()
            except (EOFError, OSError):
                break  # the server closed the pipe or died: end
            if op == "close":
                break
            try:
                value, err = _do(s, op, args), None
            except SessionError as e:
                value, err = None, (type(e).__name__, e.message, e.field)
            except Exception as e:  # noqa: BLE001 - any failure is the caller's error, not the worker's end
                value, err = None, ("SessionError", f"{type(e).__name__}: {e}"[:500], "")
            with send_lock:
                try:
                    conn.send(
                        ("snap", pub.message(force=True))
                    )  # the state as of the command, then the answer
                    conn.send(("reply", rid, value, err))
                except (OSError, ValueError):
                    break
    finally:
        stop.set()
        s.stop()
        with contextlib.suppress(OSError):
            conn.close()


# ---- the server's side --------------------------------------------------------------------------------------------
@dataclass
class _Pending:
    event: threading.Event
    value: Any = None
    error: tuple[str, str, str] | None = None


class RemoteSim:
    """What callers read of a session's simulation (`session.sim`) when it runs in a worker: its time, maneuver and
    step from the newest snapshot; visuals, plan and report asked of the worker."""

    def __init__(self, session: ProcessSession) -> None:
        self._session = session
        self.dt = 0.002
        self.maneuver: Any = None
        self._visuals: tuple[int, Any] | None = None

    @property
    def terrain(self) -> str:
        return self._session.terrain

    @property
    def t(self) -> float:
        return float(self._session.snapshot.state.get("t") or 0.0)

    def visuals(self) -> Any:
        """The scene's visuals (cached per simulation: they change only when it is replaced)."""
        gen = self._session.generation
        if self._visuals is None or self._visuals[0] != gen:
            self._visuals = (gen, self._session._call("visuals"))
        return self._visuals[1]

    def plan_dict(self) -> dict[str, Any]:
        return dict(self._session._call("plan"))

    def report(self, wall_s: float) -> dict[str, Any]:
        return dict(self._session._call("report"))

    def __setattr__(self, name: str, value: Any) -> None:
        if name.startswith("_") or name in ("dt", "maneuver"):
            object.__setattr__(self, name, value)
        else:  # an attribute of the simulation itself: set in the worker
            self._session._call("setattr", name, value)


class ProcessSession(LiveSession):
    """A live session whose simulation runs in a worker process; the same API as `LiveSession`."""

    def __init__(
        self,
        session_id: str,
        terrain: str,
        mode: Mode,
        robot: str,
        factory: SimFactory,
        origin: str = "api",
        clock: Any = time.monotonic,
        maps: str = "truth",
    ) -> None:
        # not LiveSession.__init__: the simulation is built in the worker
        self._init_fields(session_id, terrain, mode, robot, factory, origin, clock, maps)
        self._meta_cache: dict[str, Any] = {}
        self._rec_ops: list[tuple[str, Any]] = []  # recording changes waiting for self.lock (see _apply)
        self._send_lock = threading.Lock()
        self._pending: dict[int, _Pending] = {}
        self._pending_lock = threading.Lock()
        self._rid = itertools.count(1)
        self._stopping = False
        self._started = False
        self._dead: str | None = None
        self.sim = RemoteSim(self)  # type: ignore[assignment]
        self.snapshot = Snapshot(0, time.time(), {}, np.zeros((0, 3)), np.zeros((0, 4)))
        self._spawn()

    # ---- the worker ---------------------------------------------------------------------------------------------
    def _spawn(self) -> None:
        """Starts a worker and waits until its simulation is built (SessionError when it cannot be)."""
        ctx = worker_context(self._factory)
        parent, child = ctx.Pipe(duplex=True)
        proc = ctx.Process(
            target=worker_main,
            args=(child, self.id, self.terrain, self.mode, self.robot, self._factory, self.origin, self.maps),
            name=f"footfall-session-{self.id}",
            daemon=True,  # ended by multiprocessing's exit handler if the server exits without stopping it
        )
        proc.start()
        child.close()  # only the worker holds its end now: its death is the end of file here
        try:
            if not parent.poll(START_TIMEOUT_S):
                raise SessionError(f"the session's worker did not start within {START_TIMEOUT_S:.0f} s",
                                   field="sessions")  # fmt: skip
            msg = parent.recv()
        except (EOFError, OSError):
            msg = ("fatal", "the session's worker ended while starting")
        except SessionError:
            msg = ("fatal", f"the session's worker did not start within {START_TIMEOUT_S:.0f} s")
        if msg[0] != "ready":
            parent.close()
            self._reap(proc)
            raise SessionError(f"could not start the session: {msg[1]}", field="terrain")
        self.sim.dt = msg[1]
        self._proc = proc
        self._conn = parent
        self._dead = None
        self._apply(msg[2])
        self._reader = threading.Thread(target=self._read, args=(proc, parent), name=f"footfall-session-{self.id}",
                                        daemon=True)  # fmt: skip
        self._reader.start()

    @staticmethod
    def _reap(proc: Any) -> None:
        proc.join(STOP_GRACE_S)
        if proc.is_alive():
            proc.terminate()
            proc.join(1.0)
        if proc.is_alive():
            proc.kill()
            proc.join(1.0)

    @property
    def pid(self) -> int | None:
        return int(self._proc.pid) if self._proc.pid is not None else None

    def _read(self, proc: Any, conn: Any) -> None:
        """The reader thread: applies what the worker publishes, hands answers to their callers, notices its end."""
        while True:
            try:
                msg = conn.recv()
            except (EOFError, OSError):
                break
            except Exception as e:  # noqa: BLE001 - a message that does not unpickle: report, keep reading
                log.warning("session %s: unreadable message from its worker: %r", self.id, e)
                continue
            if msg[0] == "snap":
                self._apply(msg[1])
            elif msg[0] == "reply":
                with self._pending_lock:
                    p = self._pending.pop(msg[1], None)
                if p is not None:
                    p.value, p.error = msg[2], msg[3]
                    p.event.set()
        with contextlib.suppress(OSError):
            conn.close()
        proc.join(0.5 if not self._stopping else STOP_GRACE_S)
        if conn is not self._conn:  # an earlier worker, replaced by a reset
            return
        if not self._stopping:
            code = proc.exitcode
            how = f"killed by signal {-code}" if code is not None and code < 0 else f"exit code {code}"
            self._dead = f"WorkerDied: the session's worker process ended ({how})"
            self.status = "crashed"
            self.error = self._dead
            log.warning("session %s crashed: %s", self.id, self._dead)
            self._publish_meta()
        with self._pending_lock:
            pending, self._pending = list(self._pending.values()), {}
        for p in pending:
            p.error = ("SessionCrashed", f"session {self.id} crashed ({self._dead or 'stopped'})", "id")
            p.event.set()

    def _apply(self, m: dict[str, Any] | None) -> None:
        """Takes in one published message: the snapshot, the session's status, new plot samples and frames."""
        if m is None:
            return
        meta = m["meta"]
        self._meta_cache = meta
        if m["maneuver"] is not None:
            self.sim.maneuver = m["maneuver"]
        if self._dead is None:
            self.status = meta["status"]
            self.error = meta["error"]
        self.mode, self.terrain, self.maps = meta["mode"], meta["terrain"], meta["maps"]
        self.robot = meta.get("robot", self.robot)
        self.speed, self.command = meta["speed"], meta["command"]
        self.rtf, self.dropped_s, self.steps = meta["realtime_factor"], meta["dropped_s"], m["steps"]
        if m["new_rec"] is not None:
            self._rec_ops.append(("new", m["new_rec"]))
        if m["frames"] is not None:
            self._rec_ops.append(("frames", m["frames"]))
        # never wait for self.lock here: a caller may hold it while it waits for an answer this thread delivers
        if self._rec_ops and self.lock.acquire(blocking=False):
            try:
                for op, v in self._rec_ops:
                    if op == "new":
                        self.recording = Recording(v[0], v[1])
                    else:
                        rec = self.recording
                        rec.t.extend(v[0])
                        rec.xpos.extend(v[1])
                        rec.xquat.extend(v[2])
                        rec.n += len(v[0])
                self._rec_ops.clear()
            finally:
                self.lock.release()
        elif len(self._rec_ops) > MAX_FRAMES:
            del self._rec_ops[: len(self._rec_ops) - MAX_FRAMES]
        if m["new_rec"] is not None:
            self.plot.clear()
        samples: list[PlotSample] = m["plot"]
        self.plot.extend(samples)
        self.plot_n += len(samples)
        self._seq += 1
        s = m["snap"]
        self.snapshot = Snapshot(self._seq, s.wall, s.state, s.xpos, s.xquat, s.sim_json)
        self.generation = meta["generation"] + self._generation_base

    _generation_base = 0  # bumped when a reset starts a new worker (its generations start again at 0)

    def _publish_meta(self) -> None:
        s = self.snapshot
        self._seq += 1
        self.snapshot = Snapshot(
            self._seq, time.time(), {**s.state, **self._meta()}, s.xpos, s.xquat, s.sim_json
        )

    def _call(self, op: str, *args: Any, timeout: float = REQUEST_TIMEOUT_S) -> Any:
        """Sends a command to the worker and returns its answer; raises what it raised, SessionCrashed when the
        worker is gone, SessionError when it does not answer in time."""
        if self._dead is not None:
            raise SessionCrashed(f"session {self.id} crashed ({self._dead}); reset it first", field="id")
        rid = next(self._rid)
        p = _Pending(threading.Event())
        with self._pending_lock:
            self._pending[rid] = p
        try:
            with self._send_lock:
                self._conn.send((op, rid, args))
        except (OSError, ValueError):
            with self._pending_lock:
                self._pending.pop(rid, None)
            raise SessionCrashed(f"session {self.id}: its worker is gone", field="id") from None
        if not p.event.wait(timeout):
            with self._pending_lock:
                self._pending.pop(rid, None)
            raise SessionError(f"session {self.id}: its worker did not answer {op} within {timeout:.0f} s",
                               field="id")  # fmt: skip
        if p.error is not None:
            cls, message, fld = p.error
            raise _ERRORS.get(cls, SessionError)(message, field=fld)
        return p.value

    # ---- lifecycle ----------------------------------------------------------------------------------------------
    def start(self) -> None:
        self._started = True
        self._call("start")

    def stop(self, timeout: float = STOP_GRACE_S) -> None:
        """Ends the worker (asked to, then terminated) and reaps it; returns when it is gone."""
        self._stopping = True
        proc = getattr(self, "_proc", None)
        if proc is not None:
            with contextlib.suppress(OSError, ValueError), self._send_lock:
                self._conn.send(("close", 0, ()))
            self._reap(proc)
            with contextlib.suppress(OSError):
                self._conn.close()
            reader = getattr(self, "_reader", None)
            if reader is not None and reader is not threading.current_thread():
                reader.join(timeout)
        self.status = "stopped"

    @property
    def alive(self) -> bool:
        proc = getattr(self, "_proc", None)
        return proc is not None and proc.is_alive() and not self._stopping

    # ---- commands -----------------------------------------------------------------------------------------------
    def start_maneuver(self, maneuver: Any) -> None:
        self._revive()
        self._call("start_maneuver", maneuver, timeout=REPLACE_TIMEOUT_S)

    def restart(self) -> None:
        if self._dead is not None:
            self.start_maneuver(self.sim.maneuver)
            return
        self._call("restart", timeout=REPLACE_TIMEOUT_S)

    def reset(self, terrain: str | None = None, maps: str | None = None, robot: str | None = None) -> None:
        if self._revive(terrain, maps, robot):
            return
        self._call("reset", terrain, maps, robot, timeout=REPLACE_TIMEOUT_S)
        self.robot = robot or self.robot

    def _revive(self, terrain: str | None = None, maps: str | None = None, robot: str | None = None) -> bool:
        """A session whose worker died gets a new one (at the start, as a reset); returns whether it did."""
        if self._dead is None:
            return False
        old = self._proc
        self.terrain = terrain or self.terrain
        self.maps = maps or self.maps
        self.robot = robot or self.robot
        self._generation_base = self.generation + 1  # the new worker's generations start again at 0
        self._spawn()
        self._reap(old)
        if self._started:
            self._call("start")
        return True

    def pause(self) -> None:
        self._call("pause")

    def resume(self) -> None:
        self._call("resume")

    def set_speed(self, speed: float) -> None:
        self._call("set_speed", float(speed))

    def push(self, force_n: tuple[float, float, float], duration_s: float) -> None:
        self._check_live()
        self._call("push", force_n, duration_s)

    def steer(self, vx: float, vy: float, yaw_rate: float, gait: str, weights: str | None = None) -> None:
        self._check_live()
        self._call("steer", vx, vy, yaw_rate, gait, weights, timeout=REPLACE_TIMEOUT_S)

    def plan(self) -> dict[str, Any]:
        self._check_live()
        return dict(self._call("plan"))

    def report(self) -> dict[str, Any]:
        if self._dead is not None:
            return {"success": False, "failure_reason": self._dead}
        return dict(self._call("report"))

    def _meta(self) -> dict[str, Any]:
        return {
            **self._meta_cache,
            "id": self.id,
            "origin": self.origin,
            "status": self.status,
            "error": self.error,
            "generation": self.generation,
        }
