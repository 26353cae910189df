"""Live simulated robots: one background thread per session stepping MuJoCo in real time, a cap, a reaper.

By default the manager runs each session in a worker process of its own (server.session_worker.ProcessSession: a
LiveSession in the child, the same API here); `Settings.session_workers = "thread"` keeps them in this process.

A session owns a `LiveSim` (server.engine) and steps it in batches paced to the wall clock (times its speed).
Readers never wait for the physics: after each batch the stepping thread publishes an immutable `Snapshot` (state
dict, body poses, plot sample) that the REST handlers and the studio read. Commands that replace the simulation
(start a maneuver, reset) build the new one in the caller's thread and swap it in under the session's lock.

An exception inside a session's step marks that session `crashed` with the reason in its state; the thread stays
alive so a reset can revive it, and nothing propagates to the server. Sessions nobody touched for
`Settings.session_idle_s` are ended by the reaper thread.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import gc
import json
import logging
import secrets
import threading
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Literal, Protocol

import numpy as np

from server.engine import LiveSim, NotSteerable, SteeringUnavailable, default_maneuver, walk_command
from server.settings import Settings

log = logging.getLogger("footfall.sessions")

Mode = Literal["steer", "maneuver"]
Status = Literal["running", "paused", "crashed", "stopped"]
MAX_LAG_S = 0.5  # a session further behind the wall clock than this drops the difference (and counts it), s
PUBLISH_PERIOD_S = 1.0 / 60.0  # snapshots for readers, s
MAX_BATCH_TICKS = 8  # physics ticks stepped between two looks at the clock (16 ms of simulated time)
FRAME_PERIOD_S = 1.0 / 30.0  # recorded body poses for the exported preview, s
MAX_FRAMES = 30 * 120  # two minutes of recording
PLOT_SAMPLES = 600  # ten seconds at 60 Hz


class Sim(Protocol):
    """What a session needs of a simulation (server.engine.LiveSim; tests pass a fake)."""

    maneuver: Any
    terrain: str
    dt: float

    @property
    def t(self) -> float: ...
    def step(self) -> None: ...
    def trim(self) -> None: ...
    def push(self, force_n: tuple[float, float, float], duration_s: float) -> None: ...
    def steer(self, vx: float, vy: float, yaw_rate: float, gait: str) -> None: ...
    def body_poses(self) -> tuple[np.ndarray, np.ndarray]: ...
    def reference(self) -> tuple[np.ndarray, np.ndarray] | None: ...
    def tick_ms(self) -> float | None: ...
    def state_dict(self) -> dict[str, Any]: ...
    def plan_dict(self) -> dict[str, Any]: ...
    def report(self, wall_s: float) -> dict[str, Any]: ...


SimFactory = Callable[[Any, str, str], Sim]  # (maneuver, terrain, robot) -> Sim


def _malloc_trim() -> Callable[[int], int] | None:
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")
        trim: Callable[[int], int] = libc.malloc_trim
    except (OSError, AttributeError):  # not glibc: nothing to trim
        return None
    return trim


_TRIM = _malloc_trim()


def release_memory() -> None:
    """Returns the memory of an ended session to the system: collects its cycles, then asks glibc's allocator to
    give back the free pages it keeps (MuJoCo's and numpy's freed buffers stay in its arenas otherwise: the server
    grew 2.5-3.8 MB per session before)."""
    gc.collect()
    if _TRIM is not None:
        _TRIM(0)


class SessionError(Exception):
    """A session request that cannot be served; `status` is the HTTP status, `field` what it is about."""

    status = 409

    def __init__(self, message: str, field: str = "") -> None:
        super().__init__(message)
        self.message = message
        self.field = field


class SessionNotFound(SessionError):
    status = 404


class SessionLimit(SessionError):
    status = 429


class SessionCrashed(SessionError):
    status = 409


class SessionBadInput(SessionError):
    status = 422


@dataclass(frozen=True)
class PlotSample:
    """One sample for the live plots: sim time s, controller compute ms, measured and reference velocities m/s."""

    t: float
    tick_ms: float
    v_body: tuple[float, float, float]
    v_ref: tuple[float, float, float]


@dataclass(frozen=True)
class Snapshot:
    """What readers see of a session; replaced as a whole after each batch of steps."""

    seq: int
    wall: float
    state: dict[str, Any]
    xpos: np.ndarray  # (nb,3) robot body positions, world, m
    xquat: np.ndarray  # (nb,4) robot body orientations, wxyz
    sim_json: str = "{}"  # the simulation's part of `state`, JSON-encoded once for every reader


@dataclass
class Recording:
    """Body poses sampled at 30 Hz since the current maneuver started (for the self-contained preview export)."""

    maneuver: str
    terrain: str
    t: deque[float] = field(default_factory=lambda: deque(maxlen=MAX_FRAMES))
    xpos: deque[np.ndarray] = field(default_factory=lambda: deque(maxlen=MAX_FRAMES))
    xquat: deque[np.ndarray] = field(default_factory=lambda: deque(maxlen=MAX_FRAMES))
    n: int = 0  # frames recorded in all (the deques keep the last MAX_FRAMES)


class LiveSession:
    """One simulated robot stepping in real time in its own thread."""

    def __init__(
        self,
        session_id: str,
        terrain: str,
        mode: Mode,
        robot: str,
        factory: SimFactory,
        origin: str = "api",
        clock: Callable[[], float] = time.monotonic,
        maps: str = "truth",
    ) -> None:
        self._init_fields(session_id, terrain, mode, robot, factory, origin, clock, maps)
        self.sim: Sim = factory(self._entry_spec(mode, maps=maps), terrain, robot)
        self.rtf = 1.0
        self.recording = Recording(self._maneuver_name(), terrain)
        self._stop = threading.Event()
        self._wake = threading.Event()
        self.snapshot = self._take_snapshot()
        self._thread = threading.Thread(target=self._run, name=f"footfall-session-{session_id}", daemon=True)

    def _init_fields(
        self,
        session_id: str,
        terrain: str,
        mode: Mode,
        robot: str,
        factory: SimFactory,
        origin: str,
        clock: Callable[[], float],
        maps: str,
    ) -> None:
        """The session's own fields, whichever design steps its simulation (a thread here, a worker process in
        `server.session_worker.ProcessSession`)."""
        self.id = session_id
        self.terrain = terrain
        self.mode: Mode = mode
        self.maps = maps  # a walk on a terrain plans on the scene's maps ("truth") or the depth sensor's
        self.robot = robot
        self.origin = origin
        self._factory = factory
        self._clock = clock
        self.created = clock()
        self.last_access = self.created
        self.lock = threading.RLock()  # guards self.sim (self.recording in a worker-process session)
        self.status: Status = "running"
        self.error: str | None = None
        self.speed = 1.0
        self.command: dict[str, Any] | None = None  # the last steering command
        self.dropped_s = 0.0  # simulated time skipped because the session fell behind the wall clock
        self.rtf = 0.0  # measured simulated seconds per wall second over the last ~2 s (while running)
        self.steps = 0
        self.generation = 0  # bumped whenever the simulation is replaced (studio rebuilds the terrain)
        self.recording = Recording("stand", terrain)
        self.plot: deque[PlotSample] = deque(maxlen=PLOT_SAMPLES)
        self.plot_n = 0  # plot samples taken in all
        self._seq = 0
        self._snap_cond = threading.Condition(threading.Lock())  # notified at each new snapshot
        self.poses = 0  # snapshots published with the bodies moved (what a viewer can draw), in all

    @property
    def snapshot(self) -> Snapshot:
        """The latest published state (immutable; replaced whole at each publish)."""
        return self._snapshot

    @snapshot.setter
    def snapshot(self, snap: Snapshot) -> None:
        with self._snap_cond:
            old = self.__dict__.get("_snapshot")
            if old is None or old.xpos.shape != snap.xpos.shape or not np.array_equal(old.xpos, snap.xpos):
                self.poses += 1  # a snapshot with the bodies somewhere new (not a status-only update)
            self._snapshot = snap
            self._snap_cond.notify_all()

    def wait_snapshot(self, seq: int, timeout_s: float) -> None:
        """Returns once the snapshot's seq differs from `seq`, or after timeout_s (a reader's pacing: it wakes at
        each publish instead of polling)."""
        with self._snap_cond:
            if self._snapshot.seq == seq:
                self._snap_cond.wait(timeout_s)

    # ---- lifecycle ----------------------------------------------------------------------------------------------
    def start(self) -> None:
        self._thread.start()

    def stop(self, timeout: float = 2.0) -> None:
        self._stop.set()
        self._wake.set()
        if self._thread.is_alive() and threading.current_thread() is not self._thread:
            self._thread.join(timeout)
        self.status = "stopped"

    def touch(self) -> None:
        self.last_access = self._clock()

    @property
    def alive(self) -> bool:
        return self._thread.is_alive()

    @staticmethod
    def _entry_spec(mode: Mode, gait: str = "trot", maps: str = "truth") -> Any:
        """What a session starts (or resets) with: standing for maneuvers, a zero command for steering."""
        if mode == "steer":
            try:
                return walk_command(gait=gait, maps=maps)
            except (SteeringUnavailable, ValueError):
                pass  # no steering in this build: stand, and /steer answers 409
        return default_maneuver("stand")

    def _maneuver_name(self) -> str:
        return str(getattr(self.sim.maneuver, "name", "stand"))

    # ---- the stepping thread ------------------------------------------------------------------------------------
    def _run(self) -> None:
        last = time.perf_counter()
        owed = 0.0  # simulated seconds owed to the wall clock
        next_publish = last
        next_frame_t = 0.0
        window: deque[tuple[float, float]] = deque(maxlen=240)  # (wall, sim) for the measured rtf
        generation = self.generation
        while not self._stop.is_set():
            now = time.perf_counter()
            if generation != self.generation:  # a new simulation: its clock starts again at 0
                generation = self.generation
                window.clear()
                next_frame_t = 0.0
            elapsed, last = now - last, now
            running = self.status == "running"
            if running:
                owed += elapsed * self.speed
                if owed > MAX_LAG_S:
                    self.dropped_s += owed - MAX_LAG_S
                    owed = MAX_LAG_S
                with self.lock:
                    sim = self.sim
                    # Small batches, so readers get fresh snapshots at ~60 Hz even while the session catches up.
                    n = min(int(owed / sim.dt), MAX_BATCH_TICKS)
                    try:
                        for _ in range(n):
                            sim.step()
                        self.steps += n
                        owed -= n * sim.dt
                        if self.steps % 5000 < n:
                            sim.trim()
                    except Exception as e:  # noqa: BLE001 - a crash ends this session's stepping, not the server
                        self._crash(e)
                        continue
                    t_sim = sim.t
                    if t_sim + 1e-9 >= next_frame_t:
                        next_frame_t = t_sim + FRAME_PERIOD_S
                        xpos, xquat = sim.body_poses()
                        rec = self.recording
                        rec.t.append(t_sim)
                        rec.xpos.append(xpos)
                        rec.xquat.append(xquat)
                        rec.n += 1
                window.append((now, t_sim))
                if len(window) > 1 and window[-1][0] - window[0][0] > 0.5:
                    dw = window[-1][0] - window[0][0]
                    self.rtf = max(0.0, (window[-1][1] - window[0][1]) / dw)
            else:
                window.clear()
                owed = 0.0
            if now >= next_publish or not running:
                # on a fixed schedule (not `now + period`): the loop wakes every ~8 ms, and restarting the period at
                # each publish rounded it up to 24 ms (~42 snapshots/s instead of 60)
                next_publish = max(next_publish + PUBLISH_PERIOD_S, now - PUBLISH_PERIOD_S)
                try:
                    with self.lock:
                        self.snapshot = self._take_snapshot()
                        if running:
                            self._sample_plot()
                except Exception as e:  # noqa: BLE001
                    self._crash(e)
            # Sleep to the next batch (~4 ticks of 2 ms; none while catching up), or idle when paused or crashed
            # (woken by commands).
            if running:
                if owed < self.sim.dt:
                    time.sleep(max(0.0, 0.008 - (time.perf_counter() - now)))
                else:
                    time.sleep(0)  # let readers and other sessions in
            else:
                self._wake.wait(0.1)
                self._wake.clear()
                last = time.perf_counter()

    def _crash(self, e: BaseException) -> None:
        self.status = "crashed"
        self.error = f"{type(e).__name__}: {e}"[:500]
        log.warning("session %s crashed: %s", self.id, self.error)
        try:
            self.snapshot = self._take_snapshot()
        except Exception:  # noqa: BLE001 - the snapshot keeps its last good value, the error is in meta
            self.snapshot = Snapshot(
                self._seq + 1, time.time(), {**self.snapshot.state, **self._meta()}, self.snapshot.xpos,
                self.snapshot.xquat,
            )  # fmt: skip

    def _meta(self) -> dict[str, Any]:
        m = self.sim.maneuver
        duration = float(getattr(m, "duration", 0.0) or 0.0)
        return {
            "id": self.id,
            "status": self.status,
            "error": self.error,
            "mode": self.mode,
            "terrain": self.terrain,
            "robot": self.robot,
            "origin": self.origin,
            "maneuver": self._maneuver_name(),
            "maneuver_duration": duration,
            "done": duration > 0 and self.sim.t >= duration,
            "speed": self.speed,
            "realtime_factor": round(self.rtf, 3),
            "dropped_s": round(self.dropped_s, 3),
            "command": self.command,
            "maps": self.maps,
            "generation": self.generation,
        }

    def _take_snapshot(self) -> Snapshot:
        self._seq += 1
        xpos, xquat = self.sim.body_poses()
        sim_state = self.sim.state_dict()
        state = {**sim_state, **self._meta()}
        return Snapshot(self._seq, time.time(), state, xpos, xquat, json.dumps(sim_state, allow_nan=False))

    def _sample_plot(self) -> None:
        st = self.snapshot.state
        v = st.get("body", {}).get("velocity", [0.0, 0.0, 0.0])
        ref = self.sim.reference()
        v_ref = (0.0, 0.0, 0.0) if ref is None else (float(ref[1][0]), float(ref[1][1]), float(ref[1][2]))
        if self.command is not None:
            v_ref = (self.command["vx"], self.command["vy"], 0.0)
        tick = self.sim.tick_ms()
        self.plot.append(PlotSample(self.sim.t, float(tick or 0.0), (v[0], v[1], v[2]), v_ref))
        self.plot_n += 1

    # ---- commands (from REST handlers and the studio) -----------------------------------------------------------
    def _replace(self, maneuver: Any, terrain: str | None = None, robot: str | None = None) -> None:
        terrain = terrain or self.terrain
        robot = robot or self.robot
        try:
            sim = self._factory(maneuver, terrain, robot)  # built outside the lock: MuJoCo compile takes ms
        except Exception as e:  # noqa: BLE001 - the session keeps running what it ran before
            log.warning("session %s: cannot start %s: %r", self.id, getattr(maneuver, "name", "?"), e)
            raise SessionError(
                f"could not start {getattr(maneuver, 'name', 'the maneuver')}: {type(e).__name__}: {e}"[:500],
                field="maneuver",
            ) from None
        with self.lock:
            self.sim = sim
            self.terrain = terrain
            self.robot = robot
            self.status = "running" if self.status != "paused" else "paused"
            self.error = None
            self.generation += 1
            self.recording = Recording(self._maneuver_name(), terrain)
            self.plot.clear()
            self.snapshot = self._take_snapshot()
        self._wake.set()

    def start_maneuver(self, maneuver: Any) -> None:
        """Resets the robot to its stance at the origin and starts `maneuver` (validated by the caller)."""
        self.mode = "maneuver"
        self.command = None
        self._replace(maneuver)
        if self.status == "paused":
            self.resume()

    def restart(self) -> None:
        """Starts the current maneuver again from the stance."""
        self._replace(self.sim.maneuver)

    def reset(self, terrain: str | None = None, maps: str | None = None, robot: str | None = None) -> None:
        """Back to the start at the origin (optionally on another terrain, another robot (what the simulation
        loads: a shipped name or a path), or planning a walk on other maps: "truth" or "sensor"): standing, or in
        steer mode walking with a zero command; clears a crash."""
        if maps is not None:
            self.maps = maps
        gait = str(self.command["gait"]) if self.command else "trot"
        self.command = None
        self.status = "running"
        self._replace(self._entry_spec(self.mode, gait, self.maps), terrain, robot)

    def pause(self) -> None:
        """Stops stepping; when this returns, no batch is in flight and the state is the paused one."""
        if self.status == "running":
            self.status = "paused"
        with self.lock:  # waits out a batch in flight
            self.snapshot = self._take_snapshot()
        self._wake.set()

    def resume(self) -> None:
        if self.status == "paused":
            self.status = "running"
        self._wake.set()

    def set_speed(self, speed: float) -> None:
        self.speed = float(speed)

    def _check_live(self) -> None:
        if self.status == "crashed":
            raise SessionCrashed(f"session {self.id} crashed ({self.error}); reset it first", field="id")

    def push(self, force_n: tuple[float, float, float], duration_s: float) -> None:
        """Pushes the body's center of mass with force_n (N, world frame) for duration_s from now."""
        self._check_live()
        with self.lock:
            self.sim.push(force_n, duration_s)

    def steer(self, vx: float, vy: float, yaw_rate: float, gait: str, weights: str | None = None) -> None:
        """Sets the velocity command (m/s, m/s, rad/s), gait and (optionally) the step-selection weight preset. A
        session running a maneuver switches to walking (from the stance at the origin). SessionError 409 when the
        build has no steering, 422 for a bad gait."""
        self._check_live()
        switch = False
        try:
            with self.lock:
                self.sim.steer(vx, vy, yaw_rate, gait)
        except SteeringUnavailable as e:
            raise SessionError(str(e), field="steer") from None
        except NotSteerable:
            switch = True
        except ValueError as e:
            raise SessionBadInput(str(e).removeprefix("gait: "), field="gait") from None
        if switch:
            try:
                spec = walk_command(vx, vy, yaw_rate, gait, self.maps)
            except SteeringUnavailable as e:
                raise SessionError(str(e), field="steer") from None
            except ValueError as e:
                raise SessionBadInput(str(e).removeprefix("gait: "), field="gait") from None
            self._replace(spec)
            self.resume()
        if weights is not None:
            with self.lock:
                set_weights = getattr(self.sim, "set_weights", None)
                if callable(set_weights):
                    set_weights(weights)
        self.mode = "steer"
        self.command = {"vx": vx, "vy": vy, "yaw_rate": yaw_rate, "gait": gait}
        if weights is not None:
            self.command["weights"] = weights

    def state(self) -> dict[str, Any]:
        """Returns the latest published state with the session's status as of now (never waits for the physics)."""
        return {**self.snapshot.state, **self._meta(), "t": self.snapshot.state.get("t")}

    def state_json(self) -> str:
        """Returns state() as JSON text, cheaply: the simulation's part was encoded once when published."""
        sim_json = self.snapshot.sim_json
        meta = json.dumps(self._meta(), allow_nan=False)
        if sim_json == "{}" or len(sim_json) < 2:
            return meta
        return sim_json[:-1] + ", " + meta[1:]

    def plan(self) -> dict[str, Any]:
        """Returns the current plan overlays (briefly takes the lock: the arrays are live)."""
        self._check_live()
        with self.lock:
            return self.sim.plan_dict()

    def report(self) -> dict[str, Any]:
        with self.lock:
            return self.sim.report(max(1e-9, self._clock() - self.created))

    def summary(self) -> dict[str, Any]:
        st = self.snapshot.state
        return {
            k: st.get(k) for k in ("id", "status", "mode", "terrain", "maneuver", "origin", "t", "fell")
        } | {"idle_s": round(self._clock() - self.last_access, 1)}


class SessionManager:
    """Creates, finds, caps and reaps live sessions."""

    def __init__(
        self,
        settings: Settings,
        factory: SimFactory | None = None,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self.settings = settings
        self.factory: SimFactory = factory or LiveSim
        # each session in a worker process of its own (server.session_worker), or a thread of this process; "auto":
        # processes for the real simulation, threads for a fake one a test injects (and may inspect in place)
        w = settings.session_workers
        self.processes = w == "process" or (w == "auto" and factory is None)
        self.clock = clock
        self._sessions: dict[str, LiveSession] = {}
        self._reserved = 0
        self._reserved_studio = 0  # of those, sessions a studio tab is starting
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._reaper: threading.Thread | None = None

    def start(self) -> None:
        """Starts the reaper thread."""
        if self._reaper is None:
            self._reaper = threading.Thread(target=self._reap_loop, name="footfall-reaper", daemon=True)
            self._reaper.start()

    @property
    def studio_cap(self) -> int:
        """Sessions the studio's tabs may hold at once: all but one (kept for the API) when there are two or more."""
        n = self.settings.max_sessions
        return n - 1 if n >= 2 else n

    def shutdown(self) -> None:
        self._stop.set()
        for s in self.list_sessions():
            s.stop()
        with self._lock:
            self._sessions.clear()

    def create(
        self,
        terrain: str,
        mode: Mode = "maneuver",
        origin: str = "api",
        maps: str = "truth",
        robot: str | None = None,
    ) -> LiveSession:
        """Returns a new running session (on `robot`, what the simulation loads; default the server's robot);
        SessionLimit when the cap is reached."""
        with self._lock:
            # sessions being started count too: two tabs opening at once must not both take the studio's last slot
            studio = sum(1 for x in self._sessions.values() if x.origin == "studio") + self._reserved_studio
            if origin == "studio" and studio >= self.studio_cap:
                raise SessionLimit(
                    f"the studio's tabs have {studio} live robots, their share of the {self.settings.max_sessions} "
                    "sessions (one is kept for the API); close a tab, or raise FOOTFALL_MAX_SESSIONS",
                    field="sessions",
                )
            if len(self._sessions) + self._reserved >= self.settings.max_sessions:
                raise SessionLimit(
                    f"too many live sessions (the cap is {self.settings.max_sessions}); "
                    "delete one (DELETE /sessions/{id}) or wait for idle ones to be reaped",
                    field="sessions",
                )
            self._reserved += 1
            if origin == "studio":
                self._reserved_studio += 1
        try:
            sid = secrets.token_hex(8)
            cls = LiveSession
            if self.processes:
                from server.session_worker import ProcessSession

                cls = ProcessSession
            s = cls(sid, terrain, mode, robot or self.settings.robot, self.factory, origin, self.clock, maps)
            try:
                s.start()
            except BaseException:
                s.stop()
                raise
            with self._lock:
                self._sessions[sid] = s
        finally:
            with self._lock:
                self._reserved -= 1
                if origin == "studio":
                    self._reserved_studio -= 1
        log.info("session %s created (%s, %s, %s)", sid, terrain, mode, origin)
        return s

    def get(self, session_id: str, touch: bool = True) -> LiveSession:
        with self._lock:
            s = self._sessions.get(session_id)
        if s is None:
            raise SessionNotFound(
                f"no session {session_id[:40]!r} (ended, reaped or never created)", field="id"
            )
        if touch:
            s.touch()
        return s

    def delete(self, session_id: str) -> None:
        with self._lock:
            s = self._sessions.pop(session_id, None)
        if s is None:
            raise SessionNotFound(f"no session {session_id[:40]!r}", field="id")
        s.stop()
        del s
        release_memory()
        log.info("session %s ended", session_id)

    def list_sessions(self) -> list[LiveSession]:
        with self._lock:
            return list(self._sessions.values())

    def __len__(self) -> int:
        with self._lock:
            return len(self._sessions)

    def reap(self) -> list[str]:
        """Ends sessions idle longer than the limit; returns their ids."""
        now = self.clock()
        with self._lock:
            idle = [
                sid for sid, s in self._sessions.items() if now - s.last_access > self.settings.session_idle_s
            ]
            gone = [self._sessions.pop(sid) for sid in idle]
        for s in gone:
            s.stop()
            log.info("session %s reaped after %.0f s idle", s.id, now - s.last_access)
        return idle

    def _reap_loop(self) -> None:
        while not self._stop.wait(self.settings.reaper_period_s):
            try:
                if self.reap():
                    release_memory()
            except Exception:  # noqa: BLE001 - the reaper must outlive any one bad session
                log.exception("reaper")
